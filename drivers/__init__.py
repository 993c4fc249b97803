"""Hardware-facing drivers (cameras, trigger, serial, Modbus, LEDs, sd_notify).

Every driver kind has a base class, a real implementation and a virtual one used
by tests and the demo. Nothing here imports `edge`.
"""
