"""The calibration file (docs/calibration.md): YAML <-> `Calibration` (a `StereoRig` plus an optional `Site`).

```
baseline_m: 8.14
image: {width: 720, height: 480}
cameras:
  left:  {model: pinhole, fx: .., fy: .., cx: .., cy: .., dist: [k1, k2, p1, p2, k3],
          rotation_deg: [rx, ry, rz]}
  right: {model: poly10, cx: .., cy: .., coeffs: [a0, .., a9], rotation_deg: [rx, ry, rz]}
site: {lat_deg: .., lon_deg: .., height_m: .., heading_deg: ..}     # optional
```

Optional (files without them load unchanged): each camera's `rotation_sigma_deg:
[s_rx, s_ry, s_rz]` and `focal_sigma_px` (the fit's standard errors, written by `mast-stereo
calibrate`; both cameras or neither, both keys of a camera or neither), and the site's
`tilt_sigma_deg` (a 1-sigma bound on the mast's lean, per horizontal axis). They become the
fixes' calibration share of sigma (edge.core.calibsigma).

Besides types and unknown keys (edge.config.schema), a calibration is checked for
what would silently give wrong positions: a positive baseline and focal
lengths (fx, fy; a0, a5 for poly10), a principal point inside the image, and
a lens model that can be inverted over the whole image (a distortion that
folds over inside the image maps two pixels to one ray). Every error names
the file and the key, e.g. ``cameras.right.coeffs[0]``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from edge.config.schema import load_dataclass, load_yaml, setting
from edge.core.calibsigma import CameraSigma, RigSigma
from edge.core.camera import CameraModel, PinholeCamera, Poly10Camera, StereoRig
from edge.core.site import Site
from edge.errors import ConfigError

ROUND_TRIP_TOL_PX = 1e-6  # pixel -> ray -> pixel over a grid of the image


@dataclass(frozen=True)
class Calibration:
    """A calibrated rig and, if the file gives one, where it stands."""

    rig: StereoRig
    site: Site | None = None
    sigma: RigSigma | None = None  # the fit's standard errors (None: an older or hand-written file)


# ---------------------------------------------------------------- file schema


@dataclass(frozen=True)
class SiteSchema:
    lat_deg: float = setting(doc="WGS-84 latitude of the baseline midpoint", min=-90.0, max=90.0)
    lon_deg: float = setting(doc="WGS-84 longitude", min=-180.0, max=180.0)
    height_m: float = setting(
        doc="height of the baseline midpoint above mean sea level", min=-500.0, max=9000.0
    )
    heading_deg: float = setting(doc="true azimuth of the optical axis (world +Z)", min=0.0, max=360.0)
    tilt_sigma_deg: float | None = setting(
        None, min=0.0, max=5.0,
        doc="1-sigma bound on the mast's lean (each horizontal axis) since calibration, degrees; null: "
        "none given (with calibration standard errors: 0; without them the 0.5 px row figure stands)")
    geoid_separation_m: float | None = setting(
        None, min=-110.0, max=90.0,
        doc="geoid height N above the WGS-84 ellipsoid at the site, m (a GNSS receiver's GGA geoid "
        "separation); only ASTERIX I034/120 uses it (ellipsoidal height = height_m + N); null: not given, "
        "I034/120 then carries height_m")


@dataclass(frozen=True)
class _Image:
    width: int = setting(doc="image width in pixels", min=1, max=65535)
    height: int = setting(doc="image height in pixels", min=1, max=65535)


_ROT = "rotation (rx, ry, rz) in degrees, R = Rz Ry Rx, camera to world"


@dataclass(frozen=True)
class _Pinhole:
    model: Literal["pinhole"]
    fx: float = setting(positive=True, doc="focal length in pixels, horizontal")
    fy: float = setting(positive=True, doc="focal length in pixels, vertical")
    cx: float = setting(doc="principal point, pixels")
    cy: float = setting(doc="principal point, pixels")
    dist: tuple[float, float, float, float, float] = setting(doc="OpenCV k1, k2, p1, p2, k3")
    rotation_deg: tuple[float, float, float] = setting(doc=_ROT)
    rotation_sigma_deg: tuple[float, float, float] | None = setting(
        None, min=0.0, max=10.0, doc="standard errors of rx, ry, rz (deg), from `mast-stereo calibrate`")
    focal_sigma_px: float | None = setting(
        None, min=0.0, doc="standard error of the focal length (px), from `mast-stereo calibrate`")


@dataclass(frozen=True)
class _Poly10:
    model: Literal["poly10"]
    cx: float = setting(doc="pixel origin of eq. 3.5 (principal point)")
    cy: float = setting(doc="pixel origin of eq. 3.5 (principal point)")
    coeffs: tuple[float, ...] = setting(min_items=10, max_items=10, doc="a0..a9 of eq. 3.5")
    rotation_deg: tuple[float, float, float] = setting(doc=_ROT)
    rotation_sigma_deg: tuple[float, float, float] | None = setting(
        None, min=0.0, max=10.0, doc="standard errors of rx, ry, rz (deg), from `mast-stereo calibrate`")
    focal_sigma_px: float | None = setting(
        None, min=0.0, doc="standard error of the focal length (px), from `mast-stereo calibrate`")


@dataclass(frozen=True)
class _Cameras:
    left: _Pinhole | _Poly10
    right: _Pinhole | _Poly10


@dataclass(frozen=True)
class _CalibrationFile:
    baseline_m: float = setting(positive=True, doc="distance between the camera centres, metres")
    image: _Image = setting()
    cameras: _Cameras = setting()
    site: SiteSchema | None = setting(None, doc="where the rig stands; optional")


# ---------------------------------------------------------------- dict -> Calibration


def site_from_dict(data: Any, file: str | Path | None, key: str = "site") -> Site:
    """A `Site` from a mapping with lat_deg, lon_deg, height_m, heading_deg (range-checked)."""
    return _site(load_dataclass(SiteSchema, data, file, key))


def _site(s: SiteSchema) -> Site:
    return Site(lat_deg=s.lat_deg, lon_deg=s.lon_deg, height_m=s.height_m, heading_deg=s.heading_deg % 360.0,
                tilt_sigma_deg=s.tilt_sigma_deg, geoid_separation_m=s.geoid_separation_m)


def _rig_sigma(cameras: _Cameras, file: Any, prefix: str) -> RigSigma | None:
    """The cameras' standard errors: both keys on both cameras, or on neither (an older file)."""
    given = {side: (getattr(cameras, side).rotation_sigma_deg, getattr(cameras, side).focal_sigma_px)
             for side in ("left", "right")}
    for side, (rot, foc) in given.items():
        if (rot is None) != (foc is None):
            missing = "focal_sigma_px" if foc is None else "rotation_sigma_deg"
            raise ConfigError(file, f"{prefix}cameras.{side}.{missing}",
                              "rotation_sigma_deg and focal_sigma_px together (the fit's standard errors), "
                              "or neither", "only the other one")
    if (given["left"][0] is None) != (given["right"][0] is None):
        side = "right" if given["right"][0] is None else "left"
        raise ConfigError(file, f"{prefix}cameras.{side}.rotation_sigma_deg",
                          "standard errors on both cameras or on neither", "them on the other camera only")
    if given["left"][0] is None:
        return None
    out = {}
    for side, (rot, foc) in given.items():
        assert rot is not None and foc is not None
        out[side] = CameraSigma((float(rot[0]), float(rot[1]), float(rot[2])), float(foc))
    return RigSigma(out["left"], out["right"])


def _camera(spec: _Pinhole | _Poly10, image: _Image, file: Any, key: str) -> CameraModel:
    for axis, size in (("cx", image.width), ("cy", image.height)):
        value = getattr(spec, axis)
        if not 0.0 <= value <= size - 1:
            raise ConfigError(
                file, f"{key}.{axis}", f"a principal point inside the image [0, {size - 1}]", value
            )
    if isinstance(spec, _Pinhole):
        camera: CameraModel = PinholeCamera(spec.fx, spec.fy, spec.cx, spec.cy, spec.dist, spec.rotation_deg)
    else:
        for index in (0, 5):
            if spec.coeffs[index] <= 0.0:
                raise ConfigError(
                    file,
                    f"{key}.coeffs[{index}]",
                    "a number > 0 (1 / focal length in px)",
                    spec.coeffs[index],
                )
        camera = Poly10Camera(spec.cx, spec.cy, spec.coeffs, spec.rotation_deg)
    _check_invertible(camera, image, file, key)
    return camera


def _check_invertible(camera: CameraModel, image: _Image, file: Any, key: str) -> None:
    """pixel -> ray -> pixel must come back over the whole image (no fold-over, no divergence)."""
    u, v = np.meshgrid(np.linspace(0.0, image.width - 1, 17), np.linspace(0.0, image.height - 1, 13))
    uv = np.stack([u.ravel(), v.ravel()], axis=-1)
    with np.errstate(all="ignore"):  # a wild model overflows: that is the finding, not a warning line
        back = camera.camera_to_pixel(camera.pixel_to_camera(uv))
        error = np.abs(back - uv).max(axis=-1)
    bad = ~(error <= ROUND_TRIP_TOL_PX)
    if bad.any():
        first = uv[np.argmax(bad)]
        raise ConfigError(
            file,
            key,
            "a lens model that is invertible over the whole image",
            f"no unique ray at pixel ({first[0]:.0f}, {first[1]:.0f}): check the signs "
            "and sizes of the distortion coefficients",
        )


def calibration_from_dict(data: Any, file: str | Path | None, key_prefix: str = "") -> Calibration:
    """Validate a calibration mapping (docs/calibration.md format) and build the rig; errors name the key."""
    spec = load_dataclass(_CalibrationFile, data, file, key_prefix)
    prefix = f"{key_prefix}." if key_prefix else ""
    left = _camera(spec.cameras.left, spec.image, file, f"{prefix}cameras.left")
    right = _camera(spec.cameras.right, spec.image, file, f"{prefix}cameras.right")
    rig = StereoRig(spec.baseline_m, spec.image.width, spec.image.height, left, right)
    return Calibration(rig=rig, site=None if spec.site is None else _site(spec.site),
                       sigma=_rig_sigma(spec.cameras, file, prefix))


def resolve_path(file: str | Path | None, path: str) -> Path:
    """`path` as written in `file`: absolute, or relative to the file's directory."""
    p = Path(path).expanduser()
    return p if p.is_absolute() or file is None else Path(file).resolve().parent / p


def calibration_ref(value: Any, file: str | Path | None, key: str) -> Calibration | None:
    """A `calibration:` entry of a config or scenario: null, a file path (relative to `file`), or inline."""
    if value is None:
        return None
    if isinstance(value, str):
        path = resolve_path(file, value)
        try:
            return load_calibration(path)
        except ConfigError as exc:
            if exc.key or path.is_file():  # a mistake inside the calibration file: that file is the news
                raise
            found = f"{path}: {exc.found}" if exc.found is not None else str(path)
            raise ConfigError(file, key, f"a calibration file ({exc.expected})", found) from None
    if isinstance(value, dict):
        return calibration_from_dict(value, file, key)
    raise ConfigError(file, key, "a calibration file path or an inline calibration mapping", value)


def optional_site(value: Any, file: str | Path | None, key: str) -> Site | None:
    """A `site:` entry that may be null."""
    return None if value is None else site_from_dict(value, file, key)


def load_calibration(path: str | Path) -> Calibration:
    """Read and validate a calibration YAML file."""
    return calibration_from_dict(load_yaml(path), path)


def site_to_dict(site: Site) -> dict[str, float]:
    out = {
        "lat_deg": float(site.lat_deg),
        "lon_deg": float(site.lon_deg),
        "height_m": float(site.height_m),
        "heading_deg": float(site.heading_deg),
    }
    if site.tilt_sigma_deg is not None:
        out["tilt_sigma_deg"] = float(site.tilt_sigma_deg)
    if site.geoid_separation_m is not None:
        out["geoid_separation_m"] = float(site.geoid_separation_m)
    return out


def calibration_to_dict(cal: Calibration) -> dict[str, Any]:
    """The docs/calibration.md mapping (plain Python floats and lists, ready for yaml.safe_dump)."""
    rig = cal.rig
    out: dict[str, Any] = {
        "baseline_m": float(rig.baseline_m),
        "image": {"width": int(rig.width), "height": int(rig.height)},
        "cameras": {"left": _plain(rig.left.to_dict()), "right": _plain(rig.right.to_dict())},
    }
    if cal.sigma is not None:
        for side in ("left", "right"):
            cam: CameraSigma = getattr(cal.sigma, side)
            out["cameras"][side]["rotation_sigma_deg"] = [float(a) for a in cam.rotation_sigma_deg]
            out["cameras"][side]["focal_sigma_px"] = float(cam.focal_sigma_px)
    if cal.site is not None:
        out["site"] = site_to_dict(cal.site)
    return out


def _plain(mapping: dict[str, Any]) -> dict[str, Any]:
    return {
        k: [float(x) for x in v] if isinstance(v, list | tuple) else v if isinstance(v, str) else float(v)
        for k, v in mapping.items()
    }


def recording_calibration(root: str | Path, meta: dict) -> Calibration:
    """The calibration (with its site) stored in a recording's meta.yaml."""
    meta_file = Path(root) / "meta.yaml"
    if "calibration" not in meta:
        raise ConfigError(meta_file, "calibration", "the recording's calibration mapping")
    cal = calibration_from_dict(meta["calibration"], meta_file, "calibration")
    if meta.get("site") is not None:
        cal = Calibration(cal.rig, site_from_dict(meta["site"], meta_file, "site"), cal.sigma)
    return cal
