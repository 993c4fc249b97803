"""SysfsLedPanel against a fake /sys/class/leds tree of real files: trigger detached, brightness
written as 0 / max_brightness, missing and vanished LEDs warned about once and found again."""

from __future__ import annotations

import logging
import shutil
from pathlib import Path

import pytest

from drivers.leds.base import AMBER_LED, FAULT_LED, OK_LED
from drivers.leds.sysfs import SysfsLedPanel

MS = 1_000_000
S = 1000 * MS
NAMES = {OK_LED: "mast:green:ok", FAULT_LED: "mast:red:fault"}


def make_led(root: Path, name: str, max_brightness: int = 255, trigger: str = "none [heartbeat]") -> Path:
    d = root / name
    d.mkdir(parents=True)
    (d / "max_brightness").write_text(f"{max_brightness}\n")
    (d / "brightness").write_text("0\n")
    (d / "trigger").write_text(trigger + "\n")
    return d


def brightness(root: Path, name: str) -> str:
    return (root / name / "brightness").read_text()


@pytest.fixture
def tree(tmp_path: Path) -> Path:
    make_led(tmp_path, NAMES[OK_LED])
    make_led(tmp_path, NAMES[FAULT_LED], max_brightness=1)
    return tmp_path


def test_heartbeat_writes_max_brightness_and_zero_after_detaching_the_trigger(tree: Path) -> None:
    panel = SysfsLedPanel(NAMES, root=tree)
    assert not panel.has_amber
    panel.show_health("OK")
    seen = []
    t = 7 * S
    while t <= 8 * S:
        t = panel.tick(t)
        seen.append(brightness(tree, NAMES[OK_LED]))
    assert (tree / NAMES[OK_LED] / "trigger").read_text() == "none"
    assert seen == ["255", "0", "255", "0", "255"]
    assert brightness(tree, NAMES[FAULT_LED]) == "0"
    assert panel.present() == {OK_LED: True, FAULT_LED: True}
    assert panel.counters() == {"led_writes": 6, "led_errors": 0}


def test_stalled_is_steady_red_and_close_leaves_red_on(tree: Path) -> None:
    panel = SysfsLedPanel(NAMES, root=tree)
    panel.show_health("STALLED")
    panel.tick(0)
    assert (brightness(tree, NAMES[OK_LED]), brightness(tree, NAMES[FAULT_LED])) == ("0", "1")
    panel.show_health("OK")
    panel.tick(10 * MS)
    assert (brightness(tree, NAMES[OK_LED]), brightness(tree, NAMES[FAULT_LED])) == ("255", "0")
    panel.close(now_ns=20 * MS)
    assert (brightness(tree, NAMES[OK_LED]), brightness(tree, NAMES[FAULT_LED])) == ("0", "1")


def test_degraded_uses_a_dedicated_amber_led_when_configured(tree: Path) -> None:
    make_led(tree, "mast:amber:status")
    panel = SysfsLedPanel({**NAMES, AMBER_LED: "mast:amber:status"}, root=tree)
    assert panel.has_amber
    panel.show_health("DEGRADED")
    panel.tick(0)
    assert [brightness(tree, n) for n in (*NAMES.values(), "mast:amber:status")] == ["0", "0", "255"]
    panel.tick(250 * MS)
    assert brightness(tree, "mast:amber:status") == "0"


def test_an_empty_amber_name_means_no_amber_led(tree: Path) -> None:
    panel = SysfsLedPanel({**NAMES, AMBER_LED: ""}, root=tree)
    assert panel.roles == (OK_LED, FAULT_LED)
    panel.show_health("DEGRADED")
    panel.tick(0)
    assert [brightness(tree, n) for n in NAMES.values()] == ["255", "1"]


def test_a_missing_led_warns_once_and_is_picked_up_when_it_appears(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    make_led(tmp_path, NAMES[OK_LED])
    panel = SysfsLedPanel(NAMES, root=tmp_path, retry_s=2.0)
    panel.show_health("STALLED")
    with caplog.at_level(logging.WARNING, logger="drivers.leds.sysfs"):
        t = 0
        for t in range(0, 5 * S, 100 * MS):
            panel.tick(t)
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1 and "mast:red:fault not found" in warnings[0]
    assert panel.present() == {OK_LED: True, FAULT_LED: False}
    assert panel.counters()["led_errors"] == 3  # looked for at 0, 2 and 4 s, not at every tick
    make_led(tmp_path, NAMES[FAULT_LED])
    with caplog.at_level(logging.INFO, logger="drivers.leds.sysfs"):
        panel.tick(t + 2 * S)
    assert brightness(tmp_path, NAMES[FAULT_LED]) == "255"
    assert "mast:red:fault is back" in caplog.text


def test_a_vanished_led_is_not_an_error_for_the_caller(tree: Path, caplog: pytest.LogCaptureFixture) -> None:
    panel = SysfsLedPanel(NAMES, root=tree, retry_s=1.0)
    panel.show_health("OK")
    panel.tick(0)
    shutil.rmtree(tree / NAMES[OK_LED])
    with caplog.at_level(logging.WARNING, logger="drivers.leds.sysfs"):
        for t in range(100 * MS, 3 * S, 50 * MS):
            panel.tick(t)
    assert [r.getMessage() for r in caplog.records].count(
        "LED mast:green:ok cannot write its brightness: No such file or directory; its pattern is not shown "
        "(looking again every 1 s)") == 1
    assert panel.present()[OK_LED] is False


def test_an_unwritable_trigger_is_tolerated(tree: Path, caplog: pytest.LogCaptureFixture) -> None:
    trigger = tree / NAMES[OK_LED] / "trigger"
    trigger.unlink()
    trigger.mkdir()  # opening a directory for writing fails even as root
    panel = SysfsLedPanel(NAMES, root=tree)
    panel.show_health("OK")
    with caplog.at_level(logging.WARNING, logger="drivers.leds.sysfs"):
        panel.tick(0)
        panel.tick(100 * MS)
    assert brightness(tree, NAMES[OK_LED]) == "0"
    assert caplog.text.count("cannot set its trigger") == 1
