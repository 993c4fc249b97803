"""tools/bench's scene layout: as many ships as asked, each a blob of its own for the detector."""

from __future__ import annotations

import pytest

import lab.bench.pipeline as bench_tool
from edge.config.calibration import calibration_from_dict
from edge.sim.ships import ShipModel


def _bench():
    return bench_tool


@pytest.mark.parametrize("size", [720, 2048])
def test_layout_rows_are_clear_and_ships_apart(size: int) -> None:
    bench = _bench()
    ships = bench.layout(size, 32)
    assert len(ships) == 32
    cal = calibration_from_dict(bench._calibration(size), "bench")
    f, h = cal.rig.focal_px(), cal.site.height_m
    length_px, _, gap_px = bench.LAYOUT[size]
    rows: dict[float, list[float]] = {}
    for s in ships:
        (x, z), _ = s["track"]["waypoints_m"]
        assert s["length_m"] * f / z == pytest.approx(length_px, rel=0.01)   # the same size in the image
        assert length_px >= 20                                               # above the detector's minimum
        rows.setdefault(z, []).append(x * f / z)
    spans = []  # (top, bottom) rows below the horizon of each row of ships (flat-sea estimate)
    for z in sorted(rows):
        top_m = float(ShipModel.build(bench.SHIP_KIND, 20.0).extent_local[1, 2]) / 20.0 * length_px * z / f
        spans.append(((h - top_m) * f / z, h * f / z))
        cols = sorted(rows[z])
        assert min(b - a for a, b in zip(cols, cols[1:], strict=False)) >= bench.SPACING * length_px - 1e-6
        assert max(abs(c) for c in cols) + length_px / 2 <= cal.rig.width / 2
    for (top, _), (_, bottom) in zip(spans, spans[1:], strict=False):
        assert top - bottom >= gap_px                                        # rows clear of each other


@pytest.mark.parametrize("argv, message", [
    (["--sizes", "720x480"], "expected comma-separated integers"),
    (["--sizes", "1024"], "1024 is not one of (720, 2048)"),
    (["--tracks", "8,0"], "0 is not a positive integer"),
])
def test_bad_sizes_and_counts_are_refused_by_name(argv: list[str], message: str,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    """A width without a calibration used to be benched on the 2048 one, and a typo ended in a
    traceback: both are now argparse errors naming the option."""
    with pytest.raises(SystemExit) as stop:
        _bench().main(argv)
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert message in err and argv[0] in err
