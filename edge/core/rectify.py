"""Rectified views of a calibrated stereo pair, patch by patch: rows become epipolar lines.

The matcher (eq. 3.8) searches along a row of the right image, which is only
the epipolar line after rotation compensation and undistortion (eq. 3.9/3.10).
`Rectifier` defines one virtual pinhole camera per side with the same square
focal length f and principal point (cx, cy), looking along world +Z:

    rectified (u, v)  <->  normalised (x, y) = ((u - cx) / f, (v - cy) / f)

and each camera's model maps those normalised coordinates to its raw pixels.
Disparity in rectified pixels is then f (x_l - x_r), so Z = f L_B / d (eq. 2.12)
and eq. 4.1 applies to (u - cx) / f directly.

Whole images are never rectified per frame (that would cost milliseconds at
2048 x 1536). The two remap tables are computed once, in row chunks, and kept
in OpenCV's fixed-point form (CV_16SC2 + CV_16UC1, 6 bytes per pixel and side,
the same 1/32 px interpolation OpenCV applies to float maps internally);
`patch()` remaps only the few hundred pixels a track needs. When the rig is
already rectified (two identical pinholes, no distortion, no rotation) the
tables are skipped and a patch is a plain slice: bit-exact and free.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from edge.core import native
from edge.core.camera import CameraModel, PinholeCamera, StereoRig
from edge.core.prefilter import xsobel

MAP_CHUNK_ROWS = 64  # rows of the remap tables computed at a time (bounds the float64 temporaries)


def _is_ideal(camera: CameraModel, f: float, cx: float, cy: float) -> bool:
    return (isinstance(camera, PinholeCamera) and camera.fx == f and camera.fy == f and camera.cx == cx
            and camera.cy == cy and not any(camera.dist) and not any(camera.rotation_deg))


@dataclass
class Rectifier:
    """Patch-wise rectification of one rig; `identity` when the raw images already are rectified."""

    rig: StereoRig
    f_px: float = field(init=False)
    cx: float = field(init=False)
    cy: float = field(init=False)
    identity: bool = field(init=False)
    _maps: tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]] | None = field(
        init=False, default=None, repr=False)

    def __post_init__(self) -> None:
        rig = self.rig
        self.f_px = rig.focal_px()
        self.cx, self.cy = float(rig.left.cx), float(rig.left.cy)  # type: ignore[attr-defined]
        self.identity = all(_is_ideal(c, self.f_px, self.cx, self.cy) for c in (rig.left, rig.right))
        if not self.identity:
            self._maps = (self._table(rig.left), self._table(rig.right))

    def _table(self, camera: CameraModel) -> tuple[np.ndarray, np.ndarray]:
        w, h = self.rig.width, self.rig.height
        map1 = np.empty((h, w, 2), np.int16)
        map2 = np.empty((h, w), np.uint16)
        us = np.arange(w, dtype=np.float64)
        for r0 in range(0, h, MAP_CHUNK_ROWS):
            vs = np.arange(r0, min(h, r0 + MAP_CHUNK_ROWS), dtype=np.float64)
            uv = np.stack(np.meshgrid(us, vs), axis=-1)
            raw = camera.normalised_to_pixel(self.rect_to_normalised(uv)).astype(np.float32)
            raw = np.where(np.isfinite(raw), raw, -1e4)  # unmappable -> outside the image (border)
            m1, m2 = cv2.convertMaps(np.ascontiguousarray(raw[..., 0]), np.ascontiguousarray(raw[..., 1]),
                                     cv2.CV_16SC2)
            map1[r0:r0 + len(vs)], map2[r0:r0 + len(vs)] = m1, m2
        return map1, map2

    # ------------------------------------------------------------ coordinates
    def rect_to_normalised(self, uv: np.ndarray) -> np.ndarray:
        """(..., 2) rectified pixels -> rotation-compensated normalised coordinates."""
        return (np.asarray(uv, dtype=np.float64) - (self.cx, self.cy)) / self.f_px

    def normalised_to_rect(self, xy: np.ndarray) -> np.ndarray:
        return np.asarray(xy, dtype=np.float64) * self.f_px + (self.cx, self.cy)

    def raw_to_rect(self, uv_raw: np.ndarray, side: int = 0) -> np.ndarray:
        """(..., 2) raw pixels of the left (side 0) or right (1) camera -> rectified pixels."""
        if self.identity:
            return np.asarray(uv_raw, dtype=np.float64)
        camera = self.rig.left if side == 0 else self.rig.right
        return self.normalised_to_rect(camera.pixel_to_normalised(uv_raw))

    def rect_to_raw(self, uv_rect: np.ndarray, side: int = 0) -> np.ndarray:
        if self.identity:
            return np.asarray(uv_rect, dtype=np.float64)
        camera = self.rig.left if side == 0 else self.rig.right
        return camera.normalised_to_pixel(self.rect_to_normalised(uv_rect))

    def disparity_to_range(self, disparity_px: float) -> float:
        """Z = f L_B / d (eq. 2.12); inf for d <= 0."""
        return self.f_px * self.rig.baseline_m / disparity_px if disparity_px > 0 else math.inf

    # ------------------------------------------------------------ pixels
    def patch(self, image: np.ndarray, side: int, x0: int, y0: int, width: int, height: int) -> np.ndarray:
        """Rectified pixels [y0, y0 + height) x [x0, x0 + width) of a raw image (side 0 left, 1 right).

        Parts outside the image repeat the border pixel (the matcher's validity
        gates reject windows that are mostly border)."""
        h_img, w_img = image.shape[:2]
        kernels = native.kernels
        if kernels is not None and not self.identity and image.ndim == 2 and image.dtype == np.uint8 \
                and image.strides[1] == 1:
            # the same fixed-point bilinear interpolation as cv2.remap below, bit for bit (native/)
            assert self._maps is not None
            out = np.empty((height, width), np.uint8)
            kernels.remap(image, *self._maps[side], x0, y0, out)
            return out
        inside = x0 >= 0 and y0 >= 0 and x0 + width <= w_img and y0 + height <= h_img
        if inside:
            index: tuple = (slice(y0, y0 + height), slice(x0, x0 + width))
        else:  # clamp the coordinates: the border pixels repeat
            index = np.ix_(np.clip(np.arange(y0, y0 + height), 0, h_img - 1),
                           np.clip(np.arange(x0, x0 + width), 0, w_img - 1))
        if self.identity:
            return image[index]
        assert self._maps is not None
        map1, map2 = self._maps[side]
        return cv2.remap(image, map1[index], map2[index], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)

    def xsobel_patch(self, image: np.ndarray, side: int, x0: int, y0: int, width: int,
                     height: int) -> np.ndarray:
        """`patch` through the clipped horizontal Sobel (edge.core.prefilter), uint8: fetched one
        pixel larger all round for the 3x3 kernel, so away from the image border it equals the
        filtered whole rectified image."""
        return xsobel(self.patch(image, side, x0 - 1, y0 - 1, width + 2, height + 2))[1:-1, 1:-1]
