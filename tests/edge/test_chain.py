"""edge.chain: the daemon and `replay` run one chain, so a recording gives the same bytes either way.

The same recording goes through `replay` and through the daemon (`Appliance`, the replay camera
source, unpaced), with the daemon's tracks CSV output and an NMEA stream clocked by the pairs; the
daemon's UTC anchor is pinned to the recording's first pair so that its TTM/TLL times match
replay's. NMEA and CSV must agree byte for byte.
"""

from __future__ import annotations

import io
import threading
from pathlib import Path

import yaml

from drivers.camera.replay import read_frames
from drivers.notify import VirtualNotifier
from edge.appliance.daemon import Appliance
from edge.config.app import load_config
from edge.outputs.nmea_stream import NmeaStreamOutput
from edge.replay import replay


def _daemon(tmp_path: Path, root: Path, alerts: bool) -> tuple[str, str]:
    csv_path = tmp_path / "daemon.csv"
    path = tmp_path / "appliance.yaml"
    path.write_text(yaml.safe_dump({
        "cameras": {"kind": "replay", "path": str(root), "pace": False},
        "outputs": {"modbus": {"tcp": {"enabled": False}}, "tracks_csv": str(csv_path)},
        "alerts": {"enabled": alerts},
    }))
    path.chmod(0o644)
    nmea = io.StringIO()
    stream = NmeaStreamOutput(nmea, clock=None, newline="\r\n")
    app = Appliance.build(load_config(path), path, VirtualNotifier(), extra_nmea=[stream])
    first_t_ns = read_frames(root)[0][1]
    app.wall_clock_ns = lambda: first_t_ns  # UTC = the recording's clock, as replay reports it
    assert app.run(threading.Event(), seconds=120) == 0
    return nmea.getvalue(), csv_path.read_text()


def test_daemon_and_replay_send_the_same_bytes(tmp_path: Path, recording) -> None:
    root = recording("akashi-crossing", 40)
    nmea, tracks = io.StringIO(), io.StringIO()
    summary = replay(root, nmea=nmea, tracks=tracks)
    assert summary.csv_rows > 20 and summary.nmea_lines >= 4  # ships tracked and reported: a real comparison
    daemon_nmea, daemon_csv = _daemon(tmp_path, root, alerts=False)
    # then the daemon sends every live track once more as lost when it stops (replay has no such end)
    assert daemon_csv.startswith(tracks.getvalue())
    tail = daemon_csv[len(tracks.getvalue()):].splitlines()
    assert tail and all(row.split(",")[2] == "L" for row in tail)
    assert daemon_nmea.startswith(nmea.getvalue())
    assert all(line.startswith(("$RATTM", "$RATLL")) for line in daemon_nmea[len(nmea.getvalue()):].split())
