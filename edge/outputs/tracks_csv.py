"""`outputs.tracks_csv`: every fix appended to a CSV file, the same columns as `replay --tracks`.

Rows go through `drivers.append_file.AppendFile` (its own writer thread, a
bounded queue, retries when the disk comes back), so a slow disk never holds
up processing. On shutdown the queue is drained.
"""

from __future__ import annotations

from collections.abc import Iterable

from drivers.append_file import AppendFile
from edge.fix import ShipFix
from edge.replay import CSV_HEADER, csv_row


class TracksCsvOutput:
    """`publish`/`health`/`close` like the other outputs."""

    def __init__(self, path: str, *, file: AppendFile | None = None) -> None:
        self.file = file if file is not None else AppendFile(path, (CSV_HEADER + "\n").encode("ascii"))

    def start(self) -> TracksCsvOutput:
        self.file.start()
        return self

    def publish(self, fixes: Iterable[ShipFix]) -> int:
        rows = "".join(csv_row(fx) + "\n" for fx in fixes)
        if rows:
            self.file.submit(rows.encode("ascii"))
        return len(rows)

    def health(self) -> tuple[str | None, dict[str, int]]:
        st = self.file.stats()
        fault = "tracks CSV not writable" if st.fault else None
        return fault, {"csv_bytes": st.written_bytes, "csv_dropped": st.dropped, "csv_errors": st.errors}

    def close(self) -> None:
        self.file.close(drain=True)
