"""/metrics of a running daemon parsed by prometheus_client's own parser: every counter equals the
daemon's own (read while the processing thread is held between two steps), the latency histograms
count every processed pair; /state.json shows the same numbers and the track table `run --watch` draws."""

from __future__ import annotations

import dataclasses
import json

from prometheus_client.parser import text_string_to_metric_families

from edge.appliance.console import rows
from edge.appliance.timing import STAGES


def samples(text: str) -> dict[tuple[str, tuple[tuple[str, str], ...]], float]:
    out = {}
    for family in text_string_to_metric_families(text):
        for s in family.samples:
            out[(s.name, tuple(sorted(s.labels.items())))] = s.value
    return out


def test_metrics_agree_with_the_daemons_counters(running) -> None:
    app = running.app
    running.wait(lambda: app.steps >= 25 and app.last_fixes)
    with app._step_lock:  # no step meanwhile: the daemon's counters stand still
        got = samples(running.get("/metrics").decode())
        state = json.loads(running.get("/state.json"))
        c = app.pipeline.counters
        sent = dict(app.outputs.sent)
        fixes = list(app.last_fixes)
        numbers = app.outputs.target_numbers(fixes)
    assert got[("mast_pairs_total", (("result", "processed"),))] == c.processed > 0
    assert got[("mast_pairs_total", (("result", "failed"),))] == c.failed
    assert got[("mast_pairs_total", (("result", "bad_input"),))] == c.bad_input
    assert got[("mast_pairs_dropped_total", ())] == app.queue.dropped
    assert got[("mast_fixes_total", ())] == c.fixes
    for unit, n in sent.items():
        assert got[("mast_output_sent_total", (("unit", unit),))] == n
    for status in ("Q", "T", "L"):
        assert got[("mast_tracks", (("status", status),))] == sum(f.status.value == status for f in fixes)
    for stage in STAGES:  # one observation per processed pair and stage, buckets cumulative
        key = (("stage", stage),)
        assert got[("mast_stage_latency_seconds_count", key)] == c.processed
        assert got[("mast_stage_latency_seconds_bucket", (("le", "+Inf"), ("stage", stage)))] == c.processed
    assert 0 < got[("mast_frame_rate_fps", ())] < 20
    assert got[("mast_health_state", ())] in (0, 1)
    dropped = (("counter", "dropped_pairs"), ("stage", "processing"))
    assert got[("mast_stage_counter", dropped)] == app.queue.dropped
    # the page shows the same counters and the same table as `run --watch`
    assert state["counters"]["processed"] == c.processed and state["counters"]["dropped"] == app.queue.dropped
    assert state["table"] == rows(fixes, numbers)
    assert [t["id"] for t in state["tracks"]] == [f.track_id for f in sorted(fixes, key=lambda f: f.range_m)]
    assert {s["name"] for s in state["health"]["stages"]} >= {"camera_left", "camera_right", "processing"}
    assert state["health"]["leds"]  # the virtual panel's patterns


def test_faults_by_kind_are_counted(running) -> None:
    """A fault's start, as the daemon's fault log sees it in a health snapshot, shows in mast_faults."""
    app = running.app
    snap = app.health.snapshot()
    faulty = tuple(dataclasses.replace(s, fault="unplugged") if s.name == "camera_left" else s
                   for s in snap.stages)
    before = samples(running.get("/metrics").decode()).get(
        ("mast_faults_total", (("kind", "fault"), ("stage", "camera_left"))), 0)
    app.faults.observe(dataclasses.replace(snap, stages=faulty))
    got = samples(running.get("/metrics").decode())
    assert got[("mast_faults_total", (("kind", "fault"), ("stage", "camera_left")))] == before + 1
    assert dict(app.faults.started)[("camera_left", "fault")] == before + 1
