"""Fixed-point scale constants and the few integer helpers the core's hot paths share.

Every Q format used by the matching and filtering core is defined here, once, so the
DSP/FPGA port has a single page to read (docs/design.md, "Fixed point"):

- disparity and sub-pixel positions: Q8 pixels (1 LSB = 1/256 px) at the interfaces,
  Q10 inside the 3-point fits so that averaging two fits and rounding to Q8 stays within
  1 LSB of the float reference;
- Butterworth biquad coefficients: Q14, state in Q(8 + 14) = Q22 pixels ("wide state", so a
  low cutoff never leaves a dead band);
- base-2 logarithms of positive integers (the Gaussian curve model): Q24, from a 1024-entry
  table of log2(1 + i/1024) with linear interpolation (error < 2^-22);
- alpha-beta (steady-state Kalman) gains and state: Q24; its gate compares squared Q8
  residuals with Q16 px^2 thresholds.

The helpers take and return Python ints (arbitrary precision, so the *code* cannot overflow);
the widths a port needs are stated beside each routine and checked by tests. Rounding is
"half away from zero" everywhere, which is symmetric and therefore bias-free on signed data.
"""

from __future__ import annotations

import math

import numpy as np

# --- sub-pixel (eq. 5.2) ---------------------------------------------------------------
SUBPIX_BITS = 8                      # Q8 px at the interfaces (Match.disparity_q8)
SUBPIX_ONE = 1 << SUBPIX_BITS        # 256
FIT_BITS = 10                        # Q10 px for each 3-point fit before the final rounding
FIT_ONE = 1 << FIT_BITS

# --- integer log2 (Gaussian sub-pixel model) ------------------------------------------------
LOG_BITS = 24                        # Q24 log2 values
LOG_TABLE_BITS = 10                  # 1024 intervals of the mantissa [1, 2)
LOG2_TABLE = np.array([round(math.log2(1 + i / (1 << LOG_TABLE_BITS)) * (1 << LOG_BITS))
                       for i in range((1 << LOG_TABLE_BITS) + 1)], dtype=np.int64)
_LOG2_PAIRS = np.stack((LOG2_TABLE[:-1], np.diff(LOG2_TABLE)), axis=1)   # value, step (< 2^15)
_POW2 = np.array([1 << i for i in range(63)], dtype=np.int64)

# --- Butterworth biquad (eq. 6.1) ----------------------------------------------------------
BIQUAD_COEF_BITS = 14                # Q14 coefficients (CMSIS postShift = 1 convention)
BIQUAD_STATE_BITS = SUBPIX_BITS + BIQUAD_COEF_BITS   # Q22 px wide output state

# --- alpha-beta / constant-velocity Kalman -------------------------------------------------
AB_BITS = 24                         # Q24 gains and Q24 px state (int64 state)
AB_ONE = 1 << AB_BITS
VAR_BITS = 16                        # Q16 px^2 innovation variances / gate thresholds (r_q8^2 scale)

INT32_MIN = -(1 << 31)
INT32_MAX = (1 << 31) - 1


def round_shift(value: int, bits: int) -> int:
    """value / 2**bits rounded half away from zero (an arithmetic right shift with rounding)."""
    if bits <= 0:
        return value << -bits
    half = 1 << (bits - 1)
    if value >= 0:
        return (value + half) >> bits
    return -((-value + half) >> bits)


def round_shift_array(values: np.ndarray, bits: int) -> np.ndarray:
    """Vectorised `round_shift` for int64 arrays (|values| < 2**62)."""
    v = np.asarray(values, dtype=np.int64)
    half = np.int64(1 << (bits - 1))
    mag = (np.abs(v) + half) >> bits
    return np.where(v < 0, -mag, mag)


def div_round(num: int, den: int) -> int:
    """num / den rounded half away from zero (den > 0); the int64 reference of `restoring_divide`."""
    if den <= 0:
        raise ValueError("den must be positive")
    q = (2 * abs(num) + den) // (2 * den)
    return q if num >= 0 else -q


def div_round_array(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    """`div_round` of int64 arrays, elementwise (den > 0 everywhere; not checked)."""
    q = (2 * np.abs(num) + den) // (2 * den)
    return np.where(num >= 0, q, -q)


def restoring_divide(num: int, den: int, frac_bits: int) -> int:
    """Q(frac_bits) quotient of num/den for |num| <= den, rounded half away from zero.

    This is the FPGA/DSP form of the sub-pixel division (research note §3.2): one
    compare-and-subtract per quotient bit plus one more to round, so the remainder never
    exceeds 2*den and the registers need only bits(den) + 2 (no `num << 8` overflow).
    Bit-identical to `div_round(num << frac_bits, den)`; tests check it.
    """
    if den <= 0:
        raise ValueError("den must be positive")
    if abs(num) > den:
        raise ValueError("restoring_divide needs |num| <= den")
    rem = abs(num)
    quotient = 0
    for _ in range(frac_bits + 1):          # frac_bits quotient bits plus one rounding bit
        rem <<= 1
        quotient <<= 1
        if rem >= den:
            rem -= den
            quotient |= 1
    if abs(num) == den:                     # the loop above holds only |num| < den exactly
        quotient = 1 << (frac_bits + 1)
    quotient = (quotient + 1) >> 1          # the extra bit rounds half away from zero
    return quotient if num >= 0 else -quotient


def log2_q(values: np.ndarray) -> np.ndarray:
    """log2 of an int64 array of positive values (< 2^62; not checked) in Q24, integer-only:
    the exponent by comparison with powers of two (a port uses count-leading-zeros), the
    mantissa normalised to 63 bits, its top 10 fraction bits index LOG2_TABLE and the next
    30 interpolate linearly (floor).
    Error against math.log2: < 2^-22 (table interpolation) + 2^-24 (floor)."""
    e = np.searchsorted(_POW2, values, side="right") - 1             # floor(log2 v) <= 61
    frac = (values << (62 - e)) - (1 << 62)          # mantissa fraction, 62 bits (no overflow)
    low_bits = 62 - LOG_TABLE_BITS
    idx = frac >> low_bits
    pair = _LOG2_PAIRS[idx]                                         # table value and step
    rest = (frac >> (low_bits - 30)) & ((1 << 30) - 1)               # next 30 fraction bits
    return (e << LOG_BITS) + pair[..., 0] + ((pair[..., 1] * rest) >> 30)


_LOG2_LIST = LOG2_TABLE.tolist()


def log2_q_int(value: int) -> int:
    """`log2_q` of one positive Python int below 2^62, bit-identical, without numpy's per-call
    overhead (count-leading-zeros by int.bit_length)."""
    e = value.bit_length() - 1
    frac = (value << (62 - e)) - (1 << 62)
    low_bits = 62 - LOG_TABLE_BITS
    idx = frac >> low_bits
    base, step = _LOG2_LIST[idx], _LOG2_LIST[idx + 1] - _LOG2_LIST[idx]
    return (e << LOG_BITS) + base + ((step * ((frac >> (low_bits - 30)) & ((1 << 30) - 1))) >> 30)


def saturate(value: int, bits: int = 32) -> int:
    """Clamp to the signed `bits`-bit range (saturate, never wrap)."""
    lo = -(1 << (bits - 1))
    hi = (1 << (bits - 1)) - 1
    return lo if value < lo else hi if value > hi else value


def to_q(value: float, bits: int) -> int:
    """Nearest Q(bits) integer of a float (half away from zero)."""
    scaled = float(value) * (1 << bits)
    mag = math.floor(abs(scaled) + 0.5)          # an int; ValueError / OverflowError as numpy's int()
    return mag if scaled >= 0 else -mag


def from_q(value: int, bits: int) -> float:
    """Float value of a Q(bits) integer."""
    return value / float(1 << bits)
