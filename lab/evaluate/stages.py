"""The thesis's stages beside the product, on the same pairs: what `tools/evaluate --stages` compares.

Whole-pixel matching, the sub-pixel parabola (eq. 5.2), the Butterworth-filtered thesis chain
(eq. 6.1, plain SSD) and the product (ZSSD, cancellation, Kalman), each a full `Pipeline` with
its matching and filter settings overridden, so the comparison isolates those two choices.
"""

from __future__ import annotations

from dataclasses import replace

from edge.config.app import PipelineConfig
from edge.config.calibration import Calibration
from edge.core.site import Site
from edge.pipeline import Pipeline


def stage_pipelines(calibration: Calibration, config: PipelineConfig | None = None, *, fps: float = 10.0,
                    site: Site | None = None) -> dict[str, Pipeline]:
    """The thesis's three stages plus ours, side by side (tools/evaluate): whole-pixel, sub-pixel
    (parabola, eq. 5.2), filtered (Butterworth, eq. 6.1), and the product (cancellation + Kalman)."""
    cfg = config or PipelineConfig()
    return {
        "whole-pixel": Pipeline(calibration, cfg, fps=fps, site=site, subpixel="none", filter="none"),
        "sub-pixel": Pipeline(calibration, cfg, fps=fps, site=site, subpixel="parabola", filter="none"),
        "butterworth": Pipeline(calibration, replace(cfg, experimental=replace(cfg.experimental, cost="ssd")),
                                fps=fps, site=site, subpixel="parabola", filter="butterworth"),
        "product": Pipeline(calibration, cfg, fps=fps, site=site),
    }
