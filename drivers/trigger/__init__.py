"""Camera triggers: what makes both cameras expose at the same instant, and what the pairer may expect.

- `controls`: the cameras are put into external-trigger mode through named V4L2
  controls (a camera-model adapter: Alvium, Vision Components, ...); pulses come
  from outside at `rate_hz`;
- `gpio`: we generate the pulses on a GPIO line (chardev v2 uAPI), optionally
  also switching the cameras into trigger mode by controls;
- `external`: pulses come from elsewhere and the cameras are set up already;
- `none`: free-running cameras, paired by nearest timestamp only;
- `virtual`: a software pulse train for tests and the demo (drives fake devices).

`trigger_from_config(mapping)` (config.py) builds one from the `trigger:` block.
"""
