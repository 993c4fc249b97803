"""UDP datagram senders (IEC 61162-450 multicast output), never blocking the caller.

`send()` is called from the processing thread. The socket is non-blocking, so
a full send buffer drops the datagram (counted) instead of waiting: UDP is
lossy by design and IEC 61162-450 receivers detect losses from the tag
block's line counter. A failing socket (interface gone, network unreachable)
is closed, counted, flagged as a fault and logged once per outage; it is
reopened on a later send after an exponential backoff, and its return is
logged once.

`MulticastUdpSender` is the real implementation (multicast group or unicast
address, outgoing interface by name or IPv4 address, TTL, loopback);
`VirtualUdpSender` records datagrams in memory and can fail on demand.
"""

from __future__ import annotations

import abc
import errno
import ipaddress
import logging
import socket
import struct
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class UdpStats:
    """Counters of one sender since it was created."""

    fault: bool  # the socket failed and is waiting to be reopened
    sent_datagrams: int
    sent_bytes: int
    dropped: int  # not sent: buffer full, or the socket was down
    errors: int
    reconnects: int


class UdpSenderBase(abc.ABC):
    """Counting, log-once fault handling and reopen backoff; subclasses do the socket I/O."""

    def __init__(
        self,
        name: str,
        *,
        retry_initial_s: float = 0.5,
        retry_max_s: float = 10.0,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.name = name
        self.retry_initial_s = retry_initial_s
        self.retry_max_s = retry_max_s
        self._clock = clock
        self._lock = threading.Lock()
        self._open_now = False
        self._fault = False
        self._retry_at = 0.0
        self._delay_s = retry_initial_s
        self._counts = dict.fromkeys(("sent_datagrams", "sent_bytes", "dropped", "errors", "reconnects"), 0)

    def send(self, datagram: bytes) -> bool:
        """Send one datagram without blocking; False if it was dropped."""
        with self._lock:
            if not self._open_now:
                if self._clock() < self._retry_at:
                    self._counts["dropped"] += 1
                    return False
                try:
                    self._open()
                except OSError as exc:
                    self._failed("open", exc)
                    self._counts["dropped"] += 1
                    return False
                self._open_now = True
            try:
                self._send(datagram)
            except BlockingIOError:
                self._counts["dropped"] += 1
                return False
            except OSError as exc:
                self._failed("send", exc)
                self._counts["dropped"] += 1
                self._close_quietly()
                return False
            self._counts["sent_datagrams"] += 1
            self._counts["sent_bytes"] += len(datagram)
            if self._fault:
                self._counts["reconnects"] += 1
                log.info("UDP output %s is back after %d errors in all", self.name, self._counts["errors"])
            self._fault = False
            self._delay_s = self.retry_initial_s
            return True

    @property
    def healthy(self) -> bool:
        return not self._fault

    def stats(self) -> UdpStats:
        with self._lock:
            return UdpStats(fault=self._fault, **self._counts)

    def close(self) -> None:
        with self._lock:
            self._close_quietly()

    def _failed(self, what: str, exc: OSError) -> None:
        self._counts["errors"] += 1
        if not self._fault:
            log.warning("UDP output %s failed (%s: %s); retrying with backoff", self.name, what, exc)
        self._fault = True
        self._retry_at = self._clock() + self._delay_s
        self._delay_s = min(2 * self._delay_s, self.retry_max_s)

    def _close_quietly(self) -> None:
        self._open_now = False
        try:
            self._close_socket()
        except OSError:
            pass

    @abc.abstractmethod
    def _open(self) -> None:
        """Create the socket; raise OSError if that is impossible now."""

    @abc.abstractmethod
    def _send(self, datagram: bytes) -> None:
        """Send one datagram; BlockingIOError if the buffer is full, OSError on failure."""

    @abc.abstractmethod
    def _close_socket(self) -> None:
        """Close the socket (may be called when it is already closed)."""


class MulticastUdpSender(UdpSenderBase):
    """Sends to ``group:port``; multicast options are set when `group` is a multicast address.

    `interface` selects the outgoing interface by name (``eth0``, resolved at
    each open so a re-plugged interface works again) or IPv4 address; None
    lets the routing table choose.
    """

    def __init__(
        self,
        group: str,
        port: int,
        *,
        interface: str | None = None,
        ttl: int = 1,
        loopback: bool = True,
        **base: Any,
    ) -> None:
        address = ipaddress.IPv4Address(group)  # raises ValueError for a bad address
        if not 0 < port < 65536 or not 0 <= ttl <= 255:
            raise ValueError(f"need 0 < port < 65536 and 0 <= ttl <= 255, got {port}, {ttl}")
        super().__init__(f"{group}:{port}", **base)
        self.destination = (group, port)
        self.multicast = address.is_multicast
        self.interface = interface
        self.ttl = ttl
        self.loopback = loopback
        self._socket: socket.socket | None = None

    def _open(self) -> None:
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
        try:
            sock.setblocking(False)
            if self.multicast:
                sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, self.ttl)
                sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_LOOP, int(self.loopback))
                if self.interface is not None:
                    sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_IF, self._interface_option())
            else:
                sock.setsockopt(socket.IPPROTO_IP, socket.IP_TTL, max(self.ttl, 1))
        except OSError:
            sock.close()
            raise
        self._socket = sock

    def _interface_option(self) -> bytes:
        assert self.interface is not None  # only called when an interface is configured
        try:
            return socket.inet_aton(str(ipaddress.IPv4Address(self.interface)))
        except ValueError:
            index = socket.if_nametoindex(self.interface)  # OSError if the interface is absent
            return struct.pack("4s4si", bytes(4), bytes(4), index)  # struct ip_mreqn (Linux)

    def _send(self, datagram: bytes) -> None:
        if self._socket is None:
            raise OSError(errno.EBADF, "socket not open")
        self._socket.sendto(datagram, self.destination)

    def _close_socket(self) -> None:
        sock, self._socket = self._socket, None
        if sock is not None:
            sock.close()


class VirtualUdpSender(UdpSenderBase):
    """Records datagrams in memory; `set_present(False)` makes opens and sends fail (ENETDOWN)."""

    def __init__(self, name: str = "virtual-udp", **base: Any) -> None:
        super().__init__(name, **base)
        self.datagrams: list[bytes] = []
        self._present = True

    def set_present(self, present: bool) -> None:
        self._present = present

    def _open(self) -> None:
        if not self._present:
            raise OSError(errno.ENETDOWN, "virtual network down")

    def _send(self, datagram: bytes) -> None:
        if not self._present:
            raise OSError(errno.ENETDOWN, "virtual network down")
        self.datagrams.append(bytes(datagram))

    def _close_socket(self) -> None:
        pass
