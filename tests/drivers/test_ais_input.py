"""AIS input driver kinds against real peers: a UDP socket sending datagrams (plain lines and
IEC 61162-450 framing), a TCP server behind a pyserial socket:// URL, and the virtual kind's
loss and reconnection; the queue is bounded and drops the oldest lines, counted."""

from __future__ import annotations

import socket
import threading
import time

from drivers.ais_input import SerialAisInput, UdpAisInput, VirtualAisInput

LINE = b"!AIVDM,1,1,,B,15M67FC000G?ufbE`FepT@3n00Sa,0*5C"


def _wait(pred, timeout_s: float = 3.0) -> bool:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if pred():
            return True
        time.sleep(0.01)
    return False


def _free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_udp_datagrams_become_lines_with_receive_times() -> None:
    port = _free_udp_port()
    src = UdpAisInput(port, "127.0.0.1", clock=lambda: 42)
    src.start()
    try:
        assert _wait(lambda: src.stats().connected)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as tx:
            tx.sendto(LINE + b"\r\n" + LINE + b"\r\n", ("127.0.0.1", port))
            tx.sendto(b"UdPbC\x00\\s:AI0001*5E\\" + LINE + b"\r\n", ("127.0.0.1", port))
            tx.sendto(LINE[:20], ("127.0.0.1", port))  # a datagram ends its line, even without CR LF
        got: list[tuple[int, bytes]] = []
        assert _wait(lambda: got.extend(src.drain()) or len(got) >= 4)
        assert [t for t, _ in got] == [42] * 4
        assert got[0][1] == LINE and got[2][1].endswith(LINE) and got[3][1] == LINE[:20]
    finally:
        src.close()


def test_serial_url_reads_lines_and_reconnects() -> None:
    server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    server.bind(("127.0.0.1", 0))
    server.listen(2)
    port = server.getsockname()[1]
    conns: list[socket.socket] = []
    threading.Thread(target=lambda: [conns.append(server.accept()[0]) for _ in range(2)], daemon=True).start()
    src = SerialAisInput(f"socket://127.0.0.1:{port}", 38400)
    src.start()
    try:
        assert _wait(lambda: len(conns) == 1)
        conns[0].sendall(LINE[:10])
        conns[0].sendall(LINE[10:] + b"\r\n" + LINE + b"\n")
        got: list[tuple[int, bytes]] = []
        assert _wait(lambda: got.extend(src.drain()) or len(got) >= 2)
        assert [line for _, line in got] == [LINE, LINE]
        conns[0].close()  # the receiver goes away: a counted fault, then it comes back
        assert _wait(lambda: src.stats().errors >= 1, 5.0)
        assert _wait(lambda: len(conns) == 2, 10.0)
        assert _wait(lambda: src.stats().connected and src.stats().reconnects >= 1, 5.0)
        conns[1].sendall(LINE + b"\n")
        assert _wait(lambda: bool(src.drain()))
    finally:
        src.close()
        server.close()
        for c in conns:
            c.close()


def test_virtual_queue_is_bounded_and_loss_is_counted() -> None:
    src = VirtualAisInput(max_lines=10)
    src.set_present(False)
    src.start()
    try:
        assert _wait(lambda: src.stats().errors >= 1) and src.stats().fault is not None
        src.set_present(True)
        assert _wait(lambda: src.stats().connected and src.stats().fault is None)
        src.push(b"".join(b"line%d\n" % k for k in range(25)))
        assert _wait(lambda: src.stats().lines == 25)
        lines = [line for _, line in src.drain()]
        assert lines == [b"line%d" % k for k in range(15, 25)] and src.stats().dropped == 15
        src.push(b"x" * 2000)  # a line without an end for too long is cut, counted
        assert _wait(lambda: src.stats().overlong == 3)
        src.push(b"y" * 600 + b"\n")  # ... and so is a complete line too long to be a sentence
        assert _wait(lambda: src.stats().overlong == 4)
    finally:
        src.close()
