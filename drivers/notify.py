"""Talking to systemd: READY=1, STATUS=..., WATCHDOG=1, STOPPING=1, RELOADING=1,
EXTEND_TIMEOUT_USEC=... (sd_notify(3)).

The unit runs with Type=notify and WatchdogSec: systemd waits for READY=1
before it calls the service started, shows STATUS= in `systemctl status`,
and restarts the daemon when WATCHDOG=1 stops arriving. `SystemdNotifier`
uses systemd-python (which reads $NOTIFY_SOCKET); outside systemd it sends
nothing and says so by returning False. `VirtualNotifier` records messages
for tests and the demo.
"""

from __future__ import annotations

import os
import time
from abc import ABC, abstractmethod


class Notifier(ABC):
    """Service-manager notifications; every call is cheap and never raises."""

    @abstractmethod
    def send(self, message: str) -> bool:
        """Send one sd_notify message (newline-separated KEY=VALUE lines); True if delivered."""

    def ready(self, status: str = "") -> bool:
        return self.send("READY=1" + (f"\nSTATUS={_one_line(status)}" if status else ""))

    def status(self, text: str) -> bool:
        return self.send(f"STATUS={_one_line(text)}")

    def watchdog(self) -> bool:
        return self.send("WATCHDOG=1")

    def stopping(self, status: str = "") -> bool:
        return self.send("STOPPING=1" + (f"\nSTATUS={_one_line(status)}" if status else ""))

    def reloading(self, status: str = "") -> bool:
        """RELOADING=1 with the CLOCK_MONOTONIC time systemd needs to order it (systemd >= 253)."""
        now_us = time.clock_gettime_ns(time.CLOCK_MONOTONIC) // 1000
        extra = f"\nSTATUS={_one_line(status)}" if status else ""
        return self.send(f"RELOADING=1\nMONOTONIC_USEC={now_us}{extra}")

    def extend_timeout(self, seconds: float, status: str = "") -> bool:
        """Ask for `seconds` more before systemd gives up on start-up (or stop)."""
        usec = int(seconds * 1e6)
        return self.send(f"EXTEND_TIMEOUT_USEC={usec}" + (f"\nSTATUS={_one_line(status)}" if status else ""))

    @staticmethod
    def watchdog_interval_s() -> float | None:
        """Half of systemd's WatchdogSec (from $WATCHDOG_USEC) when it is meant for us, else None."""
        usec, pid = os.environ.get("WATCHDOG_USEC"), os.environ.get("WATCHDOG_PID")
        if not usec or (pid and pid != str(os.getpid())):
            return None
        try:
            return int(usec) / 2e6 if int(usec) > 0 else None
        except ValueError:
            return None


class SystemdNotifier(Notifier):
    """sd_notify through systemd-python; a no-op (False) when $NOTIFY_SOCKET is unset."""

    def __init__(self) -> None:
        # imported here: only the real notifier needs libsystemd. (mypy sees the checkout's systemd/ unit
        # directory as a namespace package first; at run time the installed package wins.)
        from systemd import daemon  # type: ignore[attr-defined]

        self._notify = daemon.notify
        self.failures = 0

    def send(self, message: str) -> bool:
        if not os.environ.get("NOTIFY_SOCKET"):
            return False
        try:
            delivered = bool(self._notify(message))
        except OSError:
            delivered = False
        self.failures += not delivered
        return delivered


class VirtualNotifier(Notifier):
    """Keeps every message it is given, in order."""

    def __init__(self) -> None:
        self.messages: list[str] = []

    def send(self, message: str) -> bool:
        self.messages.append(message)
        return True


def _one_line(text: str) -> str:
    return " ".join(text.split())
