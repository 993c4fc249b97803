"""Build a Trigger from the `trigger:` block of a `cameras:` config (examples in config/cameras/).

```
trigger:
  kind: controls | gpio | external | none
  rate_hz: 10                    # pulses per second (none: the cameras' fps)
  camera: {model: alvium, activation: rising, ...}   # controls.TriggerControls; required for controls
  chip: /dev/gpiochip0           # gpio only: the chip, the line offset, the pulse
  line: 17
  pulse_width_ms: 2
  active_low: false
  realtime_priority: 50          # gpio only, optional: SCHED_FIFO for the pulse thread
```
Unknown keys are refused with their names, so a typo cannot silently free-run a camera.
"""

from __future__ import annotations

from collections.abc import Mapping

from drivers.trigger.base import Trigger
from drivers.trigger.controls import ControlsTrigger, trigger_controls
from drivers.trigger.external import ExternalTrigger
from drivers.trigger.gpio import GpioTrigger
from drivers.trigger.none import FreeRunning

KEYS = {
    "none": {"kind", "rate_hz"},
    "external": {"kind", "rate_hz", "camera"},
    "controls": {"kind", "rate_hz", "camera"},
    "gpio": {
        "kind",
        "rate_hz",
        "camera",
        "chip",
        "line",
        "pulse_width_ms",
        "active_low",
        "realtime_priority",
    },
}


def trigger_from_config(block: Mapping | None, *, fps: float | None = None) -> Trigger:
    """The trigger a config block describes; `fps` is the cameras' rate (the default rate_hz)."""
    block = dict(block or {"kind": "none"})
    kind = str(block.get("kind", "none"))
    if kind not in KEYS:
        raise ValueError(f"trigger kind {kind!r} is not one of {', '.join(KEYS)}")
    unknown = set(block) - KEYS[kind]
    if unknown:
        raise ValueError(f"trigger kind {kind}: unknown key(s) {', '.join(sorted(unknown))}")
    rate = block.get("rate_hz", fps)
    if rate is None:
        raise ValueError(f"trigger kind {kind} needs rate_hz (or the cameras' fps)")
    setup = trigger_controls(block["camera"]) if block.get("camera") else None
    if kind == "none":
        return FreeRunning(float(rate))
    if kind == "external":
        return ExternalTrigger(float(rate), camera_setup=setup)
    if kind == "controls":
        if setup is None:
            raise ValueError("trigger kind controls needs a camera: block (model and controls)")
        return ControlsTrigger(float(rate), setup)
    for key in ("chip", "line"):
        if key not in block:
            raise ValueError(f"trigger kind gpio needs {key}")
    return GpioTrigger(
        str(block["chip"]),
        int(block["line"]),
        float(rate),
        pulse_width_s=float(block.get("pulse_width_ms", 1.0)) / 1e3,
        active_low=bool(block.get("active_low", False)),
        camera_setup=setup,
    )
