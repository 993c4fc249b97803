"""An append-only text file written by its own thread: the per-fix tracks CSV of the daemon.

Built on `SerialPortBase`'s bounded drop-oldest queue and writer thread, so a
slow or full disk costs the writer, never the processing thread: a failed
open or write (disk full, directory gone) is counted, logged once and retried
with back-off, and rows queued meanwhile are kept up to the queue bound. A
new or empty file gets `header` first. `close(drain=True)` flushes what is
queued before stopping.
"""

from __future__ import annotations

import errno
from pathlib import Path
from typing import IO, Any

from drivers.serial_port import SerialPortBase


class AppendFile(SerialPortBase):
    """Lines appended to `path`; each submitted message is written and flushed as one unit."""

    def __init__(self, path: str | Path, header: bytes = b"", *, queue_max: int = 4096, **base: Any) -> None:
        super().__init__(str(path), queue_max=queue_max, **base)
        self.path = Path(path)
        self.header = header
        self._file: IO[bytes] | None = None

    def _open(self) -> None:
        f = self.path.open("ab")
        if self.header and f.tell() == 0:
            f.write(self.header)
            f.flush()
        self._file = f

    def _write(self, data: bytes) -> None:
        if self._file is None:
            raise OSError(errno.EBADF, "file not open")
        self._file.write(data)
        self._file.flush()

    def _close_port(self) -> None:
        f, self._file = self._file, None
        if f is not None:
            f.close()

    def _cancel(self) -> None:
        """File writes do not block on a peer; nothing to unblock."""
