"""The AIS input in the running appliance (real UDP datagrams into `Appliance`) and in `replay`
(a simulated recording's ais.csv through the same stage)."""

from __future__ import annotations

import shutil
import socket
import threading
import time
from pathlib import Path

import yaml
from pyais import encode_dict

from drivers.notify import VirtualNotifier
from edge.appliance.daemon import Appliance
from edge.config.app import load_config
from edge.recording.format import read_ais, write_ais
from edge.replay import replay


def _free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_appliance_takes_ais_over_udp_as_its_own_health_stage(tmp_path: Path, recording) -> None:
    port = _free_udp_port()
    path = tmp_path / "appliance.yaml"
    path.write_text(
        yaml.safe_dump(
            {
                "cameras": {
                    "kind": "replay",
                    "path": str(recording("akashi-crossing", 30)),
                    "pace": True,
                    "loop": True,
                },
                "outputs": {"modbus": {"tcp": {"enabled": False}}},
                "health": {"min_fps": 0.0},
                "ais": {"input": {"kind": "udp", "port": port, "host": "127.0.0.1"}},
            }
        )
    )
    app = Appliance.build(load_config(path), path, VirtualNotifier())
    assert app.ais is not None
    stop = threading.Event()
    runner = threading.Thread(target=app.run, args=(stop,), daemon=True)
    runner.start()
    line = encode_dict(
        {"type": 1, "mmsi": 431000123, "lat": 34.6, "lon": 135.0}, talker_id="AI", sentence_type="VDM"
    )[0]
    try:
        end = time.monotonic() + 30
        counters: dict[str, int] = {}
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as tx:
            while time.monotonic() < end and counters.get("decoded", 0) < 3:
                tx.sendto(line.encode() + b"\r\n" + b"garbage\r\n", ("127.0.0.1", port))
                time.sleep(0.2)
                stage = next((s for s in app.health.snapshot().stages if s.name == "ais"), None)
                counters = dict(stage.counters) if stage is not None else {}
        assert counters["decoded"] >= 3 and counters["malformed"] >= 3 and counters["targets"] == 1
        assert app.steps > 0  # pairs went on being processed
    finally:
        stop.set()
        runner.join(timeout=5.0)


def test_replay_feeds_the_recordings_ais_csv(tmp_path: Path, recording) -> None:
    """An ais.csv added to a recording (the cached akashi one, copied): every line goes through the
    stage, garbage counted; a recording without one replays without an AIS stage."""
    src = recording("akashi-crossing", 30)
    assert replay(src).ais is None and read_ais(src) is None
    root = tmp_path / "rec"
    shutil.copytree(src, root)
    good = encode_dict({"type": 1, "mmsi": 431000123, "lat": 34.6, "lon": 135.0}, talker_id="AI",
                       sentence_type="VDM")[0]
    write_ais(root, [(0, good), (100_000_000, good[:-2] + "00"), (200_000_000, "not,an,ais,line"),
                     (1_000_000_000, good)])
    lines = read_ais(root)
    assert lines is not None and [t for t, _ in lines] == [0, 100_000_000, 200_000_000, 1_000_000_000]
    summary = replay(root)
    assert summary.ais is not None
    c = summary.ais.counters
    assert (c.lines, c.decoded, c.malformed) == (4, 2, 1) and c.checksum_errors == (good[-2:] != "00")
    assert any(line.startswith("AIS: lines 4") for line in summary.lines())
