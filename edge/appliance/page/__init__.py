"""The read-only maintenance page and /metrics, served by the daemon on its own threads (docs/page.md).

picture.py draws and encodes the live pictures (off the processing thread), state.py gathers what
the page shows, metrics.py renders the daemon's counters for Prometheus, server.py is the bounded
HTTP server with the token check; `Page` (page.py) ties them to a running `Appliance`. Nothing here
is imported while `page.enabled` is false.
"""
