"""Camera-model adapters: put a camera into external-trigger mode through named V4L2 controls.

There is no standard V4L2 trigger control; each vendor invents one
(research/v4l2.md §3), so the adapter is data: which controls to set, to
which values, in which order, and how the activation edge is spelled.
Controls are addressed by their v4l2-ctl names, never by vendor ids, on the
camera's sub-device when it has them there, else on the video node
(`V4L2Camera.set_control` does that lookup).

Presets (override any field in the config):

- `alvium` (Allied Vision Alvium CSI-2): trigger_source = Line0,
  trigger_activation = a menu (Rising Edge, Falling Edge, Any Edge, Level High,
  Level Low), then trigger_mode = true; released with trigger_mode = false.
- `vc-mipi` (Vision Components): trigger_mode = 1 (external; 0 is free-running).
  The edge is not a control of its own (io_mode sets polarity, per model):
  only `activation: rising` is accepted unless `activation_control` is given.

The mode control is set last, so the camera never waits for pulses with a half-set configuration.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace

from drivers.trigger.base import ControlTarget, Trigger

EDGES = ("rising", "falling", "any", "high", "low")


@dataclass(frozen=True)
class TriggerControls:
    """The controls that arm one camera model for external triggering."""

    model: str
    mode_control: str = "trigger_mode"
    mode_value: object = True
    free_run_value: object | None = False  # written at release; None leaves the mode alone
    activation: str = "rising"
    activation_control: str | None = None
    activation_items: Mapping[str, object] = field(default_factory=dict)  # edge -> menu item (or value)
    settings: Mapping[str, object] = field(default_factory=dict)  # set first, in order (trigger_source...)

    def __post_init__(self) -> None:
        if self.activation not in EDGES:
            raise ValueError(f"activation {self.activation!r} is not one of {', '.join(EDGES)}")
        if self.activation_control is None and self.activation != "rising":
            raise ValueError(
                f"{self.model}: no activation control configured, so only a rising edge is possible"
            )
        if self.activation_control is not None and self.activation not in self.activation_items:
            raise ValueError(f"{self.model}: activation {self.activation!r} has no item in activation_items")

    def plan(self) -> list[tuple[str, object]]:
        """(control, value) in the order they are written."""
        steps = list(self.settings.items())
        if self.activation_control is not None:
            steps.append((self.activation_control, self.activation_items[self.activation]))
        steps.append((self.mode_control, self.mode_value))
        return steps

    def apply(self, camera: ControlTarget) -> None:
        for name, value in self.plan():
            camera.set_control(name, value)

    def release(self, camera: ControlTarget) -> None:
        if self.free_run_value is not None and camera.has_control(self.mode_control):
            camera.set_control(self.mode_control, self.free_run_value)

    def describe(self) -> str:
        return f"{self.model} ({', '.join(f'{n}={v}' for n, v in self.plan())})"


ALVIUM_EDGES = {
    "rising": "Rising Edge",
    "falling": "Falling Edge",
    "any": "Any Edge",
    "high": "Level High",
    "low": "Level Low",
}
PRESETS: dict[str, TriggerControls] = {
    "alvium": TriggerControls(
        "alvium",
        activation_control="trigger_activation",
        activation_items=ALVIUM_EDGES,
        settings={"trigger_source": "Line0"},
    ),
    "vc-mipi": TriggerControls("vc-mipi", mode_value=1, free_run_value=0),
}
FIELDS = (
    "mode_control",
    "mode_value",
    "free_run_value",
    "activation",
    "activation_control",
    "activation_items",
    "settings",
)


def trigger_controls(config: Mapping) -> TriggerControls:
    """A TriggerControls from a config mapping: `model` (a preset or 'custom') plus any field overridden."""
    model = str(config.get("model", "custom"))
    unknown = set(config) - {"model", *FIELDS}
    if unknown:
        raise ValueError(f"unknown camera trigger setting(s): {', '.join(sorted(unknown))}")
    base = PRESETS.get(model)
    if base is None and model != "custom":
        raise ValueError(f"camera model {model!r} has no preset (presets: {', '.join(PRESETS)}, or custom)")
    overrides = {k: config[k] for k in FIELDS if k in config}
    return replace(base, **overrides) if base else TriggerControls(model, **overrides)


class ControlsTrigger(Trigger):
    """Cameras armed by controls; the pulses come from outside (a sync box, the mast's PLC) at rate_hz."""

    kind = "controls"

    def __init__(self, rate_hz: float, camera_setup: TriggerControls) -> None:
        super().__init__(rate_hz, camera_setup=camera_setup)
