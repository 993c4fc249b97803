"""The compiled per-track kernels (native/: the `mast_native` extension of the mast-stereo-native
distribution), when installed; None otherwise, and the NumPy code runs instead.

Why: per pair every track follows its point, matches it and cross-checks the match, each a few
thousand integer multiply-adds that NumPy spends more time dispatching than computing
(tools/bench --stages). The C kernels do the same integer arithmetic in the same order of float
operations, so they are bit-identical to the NumPy reference that stays beside them
(edge.core.match, refpoint, batchmatch, batchsubpix, rectify); tests/native compare the two.
docs/decisions.md says why C (meson-python) and not numba.

`kernels` is read at each call, so a test can set it to None to run the reference.
"""

from __future__ import annotations

from types import ModuleType

from edge.core.fixedpoint import LOG2_TABLE


def _load() -> ModuleType | None:
    try:
        import mast_native
    except ImportError:
        return None
    mast_native.init(LOG2_TABLE)
    return mast_native


kernels: ModuleType | None = _load()

# sub-pixel method codes of mast_core.h (MC_SUB_*)
SUBPIXEL_CODES = {"none": 0, "parabola": 1, "cancel6-gauss": 2}
SUB_OTHER = 3
# match status codes (mc_match_status) and follow status codes (mc_follow_status)
(MATCH_VALID, MATCH_EDGE, MATCH_AMBIGUOUS, MATCH_BORDER, MATCH_REFERENCE, MATCH_REFINE,
 MATCH_NO_BRACKET, MATCH_CANCEL_LR, MATCH_CANCEL_RL) = range(9)
FOLLOW_VALID, FOLLOW_EDGE, FOLLOW_AMBIGUOUS, FOLLOW_NO_BRACKET, FOLLOW_REFERENCE = range(5)

__all__ = ["SUBPIXEL_CODES", "kernels"]
