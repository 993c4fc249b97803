"""Pure computation: geometry, camera models, error budget, matching, sub-pixel fit, filters.

No I/O, no threads, no drivers (tests/test_house.py checks). Integer hot paths
sit beside float references; Q-format scale constants live in `fixedpoint`.
"""

from edge.core.match import Match, match_point, match_point_float
from edge.core.refpoint import FollowResult, follow_point

__all__ = ["Match", "FollowResult", "match_point", "match_point_float", "follow_point"]
