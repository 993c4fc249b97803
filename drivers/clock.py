"""Is the system clock synchronised? NMEA and Modbus carry UTC, so a free-running clock is a fault.

The kernel keeps the NTP discipline state that chrony, systemd-timesyncd or a GPS/PPS daemon
maintain: adjtimex(2) with no modes set only reads it, and returns TIME_ERROR (5) while the
clock is not synchronised (STA_UNSYNC). `SystemClock` asks the kernel; `VirtualClock` is told.
"""

from __future__ import annotations

import ctypes
import ctypes.util
from abc import ABC, abstractmethod

TIME_ERROR = 5  # adjtimex(2): the clock is not synchronised
TIMEX_BYTES = 256  # struct timex is 208 bytes on 64-bit Linux; modes (offset 0) = 0: read only


class Clock(ABC):
    """The system clock's synchronisation state."""

    @abstractmethod
    def synchronised(self) -> bool:
        """True while an NTP/PPS discipline keeps the clock in step with UTC."""


class SystemClock(Clock):
    def __init__(self) -> None:
        self._libc = ctypes.CDLL(ctypes.util.find_library("c"), use_errno=True)

    def synchronised(self) -> bool:
        buf = ctypes.create_string_buffer(TIMEX_BYTES)  # zeroed: modes = 0 reads without changing
        state = self._libc.adjtimex(buf)
        return 0 <= state < TIME_ERROR


class VirtualClock(Clock):
    def __init__(self, synchronised: bool = True) -> None:
        self.is_synchronised = synchronised

    def synchronised(self) -> bool:
        return self.is_synchronised
