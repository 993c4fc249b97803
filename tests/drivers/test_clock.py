"""clock: the kernel's answer is read, never changed; it matches adjtimex's state word."""

from __future__ import annotations

import ctypes
import ctypes.util

from drivers.clock import TIME_ERROR, SystemClock, VirtualClock


def test_system_clock_reads_the_kernel_state_without_changing_it() -> None:
    libc = ctypes.CDLL(ctypes.util.find_library("c"))
    state = libc.adjtimex(ctypes.create_string_buffer(256))
    assert SystemClock().synchronised() == (0 <= state < TIME_ERROR)
    assert libc.adjtimex(ctypes.create_string_buffer(256)) == state  # reading changed nothing


def test_virtual_clock_says_what_it_is_told() -> None:
    assert VirtualClock().synchronised() and not VirtualClock(False).synchronised()
