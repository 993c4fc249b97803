"""selftest: passes on the virtual drivers, fails naming the check (exit = failures) on a corrupt
calibration, an unsynchronised clock or a taken port, and reads a running daemon's health block."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import time
from pathlib import Path

import yaml
from helpers import free_port, run_cli

from drivers.clock import VirtualClock
from edge.appliance.selftest import FAIL, PASS, WARN, Check, Selftest, report

ROOT = Path(__file__).resolve().parents[3]


def write_config(tmp_path: Path, port: int, **extra: object) -> Path:
    calibration = tmp_path / "calibration.yaml"
    calibration.write_text((ROOT / "config/calibration/akashi-pinhole.yaml").read_text())
    cfg = {"cameras": {"kind": "virtual", "scenario": "akashi-crossing", "seed": 1, "pace": True},
           "calibration": str(calibration),
           "outputs": {"modbus": {"tcp": {"enabled": True, "host": "127.0.0.1", "port": port}}},
           "health": {"require_clock_sync": False, "stale_s": 10.0, "min_fps": 0.0}, **extra}
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


def results(stdout: str) -> dict[str, str]:
    return {c["name"]: c["result"] for c in json.loads(stdout)["checks"]}


def test_selftest_passes_on_the_virtual_drivers(tmp_path: Path) -> None:
    started = time.monotonic()
    out = run_cli("selftest", "--config", write_config(tmp_path, free_port()), "--json")
    assert out.returncode == 0, out.stdout + out.stderr
    got = results(out.stdout)
    for name in ("configuration", "calibration", "cameras", "core known answer", "modbus port", "disk"):
        assert got[name] == PASS, got
    assert got["daemon"] == "SKIP"  # nothing answers on the port
    assert time.monotonic() - started < 30.0


def test_a_corrupt_calibration_fails_one_check_by_name(tmp_path: Path) -> None:
    path = write_config(tmp_path, free_port())
    (tmp_path / "calibration.yaml").write_text("baseline_m: [not, a, number\n")
    out = run_cli("selftest", "--config", path)
    assert out.returncode == 1, out.stdout + out.stderr
    failed = [line for line in out.stdout.splitlines() if " FAIL " in line]
    assert len(failed) == 1 and failed[0].startswith("calibration"), out.stdout
    assert "calibration.yaml" in failed[0] and "Traceback" not in out.stdout + out.stderr


def test_unsynchronised_clock_and_taken_port_are_failures_with_hints(tmp_path: Path) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        path = write_config(tmp_path, taken.getsockname()[1])
        text = path.read_text().replace("require_clock_sync: false", "require_clock_sync: true")
        path.write_text(text)
        test = Selftest(path, clock=VirtualClock(False))
        test.config = None
        checks = {c.name: c for c in (test.check_config(), test.check_clock())}
        assert checks["clock"].result == FAIL and "timesyncd" in checks["clock"].hint
        test.daemon = None
        modbus = test.check_modbus()
        # a listening socket that is not a Modbus server: not bindable, and the health block is unreadable
        assert modbus.result == FAIL and "another program" in modbus.hint


def test_selftest_reads_the_running_daemon(tmp_path: Path) -> None:
    port = free_port()
    path = write_config(tmp_path, port)
    daemon = subprocess.Popen([sys.executable, "-m", "edge.cli", "run", "--config", str(path)], cwd=ROOT,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        got: dict[str, str] = {}
        while time.monotonic() < deadline:
            out = run_cli("selftest", "--config", path, "--json")
            got = results(out.stdout)
            if got.get("daemon") == PASS:
                break
            time.sleep(1.0)
        assert got["daemon"] == PASS and got["modbus port"] == PASS and got["cameras"] == PASS, got
        checks = {c["name"]: c for c in json.loads(out.stdout)["checks"]}
        assert "in use by the daemon" in checks["cameras"]["detail"]
        assert "answers" in checks["modbus port"]["detail"]
    finally:
        daemon.terminate()
        daemon.wait(timeout=10)


def test_ais_calibration_check_reads_the_health_registers() -> None:
    """Issue 17: selftest's AIS line from registers 40-45 as the register map builds them."""
    from edge.appliance.health import HealthSnapshot, HealthState, StageHealth
    from edge.appliance.selftest import _ais_monitor_text
    from edge.encode.registers import Identity, SlotAssignment, build_snapshot

    def regs(counters: dict[str, int]) -> tuple[int, ...]:
        health = HealthSnapshot(HealthState.OK, "", 1, 0, 10.0, 0.1, 5.0, (StageHealth("ais", True, 0.1, None,
                                                                                        counters),))
        snap = build_snapshot([], health, Identity((0, 1, 0), 4), SlotAssignment.empty(4), utc_ns=0)
        return snap.registers[40:46]

    text, fault = _ais_monitor_text(regs({"disparity_offset_mpx": 91, "disparity_sigma_mpx": 7,
                                          "bearing_offset_mdeg": -20, "bearing_sigma_mdeg": 30,
                                          "monitor_ships": 3, "disparity_fault": 1}))
    assert fault and text == ("disparity offset +0.091 px (sigma 0.007), bearing offset -0.020 deg "
                              "(sigma 0.030), 3 ships")
    assert _ais_monitor_text(regs({"lines": 5})) is None  # no estimate yet


def _masks_check(tmp_path: Path, masks: dict) -> tuple[str, str]:
    test = Selftest(write_config(tmp_path, free_port(), masks=masks))
    assert test.check_config().result == PASS and test.check_calibration().result == PASS
    check = test.check_masks()
    return check.result, check.detail


def test_masks_hiding_the_whole_sea_are_a_warning_not_a_failure(tmp_path: Path) -> None:
    whole = {"image": [{"name": "everything", "polygon": [[0, 0], [719, 0], [719, 479], [0, 479]]}]}
    result, detail = _masks_check(tmp_path, whole)
    assert result == WARN and "whole sea" in detail
    lower = {"image": [{"polygon": [[0, 300], [719, 300], [719, 479], [0, 479]]}]}
    result, detail = _masks_check(tmp_path, lower)
    assert result == PASS and "% of the sea" in detail
    report_text = report([Check("site masks", WARN, "they hide the whole sea", "look"), Check("x", PASS, "")])
    assert "all 2 checks passed or skipped, 1 with a warning" in report_text and "hint: look" in report_text


def test_a_vertex_outside_the_scenarios_image_fails_the_masks_check(tmp_path: Path) -> None:
    result, detail = _masks_check(tmp_path, {"image": [{"polygon": [[0, 0], [100, 0], [0, 100]]}]})
    assert result == PASS
    path = write_config(tmp_path, free_port())
    data = yaml.safe_load(path.read_text())
    del data["calibration"]  # the scenario's calibration: the size is known only when the source is planned
    data["masks"] = {"image": [{"polygon": [[0, 0], [1000, 0], [0, 100]]}]}
    path.write_text(yaml.safe_dump(data))
    test = Selftest(path)
    assert test.check_config().result == PASS and test.check_calibration().result == PASS
    check = test.check_masks()
    assert check.result == FAIL and "masks.image[0].polygon[1]" in check.detail
