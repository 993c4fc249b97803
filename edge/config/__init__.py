"""Configuration and calibration files: loading, checking and documenting them.

`app` (the appliance configuration), `calibration` (rig and site files, also inside a recording),
`schema` (dataclass settings loaded from YAML with errors naming file and key), `table` (the
configuration table of docs/configuration.md, generated from the schema). Every mistake is a `ConfigError`.
"""
