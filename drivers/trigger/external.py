"""External trigger: pulses come from elsewhere at a known rate; nothing to drive.

For cameras wired to a sync generator and already in trigger mode (by their
firmware, a jumper or an earlier provisioning step). The rate is what the
pairer's tolerance and the health check ("a pulse every period") need. Give a
`camera_setup` (controls.TriggerControls) to arm the cameras as well; the
`controls` kind is that combination.
"""

from __future__ import annotations

from drivers.trigger.base import Trigger


class ExternalTrigger(Trigger):
    kind = "external"
