"""Errors the appliance reports to a person, with enough context to fix the cause.

A `ConfigError` always names the file, the key path inside it (e.g.
``outputs.nmea[0].baud``), what was expected and what was found. The CLI turns
it into one line on stderr and exit status 78 (EX_CONFIG), before any hardware
is touched.
"""

from __future__ import annotations

from pathlib import Path

EX_CONFIG = 78


class ConfigError(Exception):
    """A configuration, calibration or scenario file is unusable."""

    def __init__(self, file: str | Path | None, key: str, expected: str, found: object = None) -> None:
        self.file = str(file) if file is not None else "<no file>"
        self.key = key
        self.expected = expected
        self.found = found
        super().__init__(self.message)

    @property
    def message(self) -> str:
        where = f"{self.file}: {self.key}" if self.key else self.file
        text = f"{where}: expected {self.expected}"
        if self.found is not None:
            found = repr(self.found)
            if len(found) > 80:
                found = found[:77] + "..."
            text += f", found {found}"
        return text
