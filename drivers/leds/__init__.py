"""Status LEDs on the mast's enclosure: patterns (off, on, blink, heartbeat) driven by the daemon's loop."""
