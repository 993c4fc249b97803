"""The `cameras:` block of a config (kind: v4l2) -> camera settings, a trigger, and the pair source.

```
cameras:
  kind: v4l2
  left:  {device: /dev/mast/cam-left, subdevice: /dev/mast/cam-left-sensor}   # subdevice optional
  right: {device: /dev/mast/cam-right}
  width: 2048
  height: 1536
  pixel_format: GREY          # GREY | Y16 | YUYV | MJPEG
  fps: null                   # null: the trigger sets the rate (no S_PARM)
  exposure: auto | {control: NAME, value: V, mode_control: NAME, mode_value: V}
  gain: auto | {control: NAME, value: V}
  controls: {NAME: VALUE}     # any other controls, both cameras
  buffers: 4
  skip_frames: 0
  max_skew_ms: 5              # pairing tolerance on the offset-corrected skew (default: half a period)
  trigger: {kind: controls | gpio | external | none, ...}   # drivers/trigger/config.py
```
`auto` writes nothing: the camera keeps its own (automatic) setting. A mode
control is written before its value (manual exposure first, then the time).
Per-camera keys in left/right (device, subdevice, input, controls) override
the shared ones. Worked examples: config/cameras/*.yaml. Unknown keys are
refused by name. The edge config layer will embed this block; this module only
turns it into driver objects.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from drivers.camera.v4l2 import CameraSettings
from drivers.camera.v4l2_convert import pixel_format
from drivers.camera.v4l2_pair import V4L2PairSource
from drivers.trigger.base import Trigger
from drivers.trigger.config import trigger_from_config

SHARED = {
    "kind",
    "left",
    "right",
    "width",
    "height",
    "pixel_format",
    "fps",
    "exposure",
    "gain",
    "controls",
    "buffers",
    "skip_frames",
    "max_skew_ms",
    "trigger",
}
PER_CAMERA = {"device", "subdevice", "input", "controls"}


class CamerasConfigError(ValueError):
    """A mistake in the `cameras:` block: which key (e.g. "cameras.left") and what is wrong with it."""

    def __init__(self, key: str, problem: str, sep: str = ": ") -> None:
        super().__init__(f"{key}{sep}{problem}")
        self.key, self.problem = key, problem


@dataclass(frozen=True)
class CamerasConfig:
    left: CameraSettings
    right: CameraSettings
    trigger: Trigger
    max_skew_ns: int | None

    def source(self, **kwargs) -> V4L2PairSource:
        """The pair source (kwargs go to V4L2PairSource: backoff_s, read_timeout_s, open_camera, ...)."""
        return V4L2PairSource(self.left, self.right, self.trigger, max_skew_ns=self.max_skew_ns, **kwargs)


def _setting_controls(name: str, spec: object) -> dict[str, object]:
    if spec is None or spec == "auto":
        return {}
    if not isinstance(spec, Mapping) or "control" not in spec or "value" not in spec:
        raise CamerasConfigError(f"cameras.{name}",
                                 "'auto' or {control: NAME, value: V[, mode_control, mode_value]}")
    unknown = set(spec) - {"control", "value", "mode_control", "mode_value"}
    if unknown:
        raise CamerasConfigError(f"cameras.{name}", f"unknown key(s) {', '.join(sorted(unknown))}")
    out: dict[str, object] = {}
    if "mode_control" in spec:
        out[str(spec["mode_control"])] = spec["mode_value"]
    out[str(spec["control"])] = spec["value"]
    return out


def cameras_from_config(block: Mapping) -> CamerasConfig:
    """Validate a `cameras:` block of kind v4l2 and build its settings and trigger."""
    if block.get("kind") != "v4l2":
        raise CamerasConfigError("cameras.kind", f"must be v4l2 here, not {block.get('kind')!r}", " ")
    unknown = set(block) - SHARED
    if unknown:
        raise CamerasConfigError("cameras", f"unknown key(s) {', '.join(sorted(unknown))}")
    for key in ("left", "right", "width", "height"):
        if key not in block:
            raise CamerasConfigError(f"cameras.{key}", "is required")
    try:
        fmt = pixel_format(str(block.get("pixel_format", "GREY"))).name
    except ValueError as exc:
        raise CamerasConfigError("cameras.pixel_format", str(exc)) from None
    fps = block.get("fps")
    shared_controls = {
        **_setting_controls("exposure", block.get("exposure")),
        **_setting_controls("gain", block.get("gain")),
        **dict(block.get("controls") or {}),
    }
    sides = []
    for side in ("left", "right"):
        cam = block[side]
        if not isinstance(cam, Mapping) or "device" not in cam:
            raise CamerasConfigError(f"cameras.{side}",
                                     f"needs a device (a udev name like /dev/mast/cam-{side})", " ")
        extra = set(cam) - PER_CAMERA
        if extra:
            raise CamerasConfigError(f"cameras.{side}", f"unknown key(s) {', '.join(sorted(extra))}")
        sides.append(
            CameraSettings(
                device=str(cam["device"]),
                width=int(block["width"]),
                height=int(block["height"]),
                pixel_format=fmt,
                fps=None if fps is None else float(fps),
                buffers=int(block.get("buffers", 4)),
                input=cam.get("input"),
                controls={**shared_controls, **dict(cam.get("controls") or {})},
                subdevice=cam.get("subdevice"),
                skip_frames=int(block.get("skip_frames", 0)),
            )
        )
    try:
        trigger = trigger_from_config(block.get("trigger"), fps=fps)
    except ValueError as exc:  # the trigger's own checks, and its camera-control preset's
        raise CamerasConfigError("cameras.trigger", str(exc)) from None
    skew_ms = block.get("max_skew_ms")
    return CamerasConfig(
        sides[0], sides[1], trigger, None if skew_ms is None else round(float(skew_ms) * 1e6)
    )
