"""The appliance runtime: the daemon and what it keeps running beside the pipeline.

The daemon (threads, watchdog, reload), its state file with persistence, health and the LED
panel, the console table, the journal, the capture hand-over, the frame sources and the
technician's selftest. Nothing here computes a fix: that is `edge.chain`.
"""
