"""The configured status LEDs as a driver panel: none, the kernel's LED class devices, or a virtual one.

Shared by the daemon (which drives them from health) and selftest (which checks they can be lit).
"""

from __future__ import annotations

from drivers.leds.base import AMBER_LED, FAULT_LED, OK_LED, LedPanel
from drivers.leds.sysfs import SysfsLedPanel
from drivers.leds.virtual import VirtualLedPanel
from edge.config.app import LedsConfig


def build_leds(cfg: LedsConfig) -> LedPanel | None:
    """The configured status LEDs: none, the kernel's LED class devices, or a recording panel."""
    if cfg.kind == "none":
        return None
    roles = {OK_LED: cfg.ok, FAULT_LED: cfg.fault, **({AMBER_LED: cfg.amber} if cfg.amber else {})}
    if cfg.kind == "virtual":
        return VirtualLedPanel(tuple(roles))
    return SysfsLedPanel(roles, root=cfg.root)
