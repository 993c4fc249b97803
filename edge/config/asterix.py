"""The `outputs.asterix` block of the appliance configuration: ASTERIX CAT 010 target
reports and status over UDP, to a multicast group or a unicast address, optionally with CAT 034.

The schema checks the values (addresses, ports, TTL, SAC/SIC); `check_asterix` checks at start,
on this machine, that a configured interface exists (a name known to the kernel, or a local IPv4
address), so a typo exits 78 naming the key instead of sending nowhere. No socket is bound and
nothing listens: the output only sends (docs/asterix-icd.md).
"""

from __future__ import annotations

import errno
import ipaddress
import socket
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from edge.config.schema import setting
from edge.errors import ConfigError


def _destination(value: str) -> str | None:
    try:
        address = ipaddress.IPv4Address(value)
    except ValueError:
        return "an IPv4 multicast group (239.0.0.0/8: organisation-local) or unicast address"
    if address.is_unspecified or address == ipaddress.IPv4Address("255.255.255.255"):
        return "a multicast group or a unicast address (not 0.0.0.0 or a broadcast address)"
    return None


@dataclass(frozen=True)
class AsterixDestination:
    address: str = setting("239.255.10.1", check=_destination,
                           doc="multicast group (239.0.0.0/8 is organisation-local) or unicast IPv4 address")
    port: int = setting(8600, min=1, max=65535,
                        doc="UDP port (no standard ASTERIX port; 8600 is Wireshark's default)")
    ttl: int = setting(1, min=0, max=255, doc="IP TTL (multicast hops: 1 stays on the local network)")
    interface: str | None = setting(
        None, doc="multicast only: outgoing interface by name (eth0) or local IPv4 address; null: the routes")


@dataclass(frozen=True)
class AsterixConfig:
    enabled: bool = setting(False, doc="send ASTERIX CAT 010 target reports and status over UDP")
    sac: int = setting(0, min=0, max=255, doc="System Area Code (I010/010), assigned by the VTS operator")
    sic: int = setting(1, min=0, max=255, doc="System Identification Code (I010/010), one per mast")
    target_type: Literal["psr", "other"] = setting(
        "psr", doc="I010/020 TYP: psr (a non-cooperative sensor, as radars send) or other (7)")
    tracks: AsterixDestination = setting(default_factory=AsterixDestination,
                                         doc="where the target reports go")
    status: AsterixDestination | None = setting(
        None, doc="where status (and CAT 034) messages go; null: with the target reports")
    status_period_s: float = setting(1.0, min=0.1, max=60.0, doc="periodic status (type 3) interval, s")
    start_of_update: bool = setting(False, doc="a start-of-update-cycle record (type 2) before each update")
    cat034: bool = setting(False, doc="also a CAT 034 service message (I034/050, /120) each status period")
    send_acquiring: bool = setting(True, doc="report tentative (Q) tracks too, with I010/170 CNF set")
    quarantine_s: float = setting(60.0, min=0.0, max=3600.0,
                                  doc="a track number stays unused this long after its track ended")
    overload_latency_s: float = setting(
        0.5, positive=True, max=60.0, doc="I010/550 OVL while pairs are dropped or later than this, s")


def _check_interface(dest: AsterixDestination, file: str | Path | None, key: str) -> None:
    if dest.interface is None:
        return
    if not ipaddress.IPv4Address(dest.address).is_multicast:
        raise ConfigError(file, f"{key}.interface", "null for a unicast address (the routes choose)",
                          dest.interface)
    try:
        local = ipaddress.IPv4Address(dest.interface)
    except ValueError:
        try:
            socket.if_nametoindex(dest.interface)
        except OSError:
            raise ConfigError(file, f"{key}.interface", "a network interface of this machine",
                              dest.interface) from None
        return
    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        probe.bind((str(local), 0))  # released at once: only asks whether the address is ours
    except OSError as exc:
        if exc.errno == errno.EADDRNOTAVAIL:
            raise ConfigError(file, f"{key}.interface", "a local IPv4 address of this machine",
                              dest.interface) from None
        raise
    finally:
        probe.close()


def check_asterix(cfg: AsterixConfig, file: str | Path | None) -> None:
    """At start, before any hardware: the configured interfaces exist here (ConfigError naming
    `outputs.asterix.tracks.interface` or `.status.interface` otherwise)."""
    if not cfg.enabled:
        return
    _check_interface(cfg.tracks, file, "outputs.asterix.tracks")
    if cfg.status is not None:
        _check_interface(cfg.status, file, "outputs.asterix.status")
