"""Alerts a VTS operator acts on (issue 18): close quarters, new/lost/dark targets, capacity and
appliance faults; their state (`manager`), their IEC 61162-1 sentences per NMEA port (`port`)."""
