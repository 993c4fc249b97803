"""Pure output formats: fixes and health in, text or register values out, no I/O.

`nmea` (TTM/TLL/TXY sentences, tag blocks), `targets` (NMEA target numbers lent to track ids),
`registers` (the Modbus map and its snapshot), `tracks_csv` (the per-fix CSV, docs/outputs.md).
The transports that carry them live in `edge.outputs`.
"""
