"""The AIS input in the running appliance (real UDP datagrams into `Appliance`) and in `replay`
(a simulated recording's ais.csv through the same stage)."""

from __future__ import annotations

import socket
import threading
import time
from pathlib import Path

import yaml
from pyais import encode_dict

from drivers.notify import VirtualNotifier
from edge.config.app import load_config
from edge.daemon import Appliance
from edge.replay import replay
from edge.sim.recording import read_ais


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


def test_replay_feeds_the_recordings_ais_csv(recording) -> None:
    root = recording("harbour-mix", 45)  # 9 s at 5 fps: the coaster reports at 8.3 s
    lines = read_ais(root)
    assert (
        lines and all(s.startswith("!AIVDM") for _, s in lines) and lines == sorted(lines, key=lambda r: r[0])
    )
    summary = replay(root)
    assert summary.ais is not None
    c = summary.ais.counters
    assert c.lines == len(lines) and c.malformed == c.checksum_errors == 0 and c.decoded >= 1
    assert any(line.startswith("AIS: lines") for line in summary.lines())
