"""/metrics: the daemon's own counters in the Prometheus text format (prometheus_client).

A custom collector on a private registry reads the running appliance at each scrape: nothing is
counted twice and nothing is added to the processing thread, so every value is the daemon's own
(the pipeline's counters, the capture queue's drops, the fan-out's sends, the health stages'
counters, the fault log's starts). Families (docs/page.md lists them):

    mast_pairs_total{result}              pairs given to the pipeline: processed, bad_input, failed
    mast_pairs_dropped_total              pairs the capture queue dropped before processing
    mast_frame_rate_fps                   the health monitor's processed-pairs rate
    mast_stage_latency_seconds{stage}     histograms: queue, chain, outputs, total (edge.appliance.timing)
    mast_tracks{status}                   live fixes by status (Q, T, L), as the outputs got them
    mast_faults_total{stage,kind}         faults begun (kind fault or no_heartbeat), edge.appliance.journal
    mast_fault_active{stage}              1 while that stage has a fault
    mast_output_sent_total{unit}          items each output kind sent (NMEA groups, Modbus images, ...)
    mast_stage_counter{stage,counter}     every health stage's counters (ports, clients, drops, AIS)
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

from prometheus_client.core import (
    CollectorRegistry,
    CounterMetricFamily,
    GaugeMetricFamily,
    HistogramMetricFamily,
    Metric,
)
from prometheus_client.exposition import generate_latest

from edge.appliance.health import HealthState
from edge.appliance.page.state import Watched, counters
from edge.fix import TrackStatus

CONTENT_TYPE = "text/plain; version=0.0.4; charset=utf-8"
STATE_VALUE = {HealthState.OK: 0, HealthState.DEGRADED: 1, HealthState.STALLED: 2}


class ApplianceCollector:
    """Reads `app` (and the page's own counters, `page_counters`) at each scrape."""

    def __init__(self, app: Watched, page_counters: Callable[[], dict[str, int]]) -> None:
        self.app, self.page_counters = app, page_counters

    def collect(self) -> Iterator[Metric]:
        app = self.app
        c = counters(app)
        snap = app.health.snapshot()
        pairs = CounterMetricFamily("mast_pairs", "Frame pairs given to the pipeline, by result",
                                    labels=["result"])
        for result in ("processed", "bad_input", "failed"):
            pairs.add_metric([result], c[result])
        yield pairs
        yield CounterMetricFamily("mast_pairs_dropped", "Pairs the capture queue dropped before processing "
                                  "(the newest pair wins)", value=c["dropped"])
        yield CounterMetricFamily("mast_capture_errors", "Camera read errors", value=c["capture_errors"])
        yield CounterMetricFamily("mast_fixes", "Fixes sent (one per live track and processed pair)",
                                  value=c["fixes"])
        yield CounterMetricFamily("mast_reloads", "Configuration reloads (SIGHUP) applied",
                                  value=c["reloads"])
        yield GaugeMetricFamily("mast_frame_rate_fps", "Processed pairs per second (health window)",
                                value=snap.frame_rate_hz or 0.0)
        yield GaugeMetricFamily("mast_uptime_seconds", "Seconds since the daemon started",
                                value=snap.uptime_s)
        yield GaugeMetricFamily("mast_health_state", "0 OK, 1 DEGRADED, 2 STALLED",
                                value=STATE_VALUE[snap.state])
        yield GaugeMetricFamily("mast_fault_code", "The Modbus FAULT_CODE (0: none)", value=snap.fault_code)
        hist = HistogramMetricFamily("mast_stage_latency_seconds",
                                     "Latency of each processing stage per pair", labels=["stage"])
        for stage, h in app.timing.snapshot().items():
            hist.add_metric([stage], h.cumulative(), h.sum_s)
        yield hist
        tracks = GaugeMetricFamily("mast_tracks", "Live tracks with a fix, by status (Q acquiring, "
                                   "T tracking, L lost)", labels=["status"])
        fixes = list(app.last_fixes)
        for status in TrackStatus:
            tracks.add_metric([status.value], sum(f.status is status for f in fixes))
        yield tracks
        started = CounterMetricFamily("mast_faults", "Faults begun, per health stage and kind",
                                      labels=["stage", "kind"])
        for (stage, kind), n in sorted(dict(app.faults.started).items()):
            started.add_metric([stage, kind], n)
        yield started
        active = GaugeMetricFamily("mast_fault_active", "1 while the stage reports a fault or no heartbeat",
                                   labels=["stage"])
        for s in snap.stages:
            active.add_metric([s.name], int(s.age_s is not None and (not s.fresh or s.fault is not None)))
        yield active
        sent = CounterMetricFamily("mast_output_sent", "Items the outputs sent, per unit", labels=["unit"])
        for unit, n in sorted(dict(app.outputs.sent).items()):
            sent.add_metric([unit], n)
        yield sent
        stage_counters = GaugeMetricFamily("mast_stage_counter", "Each health stage's counters as it "
                                           "reports them (cumulative counts and levels)",
                                           labels=["stage", "counter"])
        for s in snap.stages:
            for name, n in sorted(s.counters.items()):
                stage_counters.add_metric([s.name, name], n)
        yield stage_counters
        page = CounterMetricFamily("mast_page", "The maintenance page's own counters", labels=["what"])
        for what, n in sorted(self.page_counters().items()):
            page.add_metric([what], n)
        yield page


class Metrics:
    """The exposition of one appliance: `render()` is the body of GET /metrics."""

    def __init__(self, app: Watched, page_counters: Callable[[], dict[str, int]]) -> None:
        self.registry = CollectorRegistry(auto_describe=False)
        self.registry.register(ApplianceCollector(app, page_counters))

    def render(self) -> bytes:
        return generate_latest(self.registry)
