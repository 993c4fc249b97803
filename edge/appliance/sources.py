"""Which frame-pair source the configured cameras are, resolved and checked before anything opens.

`plan_source` reads the `cameras` block and the calibration, and returns a `SourcePlan`: how to
open the source, the calibration and site to use, the frame rate and whether the pairs carry
CLOCK_MONOTONIC stamps (live cameras) or a recording's own clock. Every mistake is a
`ConfigError` naming the file and key, raised before a device is touched (exit 78).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from drivers.camera.base import FramePairSource
from drivers.camera.replay import RecordingFormatError, ReplaySource
from drivers.camera.v4l2 import V4L2Camera
from drivers.camera.v4l2_config import cameras_from_config
from drivers.camera.v4l2_node import CameraGone, DeviceError
from edge.config.app import AppConfig, ReplayCameras, V4l2Cameras, VirtualCameras
from edge.config.calibration import Calibration, recording_calibration
from edge.errors import ConfigError
from edge.sim.scenario import load_scenario
from edge.sim.simulator import live_source

log = logging.getLogger(__name__)

READ_TIMEOUT_S = 0.4  # the longest a live source's read waits before it reports its cameras' state
READ_PERIODS = 2.5  # ... but never less than this many trigger periods (a slow trigger is no fault)
# a camera away is retried after 0.5 s, doubling to at most 2 s: a camera replugged after any absence
# streams again within ~2.5 s (opening a missing node costs nothing worth saving)
BACKOFF_S = (0.5, 2.0)


@dataclass(frozen=True, slots=True)
class SourcePlan:
    """What the configured cameras are, checked before anything is opened."""

    open: Callable[[], FramePairSource]
    calibration: Calibration
    fps: float
    description: str
    monotonic_stamps: bool  # pairs stamped on CLOCK_MONOTONIC (live); else a recording's own clock
    lossless: bool = False  # not paced: the capture thread waits for the processing, never drops
    search_mask: np.ndarray | None = field(default=None, compare=False)  # site masks (daemon._plan)


def read_timeout_s(rate_hz: float) -> float:
    """How long the daemon's read of a live pair source waits: READ_TIMEOUT_S, or READ_PERIODS
    trigger periods at a slow rate (a shorter wait would report every gap between pairs as a fault)."""
    return max(READ_TIMEOUT_S, READ_PERIODS / rate_hz) if rate_hz > 0 else READ_TIMEOUT_S


def plan_source(config: AppConfig, config_file: str | Path | None) -> SourcePlan:
    """Resolve `cameras` and the calibration; ConfigError names the key on any problem."""
    cams = config.cameras  # relative paths in it are already resolved against the config file
    if isinstance(cams, VirtualCameras):
        try:
            scenario = load_scenario(cams.scenario)
        except ConfigError as exc:
            if exc.key or Path(exc.file).is_file():  # a mistake inside the scenario file: name that file
                raise
            raise ConfigError(config_file, "cameras.scenario", exc.expected, cams.scenario) from None
        cal = config.calibration or scenario.spec.calibration
        site = config.effective_site or scenario.spec.site or cal.site
        return SourcePlan(lambda: live_source(scenario, cams.seed, cams.pace, cams.loop),
                          Calibration(cal.rig, site, cal.sigma), scenario.spec.fps,
                          f"virtual scenario {cams.scenario!r} seed {cams.seed}", monotonic_stamps=cams.pace,
                          lossless=not cams.pace)
    if isinstance(cams, ReplayCameras):
        root = Path(cams.path)
        try:
            probe = ReplaySource(root)
        except (OSError, ValueError, RecordingFormatError) as exc:
            raise ConfigError(config_file, "cameras.path", "a readable recording directory",
                              f"{root}: {exc}") from exc
        cal = config.calibration or recording_calibration(root, probe.meta)
        site = config.effective_site or cal.site
        fps = float(probe.meta.get("fps") or 0.0)
        probe.close()
        if not fps > 0:
            raise ConfigError(root / "meta.yaml", "fps", "a positive frame rate", fps)
        return SourcePlan(lambda: ReplaySource(root, pace=cams.pace, loop=cams.loop),
                          Calibration(cal.rig, site, cal.sigma), fps, f"recording {root}",
                          monotonic_stamps=False, lossless=not cams.pace)
    return _v4l2_plan(config, cams, config_file)


def _v4l2_plan(config: AppConfig, cams: V4l2Cameras, config_file: str | Path | None) -> SourcePlan:
    """Two V4L2 cameras. Each device present now is opened once and its format negotiated, so a
    wrong node or a format it does not offer is a configuration error (exit 78) before anything
    streams; a device that is absent now is a camera fault the pair source retries (DEGRADED)."""
    assert config.calibration is not None  # config_from_dict requires it for v4l2
    built = cameras_from_config(cams.block())
    for side, settings in (("left", built.left), ("right", built.right)):
        if not Path(settings.device).exists():
            log.warning("camera %s (%s) is not there yet: it will be retried", side, settings.device)
            continue
        try:
            V4L2Camera(settings).close()
        except CameraGone:
            log.warning("camera %s (%s) went away while probed: it will be retried", side, settings.device)
        except DeviceError as exc:
            raise ConfigError(config_file, f"cameras.{side}.device", "a V4L2 capture device that offers "
                              f"{cams.width}x{cams.height} {cams.pixel_format}", str(exc)) from None
    rate_hz = built.trigger.rate_hz
    description = (f"v4l2 {built.left.device} + {built.right.device}, {cams.width}x{cams.height} "
                   f"{cams.pixel_format}, {built.trigger.describe()}")
    calibration = Calibration(config.calibration.rig, config.effective_site, config.calibration.sigma)
    # a short read timeout: camera faults reach health within 0.4 s, not at the next pair
    timeout_s = read_timeout_s(rate_hz)
    return SourcePlan(lambda: cameras_from_config(cams.block()).source(read_timeout_s=timeout_s,
                                                                       backoff_s=BACKOFF_S),
                      calibration, rate_hz, description, monotonic_stamps=True)
