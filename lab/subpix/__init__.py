"""Research sub-pixel methods, kept out of the appliance: importing this package registers them
with `edge.core.match` (`match_point(..., subpixel="refit")`), for tools/bench-core, tools/evaluate
--subpixel and their tests.
"""

from edge.core.match import register_refiner
from lab.subpix.refit import refine_refit

register_refiner("refit", refine_refit)
