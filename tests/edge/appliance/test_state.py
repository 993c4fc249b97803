"""The crash state (edge.appliance.state): a round trip through the file keeps every number that must stay
off the wire, ages quarantines by the time since the save, and a bad file is a fault, not a crash."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest

from edge.appliance.state import (
    FILE_NAME,
    NumbersState,
    State,
    StateError,
    StateKeeper,
    parse_state,
    write_atomic,
)
from edge.encode.target_numbers import TargetNumbers
from edge.fix import TrackStatus


def allocator() -> TargetNumbers:
    numbers = TargetNumbers(max_number=5, quarantine_s=60.0)
    for tid in (10, 11, 12):
        numbers.assign(tid, 0.0)
    numbers.release(11)  # lost: its L repeats not all sent
    numbers.release(12)
    numbers.retire(3, 0.0)  # track 12's number: quarantined until 60 s
    return numbers


def test_round_trip_holds_live_lost_and_quarantined_numbers(tmp_path: Path) -> None:
    state = State(2001, {"serial:/dev/ttyS1": NumbersState.of(allocator(), 20.0)})
    assert state.numbers["serial:/dev/ttyS1"] == NumbersState([1, 2], {3: 40.0})
    path = tmp_path / FILE_NAME
    write_atomic(path, state.to_json())
    back = parse_state(path.read_text(), time.time(), time.monotonic())
    assert back.next_track_id == 2001 and back.numbers["serial:/dev/ttyS1"].in_use == [1, 2]
    assert 39.0 < back.numbers["serial:/dev/ttyS1"].quarantine_s[3] <= 40.0
    fresh = TargetNumbers(max_number=5, quarantine_s=60.0)
    for n in back.numbers["serial:/dev/ttyS1"].in_use:
        fresh.hold(n, 60.0, 100.0)
    fresh.hold(3, back.numbers["serial:/dev/ttyS1"].quarantine_s[3], 100.0)
    assert [fresh.assign(t, 100.0) for t in (20, 21, 22)] == [4, 5, None]  # 1-3 held
    assert fresh.assign(23, 160.0) in (1, 2, 3)  # all free again once the quarantine is over


def test_quarantine_ages_on_the_wall_clock_across_a_reboot() -> None:
    text = State(1, {"k": NumbersState([], {7: 50.0})}).to_json()
    data = json.loads(text)
    data["boot_id"] = "another boot"
    aged = parse_state(json.dumps(data), data["saved_wall_s"] + 30.0, 0.0)
    assert aged.numbers["k"].quarantine_s[7] == pytest.approx(20.0, abs=0.01)
    stepped_back = parse_state(json.dumps(data), data["saved_wall_s"] - 999.0, 0.0)
    assert stepped_back.numbers["k"].quarantine_s[7] == pytest.approx(50.0)  # never younger than saved


@pytest.mark.parametrize("text", ["", "{", "[]", '{"format": 2}', '{"format": 1}',
                                  '{"format":1,"boot_id":"","saved_wall_s":0,"saved_mono_s":0,'
                                  '"next_track_id":0,"numbers":{}}'])
def test_malformed_text_is_a_state_error(text: str) -> None:
    with pytest.raises(StateError):
        parse_state(text, time.time(), time.monotonic())


def test_keeper_reports_missing_and_corrupt_files_and_saves_atomically(
        tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    keeper = StateKeeper(tmp_path)
    assert keeper.load() is None and not keeper.corrupt and "no state file" in (keeper.fault or "")
    keeper.close()
    (tmp_path / FILE_NAME).write_bytes(b"\xff\xfe garbage")
    (tmp_path / f".{FILE_NAME}.999.tmp").write_text("half a write")
    keeper = StateKeeper(tmp_path)
    assert not list(tmp_path.glob("*.tmp"))  # an interrupted write's leftover is removed
    assert keeper.load() is None and keeper.corrupt and "unusable" in caplog.text
    keeper.offer(State(5, {}))
    keeper.offer(State(6, {}))
    keeper.close()
    assert parse_state((tmp_path / FILE_NAME).read_text(), time.time(), time.monotonic()).next_track_id == 6


def _appliance(tmp_path: Path, port: int):
    from drivers.notify import SystemdNotifier
    from edge.appliance.daemon import Appliance
    from edge.config.app import config_from_dict

    cfg = {"cameras": {"kind": "virtual", "scenario": "akashi-crossing"},
           "site": {"lat_deg": 34.63, "lon_deg": 135.02, "height_m": 25.0, "heading_deg": 180.0,
                    "geoid_separation_m": 37.4},
           "outputs": {"modbus": {"tcp": {"enabled": False}},
                       "asterix": {"enabled": True, "cat034": True,
                                   "tracks": {"address": "127.0.0.1", "port": port}}},
           "health": {"state_dir": str(tmp_path / "state"), "leds": {"kind": "none"}}}
    return Appliance.build(config_from_dict(cfg, tmp_path / "mast.yaml"), None, SystemdNotifier())


def test_asterix_track_numbers_survive_a_crash(tmp_path: Path) -> None:
    """ASTERIX I010/161 numbers are kept like the NMEA ones: after a crash (no clean close) the
    restarted daemon lends none of the numbers the killed one had in use; and its CAT 034 I034/120
    states the site's height above the ellipsoid (height_m + geoid_separation_m)."""
    from edge.fix import ShipFix
    from edge.outputs.asterix import AsterixOutput
    from lab.asterix_capture import UdpReceiver

    def fixes(*ids: int) -> list[ShipFix]:
        return [ShipFix(0, i, TrackStatus.TRACKING, 0.0, 0.0, 1000.0, 1000.0, 180.0, 34.62, 135.02, None,
                        None, 5.0, 20.0) for i in ids]

    rx = UdpReceiver()
    try:
        first = _appliance(tmp_path, rx.port)
        (out,) = [o for o in first.outputs.outputs if isinstance(o, AsterixOutput)]
        assert out.site == (34.63, 135.02, 25.0 + 37.4)
        assert first.persistence is not None
        first.persistence.restore(first.pipeline, first.outputs)
        out.publish(fixes(1, 2, 3), 0)
        used = {out.numbers.number_of(t) for t in (1, 2, 3)}
        first.persistence.after_step(first.pipeline, first.outputs)
        first.persistence.keeper.close()  # the writer finishes what was offered; then the "crash"
        saved = json.loads((tmp_path / "state" / FILE_NAME).read_text())["numbers"]["asterix:0/1"]
        assert set(saved["in_use"]) == used
        again = _appliance(tmp_path, rx.port)
        assert again.persistence is not None
        again.persistence.restore(again.pipeline, again.outputs)
        (out2,) = [o for o in again.outputs.outputs if isinstance(o, AsterixOutput)]
        out2.publish(fixes(1001, 1002, 1003, 1004), 0)
        after = {out2.numbers.number_of(t) for t in (1001, 1002, 1003, 1004)}
        assert len(used) == 3 and None not in after and not used & after
        again.persistence.keeper.close()
    finally:
        rx.close(settle_s=0.0)
