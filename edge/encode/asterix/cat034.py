"""Optional CAT 034 service messages (edition 1.27 as common decoders read it) for VTSs that
expect them next to CAT 010: one North-marker message (I034/000 = 1) per status period, with
I034/010 SAC/SIC, /030 time of day, /050 system status (COM: NOGO, OVL RDP, TSV) and /120 the
sensor's position and height. The camera does not rotate: the North marker stands for the
periodic service message a radar sends once a scan.
"""

from __future__ import annotations

from edge.encode.asterix.blocks import record
from edge.encode.asterix.cat010 import SensorStatus, Source
from edge.encode.asterix.items import (
    Nogo,
    data_source,
    message_type,
    sensor_position,
    service_status,
    time_of_day,
)

CATEGORY = 34
NORTH_MARKER = 1
FRN = {"010": 1, "000": 2, "030": 3, "050": 6, "120": 11}


def service_message(source: Source, utc_ns: int, status: SensorStatus,
                    site: tuple[float, float, float] | None) -> bytes:
    """One North-marker record; `site` is (lat deg, lon deg, height m above the ellipsoid) or None.
    I034/050 NOGO is set unless the sensor is operational (CAT 034 has one NOGO bit)."""
    items = {FRN["010"]: data_source(source.sac, source.sic), FRN["000"]: message_type(NORTH_MARKER),
             FRN["030"]: time_of_day(utc_ns),
             FRN["050"]: service_status(nogo=status.nogo is not Nogo.OPERATIONAL, overload=status.overload,
                                        time_invalid=status.time_invalid)}
    if site is not None:
        items[FRN["120"]] = sensor_position(*site)
    return record(items)
