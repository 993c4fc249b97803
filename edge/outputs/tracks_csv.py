"""`outputs.tracks_csv`: every fix appended to a CSV file, the same columns as `replay --tracks`.

Rows go through `drivers.append_file.AppendFile` (its own writer thread, a
bounded queue, retries when the disk comes back), so a slow disk never holds
up processing. On shutdown the queue is drained.
"""

from __future__ import annotations

from collections.abc import Iterable

from drivers.append_file import AppendFile
from edge.encode.tracks_csv import CSV_HEADER, csv_row
from edge.fix import ShipFix


class TracksCsvOutput:
    """Appends one CSV row per fix; an `Output` like the others."""

    stage = "tracks_csv"
    unit = "csv_rows"

    def __init__(self, path: str, *, file: AppendFile | None = None) -> None:
        self.file = file if file is not None else AppendFile(path, (CSV_HEADER + "\n").encode("ascii"))

    def start(self) -> None:
        self.file.start()

    def publish(self, fixes: Iterable[ShipFix], utc_ns: int = 0) -> list[str]:
        rows = [csv_row(fx) + "\n" for fx in fixes]
        if rows:
            self.file.submit("".join(rows).encode("ascii"))
        return rows

    def health(self) -> tuple[str | None, dict[str, int]]:
        st = self.file.stats()
        fault = "tracks CSV not writable" if st.fault else None
        return fault, {"csv_bytes": st.written_bytes, "csv_dropped": st.dropped, "csv_errors": st.errors}

    def close(self) -> None:
        self.file.close(drain=True)
