"""Replay: the real pipeline over a recording, synchronously, writing NMEA and the per-fix CSV.

`mast-stereo replay RECORDING [--config FILE] [--nmea FILE] [--tracks FILE]`
(docs/cli.md, docs/recordings.md). Calibration, site and frame rate come from the recording's
meta.yaml; a configuration file, when given, overrides the calibration and
site it names and supplies the pipeline settings. Pairs are processed as fast
as the CPU allows, in recording order, by the same `Pipeline` the daemon
runs, inside the same `Chain` (AIS from the recording's ais.csv, alerts when configured); NMEA
goes through the daemon's NMEA stream output on an unlimited line, clocked by the pairs' own
timestamps. No wall clock enters anywhere, so the same recording gives byte-identical output.

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
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import BinaryIO, TextIO

from drivers.camera.replay import RecordingFormatError, ReplaySource
from edge.ais.live import RecordedAis
from edge.ais.stage import AisStage
from edge.alerts.port import PortAlerts
from edge.chain import Chain
from edge.config.app import AppConfig, PipelineConfig, load_config
from edge.config.asterix import AsterixConfig, check_asterix
from edge.config.calibration import Calibration, recording_calibration
from edge.config.masks import build_search_mask
from edge.encode.tracks_csv import CSV_HEADER, csv_row
from edge.errors import ConfigError
from edge.fix import ShipFix
from edge.outputs.asterix import AsterixOutput, sensor_position
from edge.outputs.nmea_stream import NmeaStreamOutput
from edge.pipeline import Counters, Pipeline
from edge.recording.format import read_ais

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
    asterix_blocks: int = 0  # ASTERIX data blocks written or sent
    asterix_records: int = 0
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
        ] + ([f"ASTERIX: {self.asterix_blocks} data blocks, {self.asterix_records} records"]
             if self.asterix_blocks else []) + ([] if self.ais is None else [
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


def recorded_ais(root: str | Path) -> RecordedAis | None:
    """The recording's ais.csv lines as an AIS source, or None when it has none."""
    try:
        lines = read_ais(root)
    except ValueError as exc:
        raise ConfigError(Path(root) / "ais.csv", "header", "t_ns,sentence", str(exc)) from None
    return None if lines is None else RecordedAis(lines)


def build_chain(root: str | Path, source: ReplaySource, config: AppConfig | None,
                config_file: str | Path | None = None) -> Chain:
    """The chain for a recording: its pipeline (with the configuration's site masks; `config_file`
    names the file in their errors); AIS when it has an ais.csv (config.ais, else the defaults);
    alerts when the configuration enables them."""
    pipeline = build_pipeline(root, source, config, config_file)
    ais = recorded_ais(root)
    chain = Chain.from_config(config, pipeline, ais) if config is not None else \
        Chain(pipeline, Chain.build_ais(None, pipeline, ais))
    if ais is not None and ais.lines:
        chain.start(min(ais.lines[0][0], 0))
    return chain


def build_asterix(config: AppConfig | None, pipeline: Pipeline, clock: Callable[[], float],
                  send: bool) -> AsterixOutput:
    """The ASTERIX output of a replay: the configuration's `outputs.asterix` (else its defaults),
    clocked by the pairs, status always operational (a recording has no appliance health); UDP
    to the configured destinations with `send`, else only the blocks (for a file)."""
    cfg = config.outputs.asterix if config is not None else AsterixConfig()
    position = sensor_position(pipeline.site)
    if send:
        return AsterixOutput.from_config(cfg, None, position, clock=clock)
    return AsterixOutput(cfg, site=position, clock=clock)


def replay(root: str | Path, *, config_path: str | Path | None = None, nmea: TextIO | None = None,
           tracks: TextIO | None = None, on_fixes: Callable[[int, list[ShipFix]], None] | None = None,
           asterix: BinaryIO | None = None, asterix_send: bool = False) -> ReplaySummary:
    """Run the chain over a recording; write NMEA lines to `nmea` and CSV rows to `tracks`;
    ASTERIX data blocks to `asterix` (raw, back to back) and, with `asterix_send`, over UDP to the
    configuration's `outputs.asterix` destinations."""
    config = load_config(config_path) if config_path is not None else None
    if asterix_send and config is not None:
        check_asterix(replace(config.outputs.asterix, enabled=True), config_path)
    source = open_recording(root)
    chain = build_chain(root, source, config, config_path)
    summary = ReplaySummary(pairs_in_recording=len(source), pipeline=chain.pipeline.counters)
    if chain.ais is not None:
        summary.ais = chain.ais.stage
    stream = NmeaStreamOutput(nmea, clock=None, newline="\r\n")
    if chain.alerts is not None:  # the alert sentences too, before the track updates of each pair
        stream.scheduler.alerts = PortAlerts(chain.alerts, chain.alerts.cfg)
    seen: set[int] = set()
    now = [0.0]  # the ASTERIX status clock: the pairs' own time
    ast = build_asterix(config, chain.pipeline, lambda: now[0], asterix_send) \
        if asterix is not None or asterix_send else None
    if tracks is not None:
        tracks.write(CSV_HEADER + "\n")
    with source:
        for pair in source:
            fixes = chain.step(pair)
            seen.update(fix.track_id for fix in fixes)
            if tracks is not None:
                tracks.write("".join(csv_row(fix) + "\n" for fix in fixes))
                summary.csv_rows += len(fixes)
            summary.nmea_lines += sum(len(group) for group in stream.publish(fixes, pair.t_ns))
            if ast is not None:
                now[0] = pair.t_ns / 1e9
                summary.asterix_blocks += _write(asterix, ast.publish(fixes, pair.t_ns))
            if on_fixes is not None:
                on_fixes(pair.t_ns, fixes)
    if ast is not None:  # the recording ends: every track's last report (TRE)
        summary.asterix_blocks += _write(asterix, ast.finish())
        summary.asterix_records = ast.counts["records"]
        ast.close()
    summary.skipped_pairs, summary.dropped_pairs = source.skipped, source.dropped
    summary.unordered_pairs = source.out_of_order
    summary.tracks = len(seen)
    return summary


def _write(out: BinaryIO | None, blocks: list[bytes]) -> int:
    if out is not None:
        for block in blocks:
            out.write(block)
    return len(blocks)
