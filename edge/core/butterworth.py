"""The thesis's 2nd-order Butterworth disparity filter (eq. 6.1), streaming, one state per track:
an integer biquad with Q14 coefficients and a float reference beside it.

Kept for comparison with the default Kalman filter (edge.core.kalman): it lags a ship that
approaches or recedes by the DC group delay sqrt(2)/(2 pi fc) (0.45 s at 0.5 Hz), and it has
no outlier rejection (research note §2.2).

Fixed-point design (research note §3.3):
- coefficients from `scipy.signal.butter(2, fc, fs=fs, output='sos')`, rounded to Q14, then
  b1 := (1 + a1 + a2) - b0 - b2 in integers so the DC gain is exactly 1 (Neunaber): at low
  fc/fs b0 is only a few LSB and rounding alone would miss unity by up to 14 %;
- direct form I with a *wide output state*: y is kept in Q22 (Q8 px + 14 bits), so the
  feedback never loses the bits that make a narrow Q8 state stick up to 0.5 LSB/(1+a1+a2)
  away from a constant input (1.15 px at 0.2 Hz / 30 fps). Output is rounded to Q8 px.
- widths: |d| < 512 px gives x < 2^17 (Q8), y state < 2^31 (Q22), products < 2^47: int64,
  like CMSIS `arm_biquad_cascade_df1_32x64_q31`. Note the sign: y = b.x - a1 y1 - a2 y2
  (scipy's convention; CMSIS adds, so negate a1, a2 there).
- the state starts at the step-response steady state of the first sample, so a track does
  not ring up from zero.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import butter

from edge.core.fixedpoint import BIQUAD_COEF_BITS, SUBPIX_BITS, from_q, round_shift, saturate, to_q


@dataclass(frozen=True)
class BiquadQ14:
    """Q14 coefficients (scipy signs: y = b0 x + b1 x1 + b2 x2 - a1 y1 - a2 y2), DC gain exact."""

    b0: int
    b1: int
    b2: int
    a1: int
    a2: int

    def as_float(self) -> np.ndarray:
        """The same quantised filter as a scipy sos row [b0 b1 b2 1 a1 a2]."""
        one = float(1 << BIQUAD_COEF_BITS)
        return np.array([[self.b0 / one, self.b1 / one, self.b2 / one, 1.0, self.a1 / one, self.a2 / one]])


def butterworth_sos(cutoff_hz: float, fs_hz: float) -> np.ndarray:
    """The unquantised design (scipy), one second-order section."""
    if not 0 < cutoff_hz < fs_hz / 2:
        raise ValueError(f"cutoff {cutoff_hz} Hz must lie in (0, fs/2 = {fs_hz / 2}) Hz")
    return butter(2, cutoff_hz, fs=fs_hz, output="sos")


def design_q14(cutoff_hz: float, fs_hz: float) -> BiquadQ14:
    """Quantise the design to Q14 with exactly unity DC gain (b1 absorbs the rounding)."""
    b0, _b1, b2, _a0, a1, a2 = butterworth_sos(cutoff_hz, fs_hz)[0]
    q = BIQUAD_COEF_BITS
    qb0, qb2, qa1, qa2 = to_q(b0, q), to_q(b2, q), to_q(a1, q), to_q(a2, q)
    qb1 = (1 << q) + qa1 + qa2 - qb0 - qb2
    return BiquadQ14(qb0, qb1, qb2, qa1, qa2)


class ButterworthQ:
    """Integer streaming biquad on Q8-px disparity (wide Q22 output state, int64)."""

    def __init__(self, cutoff_hz: float, fs_hz: float) -> None:
        self.coef = design_q14(cutoff_hz, fs_hz)
        self._x1 = self._x2 = 0
        self._y1 = self._y2 = 0
        self.started = False

    def reset(self, x_q8: int) -> None:
        """Load the step-response steady state of a constant input x_q8."""
        self._x1 = self._x2 = x_q8
        self._y1 = self._y2 = x_q8 << BIQUAD_COEF_BITS
        self.started = True

    def update(self, x_q8: int) -> int:
        """Filter one Q8 sample; returns the Q8 output."""
        if not self.started:
            self.reset(x_q8)
        c, q = self.coef, BIQUAD_COEF_BITS
        forward = c.b0 * x_q8 + c.b1 * self._x1 + c.b2 * self._x2                  # Q22
        feedback = round_shift(c.a1 * self._y1 + c.a2 * self._y2, q)                # Q36 -> Q22
        y = forward - feedback
        self._x2, self._x1 = self._x1, x_q8
        self._y2, self._y1 = self._y1, y
        return saturate(round_shift(y, q), 32)

    def update_px(self, x_px: float) -> float:
        """Convenience: float px in, float px out (input rounded to Q8)."""
        return from_q(self.update(to_q(x_px, SUBPIX_BITS)), SUBPIX_BITS)


class ButterworthFloat:
    """Float64 reference: direct form I with the same (quantised) or the exact coefficients."""

    def __init__(self, cutoff_hz: float, fs_hz: float, quantised: bool = True) -> None:
        sos = design_q14(cutoff_hz, fs_hz).as_float() if quantised else butterworth_sos(cutoff_hz, fs_hz)
        self.b0, self.b1, self.b2, _, self.a1, self.a2 = (float(v) for v in sos[0])
        self._x1 = self._x2 = self._y1 = self._y2 = 0.0
        self.started = False

    def reset(self, x_px: float) -> None:
        """Step-response steady state (the same as scipy's sosfilt_zi(sos) * x)."""
        dc = (self.b0 + self.b1 + self.b2) / (1.0 + self.a1 + self.a2)
        self._x1 = self._x2 = x_px
        self._y1 = self._y2 = dc * x_px
        self.started = True

    def update(self, x_px: float) -> float:
        if not self.started:
            self.reset(x_px)
        y = (self.b0 * x_px + self.b1 * self._x1 + self.b2 * self._x2
             - self.a1 * self._y1 - self.a2 * self._y2)
        self._x2, self._x1 = self._x1, x_px
        self._y2, self._y1 = self._y1, y
        return y


def group_delay_s(cutoff_hz: float) -> float:
    """DC group delay of the 2nd-order Butterworth, sqrt(2) / (2 pi fc): its ramp lag."""
    return float(np.sqrt(2.0) / (2.0 * np.pi * cutoff_hz))
