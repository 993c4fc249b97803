"""Boots the appliance VM once and runs tests/hw there (vivid cameras, gpio-sim); each guest test must pass.

The guest session's junit report (written into the shared project directory)
gives one host assertion per guest test, so a failure names the guest test and
carries its message; a guest test that skipped counts as a failure here (in the
VM every hardware test must run).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest
from vm.vmharness import ROOT, guest_pytest, unavailable_reason

EXPECTED = {
    "test_two_cameras_capture_with_sequence_and_monotonic_timestamps",
    "test_pixel_formats_give_the_same_grey_pattern[GREY]",
    "test_pixel_formats_give_the_same_grey_pattern[Y16]",
    "test_pixel_formats_give_the_same_grey_pattern[YUYV]",
    "test_unoffered_size_names_what_vivid_offers",
    "test_percentage_of_dropped_buffers_shows_as_counted_drops",
    "test_disconnect_faults_the_camera_and_the_source_reconnects",
    "test_gpio_trigger_rate_and_pulse_width_on_the_sim",
    "test_daemon_on_vivid_survives_a_camera_unplug",
    "test_record_from_vivid_gives_a_recording_replay_accepts",
}


@pytest.fixture(scope="module")
def guest_results() -> tuple[dict[str, tuple[str, str, str]], str, float]:
    reason = unavailable_reason()
    if reason:
        pytest.skip(reason)
    out_dir = ROOT / ".vm-results"
    out_dir.mkdir(exist_ok=True)
    junit = out_dir / "capture-junit.xml"
    junit.unlink(missing_ok=True)
    run = guest_pytest(["tests/hw"], junit, timeout_s=600)
    assert junit.exists(), f"the guest session wrote no report (exit {run.returncode}):\n{run.output[-4000:]}"
    results = {}
    for case in ET.parse(junit).getroot().iter("testcase"):
        outcome = next((c.tag for c in case if c.tag in ("failure", "error", "skipped")), "passed")
        detail = next(
            (c.get("message", "") + "\n" + (c.text or "") for c in case if c.tag != "system-out"), ""
        )
        printed = "".join(c.text or "" for c in case if c.tag == "system-out")
        results[case.get("name")] = (outcome, detail, printed)
    return results, run.output, run.wall_s


def test_every_hardware_test_ran_in_the_guest(guest_results) -> None:
    results, output, wall_s = guest_results
    assert set(results) == EXPECTED, output[-3000:]
    print(f"VM session: {wall_s:.1f} s wall")


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_guest(guest_results, name: str) -> None:
    results, output, _ = guest_results
    outcome, detail, printed = results.get(name, ("missing", output[-3000:], ""))
    assert outcome == "passed", f"{name}: {outcome}\n{detail[-3000:]}"
    if printed.strip():
        print(printed.strip())  # the guest test's measurements (pytest -s or -rA shows them)
