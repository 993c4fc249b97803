"""From scene radiance to an 8-bit camera image: optics, exposure, sensor noise, quantisation.

Order of operations for each camera (independently, with its own noise):

1. PSF: a Gaussian blur of `psf_sigma_px` on the area-integrated radiance
   (pixel box (x) Gaussian); symmetric, so it moves no centroid.
2. Exposure and the camera's gain: the right camera may be `right_gain`
   brighter and `right_offset_dn` offset (radiometric mismatch, research §6.3).
3. Shot noise: Gaussian with variance I / electrons_per_dn (Poisson in
   electrons, expressed in DN), then read noise of `read_noise_dn` RMS.
4. Offset, rounding to the nearest integer, clipping to 0..255: glints and
   bright sky saturate as a real 8-bit sensor does.

Noise comes from a generator the caller seeds per frame and camera, so a
render is reproducible pair by pair and the two views never share noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from edge.config.schema import setting


@dataclass(frozen=True)
class ImagingSpec:
    exposure: float = setting(1.0, positive=True, doc="exposure scale on the scene radiance")
    psf_sigma_px: float = setting(0.6, min=0.0, max=5.0, doc="Gaussian PSF sigma, pixels (0: none)")
    read_noise_dn: float = setting(1.0, min=0.0, max=50.0, doc="read noise RMS, DN")
    electrons_per_dn: float = setting(
        8.0, positive=True, doc="conversion gain: shot-noise variance = I / this"
    )
    shot_noise: bool = setting(True, doc="add photon shot noise")
    right_gain: float = setting(1.0, min=0.5, max=2.0, doc="right camera gain relative to the left")
    right_offset_dn: float = setting(0.0, min=-50.0, max=50.0, doc="right camera black-level offset, DN")

    @property
    def noise_free(self) -> bool:
        return self.read_noise_dn == 0.0 and not self.shot_noise


def blur(radiance: np.ndarray, sigma_px: float) -> np.ndarray:
    """Gaussian PSF, kernel to 4 sigma, edges reflected (no dark border)."""
    if sigma_px <= 0.0:
        return radiance
    size = 2 * int(np.ceil(4.0 * sigma_px)) + 1
    return cv2.GaussianBlur(
        radiance, (size, size), sigmaX=sigma_px, sigmaY=sigma_px, borderType=cv2.BORDER_REFLECT
    )


def expose(
    radiance: np.ndarray, spec: ImagingSpec, right: bool, rng: np.random.Generator | None
) -> np.ndarray:
    """The 8-bit image one camera records from a radiance image (float32, DN at unit exposure)."""
    gain = spec.exposure * (spec.right_gain if right else 1.0)
    signal: np.ndarray = blur(radiance.astype(np.float32, copy=False), spec.psf_sigma_px) * np.float32(gain)
    if rng is not None and not spec.noise_free:
        sigma2 = np.full(signal.shape, np.float32(spec.read_noise_dn**2), np.float32)
        if spec.shot_noise:
            sigma2 += np.maximum(signal, 0.0) / np.float32(spec.electrons_per_dn)
        signal = signal + np.sqrt(sigma2) * rng.standard_normal(signal.shape, dtype=np.float32)
    if right and spec.right_offset_dn:
        signal = signal + np.float32(spec.right_offset_dn)
    return np.clip(np.rint(signal), 0, 255).astype(np.uint8)
