"""Fake devices for tests and benchmarks: a V4L2 kernel interface in memory, with no hardware."""
