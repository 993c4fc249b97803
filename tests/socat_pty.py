"""Test helper: the socat pty pair and reader process, from `lab.faults.serial_rig` (shared with
`tools/faults`); kept under this name for the serial tests that import it."""

from lab.faults.serial_rig import SocatPair, reader_lines, start_reader

__all__ = ["SocatPair", "reader_lines", "start_reader"]
