"""Fault injection: the daemon run through what a harbour throws at it, as a PASS/FAIL matrix.

`matrix` holds the row and case types, the discovery of cases and `tools/faults`'s table;
each other module of this package holds one group of cases as a module-level `CASES` list
(cameras and trigger, outputs and Modbus, inputs, lifecycle). `tests/faults/` runs the same
cases under pytest, so the matrix a technician prints is the one CI checks.
"""
