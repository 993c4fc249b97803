"""Fault case for the maintenance page: an HTTP garbage flood against a running daemon.

`http-garbage-flood`: a real `mast-stereo run` (replaying a recording at its frame rate, the page
on loopback with a token) takes `CONNECTIONS` hostile connections from `WORKERS` threads: random
bytes, a request head past the size bound, a head that never ends (slowloris), a valid request line
with broken headers, a wrong token, a request whose answer is never read, connect-and-close, a
TLS ClientHello. Meanwhile a probe asks the page for /state.json with the right token every 0.5 s.

Pass: the pair rate during the flood is within 10 % of the rate before it (the daemon's own
counter, read from /metrics before and after each window); the page answered at least one probe
during the flood and answers after it; the daemon's page counters show the flood was refused and
bounded (refused connections, 400/401/431, timeouts), and the daemon is still running.
"""

from __future__ import annotations

import base64
import os
import random
import socket
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from collections import Counter
from pathlib import Path

import yaml

from lab.faults._rig import free_port
from lab.faults.matrix import Case, Row

CONNECTIONS = 2000
WORKERS = 32
WINDOW_S = 6.0  # the rate windows before and after
TOKEN = "flood-test-token-0123456789abcdef"
KINDS = ("random", "too-large", "slowloris", "bad-headers", "wrong-token", "never-reads", "connect-close",
         "tls-hello")


def _garbage(kind: str, rng: random.Random, port: int) -> bytes:
    if kind == "random":
        return rng.randbytes(rng.randint(1, 2000))
    if kind == "too-large":
        return b"GET / HTTP/1.1\r\n" + b"X-Junk: " + b"a" * 20000 + b"\r\n\r\n"
    if kind == "slowloris":
        return b"GET /state.json HTTP/1.1\r\nHost: x\r\n"  # never finished
    if kind == "bad-headers":
        return b"GET /metrics HTTP/1.1\r\n\x00\xff: \x01\r\n:::\r\n" + rng.randbytes(50) + b"\r\n\r\n"
    if kind == "wrong-token":
        return b"GET /metrics HTTP/1.1\r\nAuthorization: Bearer wrong\r\n\r\n"
    if kind == "never-reads":
        auth = base64.b64encode(f"x:{TOKEN}".encode()).decode()
        return f"GET /left.jpg HTTP/1.1\r\nAuthorization: Basic {auth}\r\n\r\n".encode()
    if kind == "tls-hello":
        return bytes.fromhex("16030100a5010000a10303") + rng.randbytes(160)
    return b""  # connect-close


def _hit(kind: str, rng: random.Random, port: int) -> str:
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=3) as s:
            s.sendall(_garbage(kind, rng, port))
            if kind in ("slowloris", "never-reads"):
                time.sleep(rng.uniform(0.5, 2.0))  # hold a slot, read nothing
                return "held"
            s.settimeout(1.5)
            try:
                answer = s.recv(64)
            except (TimeoutError, ConnectionResetError):
                return "no answer"
            return answer.split(b"\r\n", 1)[0].decode(errors="replace")[:20] or "closed"
    except OSError as exc:
        return type(exc).__name__


def flood(port: int, connections: int = CONNECTIONS, workers: int = WORKERS, seed: int = 28) -> Counter[str]:
    """`connections` garbage connections from `workers` threads; what came back, counted."""
    seen: Counter[str] = Counter()
    lock = threading.Lock()
    todo = list(range(connections))

    def work(k: int) -> None:
        rng = random.Random(seed * 1000 + k)
        while True:
            with lock:
                if not todo:
                    return
                n = todo.pop()
            got = _hit(KINDS[n % len(KINDS)], rng, port)
            with lock:
                seen[got] += 1

    threads = [threading.Thread(target=work, args=(k,), daemon=True) for k in range(workers)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return seen


def get(port: int, path: str, token: str | None = TOKEN, timeout_s: float = 3.0) -> bytes:
    req = urllib.request.Request(f"http://127.0.0.1:{port}{path}",
                                 headers={} if token is None else {"Authorization": f"Bearer {token}"})
    with urllib.request.urlopen(req, timeout=timeout_s) as r:
        return bytes(r.read())


def processed(port: int) -> tuple[float, int]:
    """(monotonic time, pairs processed) from /metrics, retried while the page is busy."""
    from prometheus_client.parser import text_string_to_metric_families

    for _ in range(40):
        try:
            text = get(port, "/metrics").decode()
        except (OSError, urllib.error.URLError):
            time.sleep(0.25)
            continue
        for family in text_string_to_metric_families(text):
            if family.name == "mast_pairs":
                for s in family.samples:
                    if s.labels.get("result") == "processed":
                        return time.monotonic(), int(s.value)
    raise RuntimeError("/metrics never answered")


def write_config(workdir: Path, recording: Path, port: int) -> Path:
    token = workdir / "page.token"
    token.write_text(TOKEN + "\n")
    token.chmod(0o600)
    cfg = {"cameras": {"kind": "replay", "path": str(recording), "pace": True, "loop": True},
           "outputs": {"modbus": {"tcp": {"enabled": False}}},
           "health": {"require_clock_sync": False, "min_fps": 0.0, "leds": {"kind": "none"},
                      "state_dir": str(workdir / "state")},
           "page": {"enabled": True, "port": port, "token_file": str(token), "docs_dir": None}}
    path = workdir / "flood.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


def http_garbage_flood(workdir: Path, recording: Path | None = None,
                       connections: int = CONNECTIONS) -> list[Row]:
    if recording is None:
        from lab.faults._recording import render_clean

        recording = render_clean(workdir / "rec")
    port = free_port()
    config = write_config(workdir, recording, port)
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "edge.cli", "run", "--config", str(config)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env)
    try:
        t_start, _ = processed(port)
        time.sleep(2.0)  # past the start
        t0, n0 = processed(port)
        time.sleep(WINDOW_S)
        t1, n1 = processed(port)
        before_hz = (n1 - n0) / (t1 - t0)
        answered, probes = 0, 0
        stop = threading.Event()

        def probe() -> None:
            nonlocal answered, probes
            while not stop.is_set():
                probes += 1
                try:
                    get(port, "/state.json")
                    answered += 1
                except (OSError, urllib.error.URLError):
                    pass
                stop.wait(0.5)

        prober = threading.Thread(target=probe, daemon=True)
        prober.start()
        f0 = time.monotonic()
        seen = flood(port, connections)
        flood_s = time.monotonic() - f0
        stop.set()
        prober.join()
        t2, n2 = processed(port)
        during_hz = (n2 - n1) / (t2 - t1)
        page_after = b'"health"' in get(port, "/state.json")
        metrics = get(port, "/metrics").decode()
        refused = sum(float(line.rsplit(" ", 1)[1]) for line in metrics.splitlines()
                      if line.startswith("mast_page_total{") and any(
                          k in line for k in ("refused", "status_4", "timeouts", "incomplete", "status_501")))
        alive = proc.poll() is None
    finally:
        proc.terminate()
        try:
            _, err = proc.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            _, err = proc.communicate()
    change = (during_hz - before_hz) / before_hz if before_hz else float("inf")
    top = ", ".join(f"{k} {v}" for k, v in seen.most_common(4))
    return [
        Row(f"{connections} garbage HTTP connections ({flood_s:.1f} s)", "pair rate within 10 %",
            f"{before_hz:.2f} -> {during_hz:.2f} pairs/s ({100 * change:+.1f} %)", abs(change) <= 0.10),
        Row("page during and after the flood", "answers the probe; answers after",
            f"{answered}/{probes} probes answered during; after: {'yes' if page_after else 'no'}",
            answered > 0 and page_after),
        Row("flood refused and bounded", "counted refusals, daemon running, no traceback",
            f"{refused:.0f} refused/4xx/timeouts; running {alive}; answers: {top}"[:200],
            refused >= connections * 0.5 and alive and "Traceback" not in err and t_start > 0),
    ]


CASES = [Case("http-garbage-flood", "page", http_garbage_flood)]
