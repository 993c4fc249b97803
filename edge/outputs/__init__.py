"""Outputs of the appliance: each turns the live `ShipFix` list into bytes for one transport.

Every output is fed from the processing thread once per step (`publish`) and
must never block it: rate limiting, queueing and I/O retries live here and in
the drivers, never in the pipeline.
"""
