"""Replay: the real pipeline over a recording, synchronously, writing NMEA and the per-fix CSV.

`mast-stereo replay RECORDING [--config FILE] [--nmea FILE] [--tracks FILE]`
(DESIGN.md). Calibration, site and frame rate come from the recording's
meta.yaml; a configuration file, when given, overrides the calibration and
site it names and supplies the pipeline settings. Pairs are processed as fast
as the CPU allows, in recording order, by the same `Pipeline` the daemon
runs; NMEA goes through the daemon's `NmeaScheduler` on an unlimited line,
clocked by the pairs' own timestamps. No wall clock enters anywhere, so the
same recording gives byte-identical output.

With `alerts.enabled` in the configuration the alert sentences (ALF, ALC, HBT: edge.alerts) go
out too, before the track updates of each pair, clocked by the same timestamps; HBT says A
(a recording has no appliance health). Without it the output is as before, byte for byte.

Faults in the recording (missing or corrupt PNGs, sequence gaps, timestamps
that go back, pairs the pipeline refuses) are counted and reported in the
summary, never raised. A
directory that is not a recording is a configuration error (exit 78).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

from drivers.camera.replay import RecordingFormatError, ReplaySource
from edge.ais.stage import AisStage, feed_until
from edge.alerts.manager import AlertManager
from edge.alerts.port import PortAlerts
from edge.config.ais import AisConfig
from edge.config.app import AppConfig, PipelineConfig, load_config
from edge.config.calibration import Calibration, recording_calibration
from edge.config.masks import build_search_mask
from edge.encode.tracks_csv import CSV_HEADER, csv_row
from edge.errors import ConfigError
from edge.fix import ShipFix
from edge.outputs.schedule import NmeaSchedule, NmeaScheduler
from edge.pipeline import Counters, Pipeline
from edge.sim.recording import read_ais

log = logging.getLogger(__name__)

@dataclass
class ReplaySummary:
    """What a replay did: the source's and the pipeline's counters, and the outputs written."""

    pairs_in_recording: int = 0
    skipped_pairs: int = 0  # unreadable/missing PNGs (the source skipped them)
    dropped_pairs: int = 0  # sequence-number gaps in the recording
    unordered_pairs: int = 0  # timestamps not after the previous pair's (the source skipped them)
    pipeline: Counters = field(default_factory=Counters)
    tracks: int = 0  # distinct track ids that produced fixes
    nmea_lines: int = 0
    csv_rows: int = 0
    ais: AisStage | None = None  # the AIS stage, when the recording has an ais.csv

    def lines(self) -> list[str]:
        p = self.pipeline
        return [
            f"pairs in recording {self.pairs_in_recording}, read {p.pairs}, skipped (unreadable) "
            f"{self.skipped_pairs}, dropped (sequence gaps) {self.dropped_pairs}, "
            f"skipped (time going back) {self.unordered_pairs}",
            f"pipeline: processed {p.processed}, refused {p.bad_input}, failed {p.failed}, "
            f"coasted gaps {p.gaps}, detection passes {p.detections}"
            + (f", detections in site masks {p.masked}" if p.masked else ""),
            f"fixes {p.fixes} from {self.tracks} tracks; NMEA lines {self.nmea_lines}, "
            f"CSV rows {self.csv_rows}",
        ] + ([] if self.ais is None else [
            "AIS: " + ", ".join(f"{k.replace('_', ' ')} {v}" for k, v in self.ais.health_counters().items())])


def open_recording(root: str | Path) -> ReplaySource:
    try:
        return ReplaySource(root)
    except RecordingFormatError as exc:
        raise ConfigError(exc.path, "format", f"a mast-stereo recording ({exc.problem})") from None


def build_pipeline(root: str | Path, source: ReplaySource, config: AppConfig | None,
                   config_file: str | Path | None = None) -> Pipeline:
    """The pipeline for a recording: its calibration/site/fps, overridden by `config` where set
    (its site masks too; `config_file` names the file in their errors)."""
    cal = recording_calibration(root, source.meta)
    pipeline_cfg = PipelineConfig()
    mask = None
    if config is not None:
        chosen = config.calibration or cal
        cal = Calibration(chosen.rig, config.effective_site or cal.site, chosen.sigma)
        pipeline_cfg = config.pipeline
    if cal.site is None:
        raise ConfigError(Path(root) / "meta.yaml", "site",
                          "a site (lat_deg, lon_deg, height_m, heading_deg) in recording or config")
    fps = source.meta.get("fps")
    if isinstance(fps, bool) or not isinstance(fps, int | float) or not fps > 0:
        raise ConfigError(Path(root) / "meta.yaml", "fps", "a positive frame rate", fps)
    if config is not None:
        mask = build_search_mask(config.masks, cal.rig, cal.site, config_file)
    return Pipeline(cal, pipeline_cfg, fps=float(fps), search_mask=mask)


def build_ais(root: str | Path, pipeline: Pipeline, config: AppConfig | None) -> tuple[AisStage, list] | None:
    """The AIS stage and the recording's ais.csv lines, or None when it has none (config.ais, else
    the defaults)."""
    try:
        lines = read_ais(root)
    except ValueError as exc:
        raise ConfigError(Path(root) / "ais.csv", "header", "t_ns,sentence", str(exc)) from None
    if lines is None:
        return None
    cfg = (config.ais if config is not None else None) or AisConfig()
    stage = AisStage(cfg, pipeline.site, pipeline.rect.f_px, pipeline.rig.baseline_m)
    if lines:
        stage.start(min(lines[0][0], 0))
    return stage, lines


def replay(root: str | Path, *, config_path: str | Path | None = None, nmea: TextIO | None = None,
           tracks: TextIO | None = None, on_fixes: Callable[[int, list[ShipFix]], None] | None = None
           ) -> ReplaySummary:
    """Run the pipeline over a recording; write NMEA lines to `nmea` and CSV rows to `tracks`."""
    config = load_config(config_path) if config_path is not None else None
    source = open_recording(root)
    pipeline = build_pipeline(root, source, config, config_path)
    summary = ReplaySummary(pairs_in_recording=len(source), pipeline=pipeline.counters)
    ais = build_ais(root, pipeline, config)
    ais_next = 0
    if ais is not None:
        summary.ais = ais[0]
    now = [0.0]
    scheduler = NmeaScheduler(NmeaSchedule(), None, clock=lambda: now[0])
    manager = None
    if config is not None and config.alerts.enabled:  # issue 18: the alert sentences too
        manager = AlertManager(config.alerts, config.pipeline.max_tracks)
        scheduler.alerts = PortAlerts(manager, config.alerts)
    seen: set[int] = set()
    if tracks is not None:
        tracks.write(CSV_HEADER + "\n")
    with source:
        for pair in source:
            fixes = pipeline.step(pair)
            if ais is not None:  # the lines received up to this exposure, then the association
                stage, lines = ais
                ais_next = feed_until(stage, lines, ais_next, pair.t_ns)
                fixes = stage.annotate(fixes, pipeline.ground.position)
            now[0] = pair.t_ns / 1e9
            if manager is not None:
                manager.step(fixes, pair.t_ns)
            for fix in fixes:
                seen.add(fix.track_id)
                if tracks is not None:
                    tracks.write(csv_row(fix) + "\n")
                    summary.csv_rows += 1
            for group in scheduler.step(fixes):
                if nmea is not None:
                    nmea.write("".join(group))
                summary.nmea_lines += len(group)
            if on_fixes is not None:
                on_fixes(pair.t_ns, fixes)
    summary.skipped_pairs, summary.dropped_pairs = source.skipped, source.dropped
    summary.unordered_pairs = source.out_of_order
    summary.tracks = len(seen)
    return summary
