"""drivers.serial_port input (read_lines): lines split on CR/LF, bounded, garbage counted."""

from __future__ import annotations

import time

from drivers.serial_port import MAX_LINE_BYTES, MAX_RECEIVED, VirtualSerialPort


def _collect(port: VirtualSerialPort, want: int, timeout_s: float = 3.0) -> list[str]:
    got: list[str] = []
    end = time.monotonic() + timeout_s
    while len(got) < want and time.monotonic() < end:
        got += port.received()
        time.sleep(0.01)
    return got


def test_lines_split_across_reads_and_line_ends() -> None:
    port = VirtualSerialPort(read_lines=True)
    port.start()
    try:
        port.feed(b"$IIACN,1")
        time.sleep(0.05)
        port.feed(b",2*00\r\n$A*00\n\r\n$B*00\r")
        got = _collect(port, 3)
    finally:
        port.close()
    assert got == ["$IIACN,1,2*00", "$A*00", "$B*00"]
    assert port.stats().received_lines == 3


def test_garbage_and_overflow_are_dropped_and_counted() -> None:
    port = VirtualSerialPort(read_lines=True)
    port.feed(b"x" * (MAX_LINE_BYTES + 1) + b"\n" + b"".join(b"$L%d\n" % k for k in range(MAX_RECEIVED + 5)))
    port.start()
    try:
        end = time.monotonic() + 3.0
        while port.stats().received_lines < MAX_RECEIVED + 5 and time.monotonic() < end:
            time.sleep(0.01)
        got = port.received()
    finally:
        port.close()
    assert len(got) == MAX_RECEIVED and got[-1] == f"$L{MAX_RECEIVED + 4}"  # the newest kept
    assert port.stats().received_dropped == 1 + 5


def test_without_read_lines_nothing_is_read() -> None:
    port = VirtualSerialPort()
    port.feed(b"$A*00\r\n")
    port.start()
    try:
        time.sleep(0.3)
        assert port.received() == [] and port.stats().received_lines == 0
    finally:
        port.close()
