"""Which frame-pair source the configured cameras are, resolved and checked before anything opens.

`plan_source` reads the `cameras` block and the calibration, and returns a `SourcePlan`: how to
open the source, the calibration and site to use, the frame rate and whether the pairs carry
CLOCK_MONOTONIC stamps (live cameras) or a recording's own clock. Every mistake is a
`ConfigError` naming the file and key, raised before a device is touched (exit 78).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from drivers.camera.base import FramePairSource
from drivers.camera.replay import ReplaySource
from edge.config.app import AppConfig, ReplayCameras, VirtualCameras
from edge.config.calibration import Calibration, recording_calibration
from edge.errors import ConfigError
from edge.sim.scenario import load_scenario
from edge.sim.simulator import live_source


@dataclass(frozen=True, slots=True)
class SourcePlan:
    """What the configured cameras are, checked before anything is opened."""

    open: Callable[[], FramePairSource]
    calibration: Calibration
    fps: float
    description: str
    monotonic_stamps: bool  # pairs stamped on CLOCK_MONOTONIC (live); else a recording's own clock


def plan_source(config: AppConfig, config_file: str | Path | None) -> SourcePlan:
    """Resolve `cameras` and the calibration; ConfigError names the key on any problem."""
    cams = config.cameras  # relative paths in it are already resolved against the config file
    if isinstance(cams, VirtualCameras):
        scenario = load_scenario(cams.scenario)
        cal = config.calibration or scenario.spec.calibration
        site = config.effective_site or scenario.spec.site or cal.site
        return SourcePlan(lambda: live_source(scenario, cams.seed, cams.pace, cams.loop),
                          Calibration(cal.rig, site), scenario.spec.fps,
                          f"virtual scenario {cams.scenario!r} seed {cams.seed}", monotonic_stamps=cams.pace)
    if isinstance(cams, ReplayCameras):
        root = Path(cams.path)
        try:
            probe = ReplaySource(root)
        except (OSError, ValueError) as exc:
            raise ConfigError(config_file, "cameras.path", "a readable recording directory",
                              f"{root}: {exc}") from exc
        cal = config.calibration or recording_calibration(root, probe.meta)
        site = config.effective_site or cal.site
        fps = float(probe.meta.get("fps") or 0.0)
        probe.close()
        if not fps > 0:
            raise ConfigError(root / "meta.yaml", "fps", "a positive frame rate", fps)
        return SourcePlan(lambda: ReplaySource(root, pace=cams.pace, loop=cams.loop),
                          Calibration(cal.rig, site), fps, f"recording {root}", monotonic_stamps=False)
    raise ConfigError(config_file, "cameras.kind",
                      "'virtual' or 'replay' (this build has no V4L2 capture driver yet)", cams.kind)
