"""The `masks:` block of the configuration: exclusion zones where no ship is detected or born.

    masks:
      image:                      # raw left-image pixels (u right, v down; (0, 0): top-left pixel's centre)
        - name: mast and railing
          polygon: [[0, 430], [719, 430], [719, 479], [0, 479]]
      geo:                        # on the sea surface, WGS-84 [lat_deg, lon_deg]
        - name: north pier
          polygon: [[34.6290, 135.0180], [34.6290, 135.0195], [34.6270, 135.0195], [34.6270, 135.0180]]

Every polygon is checked when the file loads (`ConfigError`, exit 78, naming the key down to the
vertex, e.g. ``masks.geo[0].polygon[2]``): at least 3 vertices of 2 finite numbers, latitude in
[-90, 90] and longitude in [-180, 180], not self-intersecting (`edge.core.masks.polygon_problem`).
Image vertices must lie in the left image, which needs its size: `check_image_polygons` runs as soon
as the calibration is known (at load with a calibration in the file, else when the source is planned).
`build_search_mask` turns the block into the pipeline's boolean search mask (True: may detect).
docs/site-masks.md is the operator's page.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from edge.config.schema import setting
from edge.core.camera import StereoRig
from edge.core.geodesy import geodetic_to_world
from edge.core.masks import polygon_problem, sea_pixel_grid, search_mask
from edge.core.site import Site
from edge.errors import ConfigError

_POLYGON = "a list of at least 3 vertices, each a list of 2 numbers"


def _vertices(data: Any, file: Any, key: str, names: tuple[str, str]) -> tuple[tuple[float, float], ...]:
    """A polygon's vertices as numbers, or a ConfigError naming the vertex."""
    if not isinstance(data, list | tuple):
        raise ConfigError(file, key, _POLYGON, data if not isinstance(data, dict) else "a mapping")
    out = []
    for i, vertex in enumerate(data):
        ok = isinstance(vertex, list | tuple) and len(vertex) == 2 and all(
            isinstance(c, int | float) and not isinstance(c, bool) and math.isfinite(c) for c in vertex)
        if not ok:
            raise ConfigError(file, f"{key}[{i}]", f"a vertex [{names[0]}, {names[1]}] of 2 finite numbers",
                              vertex)
        out.append((float(vertex[0]), float(vertex[1])))
    if len(out) < 3:
        raise ConfigError(file, key, "at least 3 vertices (a polygon)", data)
    return tuple(out)


def _check_shape(vertices: tuple[tuple[float, float], ...], file: Any, key: str) -> None:
    problem = polygon_problem(np.array(vertices))
    if problem is not None:
        index, expected = problem
        raise ConfigError(file, f"{key}[{index}]", expected, list(vertices[index]))


def load_image_polygon(data: Any, file: Any, key: str) -> tuple[tuple[float, float], ...]:
    """`masks.image[k].polygon`: [u, v] raw left-image pixel vertices, a simple polygon."""
    vertices = _vertices(data, file, key, ("u", "v"))
    _check_shape(vertices, file, key)
    return vertices


def load_geo_polygon(data: Any, file: Any, key: str) -> tuple[tuple[float, float], ...]:
    """`masks.geo[k].polygon`: [lat_deg, lon_deg] WGS-84 vertices, a simple polygon."""
    vertices = _vertices(data, file, key, ("lat_deg", "lon_deg"))
    for i, (lat, lon) in enumerate(vertices):
        if not -90.0 <= lat <= 90.0:
            raise ConfigError(file, f"{key}[{i}]", "a latitude in [-90, 90] degrees first", [lat, lon])
        if not -180.0 <= lon <= 180.0:
            raise ConfigError(file, f"{key}[{i}]", "a longitude in [-180, 180] degrees second", [lat, lon])
    # the shape is judged on a plane (longitude scaled by cos(latitude)), as the sea is cast
    mean_lat = math.radians(sum(v[0] for v in vertices) / len(vertices))
    plane = tuple((lon * math.cos(mean_lat), lat) for lat, lon in vertices)
    problem = polygon_problem(np.array(plane))
    if problem is not None:
        index, expected = problem
        raise ConfigError(file, f"{key}[{index}]", expected, list(vertices[index]))
    return vertices


@dataclass(frozen=True)
class ImageMask:
    polygon: tuple[tuple[float, float], ...] = setting(
        load=load_image_polygon, accepts="a list of at least 3 [u, v] vertices",
        doc="left-image pixels (u right, v down), a simple polygon inside the image")
    name: str = setting("", doc="what it hides (shown by `mast-stereo masks`)")


@dataclass(frozen=True)
class GeoMask:
    polygon: tuple[tuple[float, float], ...] = setting(
        load=load_geo_polygon, accepts="a list of at least 3 [lat_deg, lon_deg] vertices",
        doc="WGS-84 latitude/longitude on the sea surface, a simple polygon")
    name: str = setting("", doc="what it hides (land, a pier, an anchorage)")


@dataclass(frozen=True)
class MasksConfig:
    image: tuple[ImageMask, ...] = setting((), doc="exclusion polygons in the left image")
    geo: tuple[GeoMask, ...] = setting((), doc="exclusion polygons on the sea by latitude/longitude")

    @property
    def empty(self) -> bool:
        return not self.image and not self.geo


def check_image_polygons(masks: MasksConfig, width: int, height: int, file: str | Path | None) -> None:
    """Every image vertex inside the width x height left image (its outer edge: -0.5 .. size - 0.5)."""
    for k, m in enumerate(masks.image):
        for i, (u, v) in enumerate(m.polygon):
            if not (-0.5 <= u <= width - 0.5 and -0.5 <= v <= height - 0.5):
                raise ConfigError(file, f"masks.image[{k}].polygon[{i}]",
                                  f"a vertex inside the {width}x{height} left image "
                                  f"(u in [-0.5, {width - 0.5}], v in [-0.5, {height - 0.5}])", [u, v])


def sea_grid(rig: StereoRig, site: Site) -> np.ndarray:
    """Every raw left pixel's sea point, world (X, Z) m (NaN: no sea), `edge.core.masks.sea_pixel_grid`."""
    return sea_pixel_grid(rig.left, -0.5 * rig.baseline_m, rig.width, rig.height, site.height_m)


def geo_polygons_xz(masks: MasksConfig, site: Site) -> list[np.ndarray]:
    """The geo polygons' vertices at sea level in the rig's world frame, (n, 2) X, Z metres each."""
    out = []
    for m in masks.geo:
        lat, lon = np.array(m.polygon).T
        world = geodetic_to_world(lat, lon, np.zeros_like(lat), site)
        out.append(world[:, [0, 2]])
    return out


def build_search_mask(masks: MasksConfig, rig: StereoRig, site: Site | None, file: str | Path | None,
                      sea_xz: np.ndarray | None = None) -> np.ndarray | None:
    """The pipeline's search mask for this rig and site (None: no masks configured); ConfigError
    for an image vertex outside the image or geo polygons without a site."""
    if masks.empty:
        return None
    check_image_polygons(masks, rig.width, rig.height, file)
    if masks.geo and site is None:
        raise ConfigError(file, "masks.geo", "a site (lat_deg, lon_deg, height_m, heading_deg) to place it")
    if masks.geo and sea_xz is None:
        assert site is not None
        sea_xz = sea_grid(rig, site)
    polygons = geo_polygons_xz(masks, site) if site is not None and masks.geo else []
    return search_mask(rig.width, rig.height, [np.array(m.polygon) for m in masks.image], polygons, sea_xz)
