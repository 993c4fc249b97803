"""Outputs fan-out: NMEA and Modbus see the same tracks with the same target numbers;
a Modbus server that cannot start is a counted, retried fault, never an exception."""

from __future__ import annotations

import time

import pynmea2

from drivers.modbus import ModbusServer, VirtualModbusServer
from drivers.serial_port import VirtualSerialPort
from edge.appliance.health import HealthMonitor, HealthState, Status, standard_stages
from edge.encode.registers import Identity, read_field
from edge.fix import ShipFix, TrackStatus
from edge.outputs.fanout import OUTPUT_STAGES, Outputs, firmware_version
from edge.outputs.nmea_serial import NmeaSerialOutput

T_NS = 1_790_000_000_000_000_000


def fix(track_id: int, range_m: float) -> ShipFix:
    return ShipFix(T_NS, track_id, TrackStatus.TRACKING, 10.0, 20.0, range_m, range_m, 200.0,
                   34.6, 135.0, 8.0, 90.0, 12.0, 5.0, age_s=3.0)


class Clock:
    def __init__(self) -> None:
        self.t_s = 0.0

    def __call__(self) -> float:
        return self.t_s


def wait_for(predicate, timeout_s: float = 3.0) -> bool:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.01)
    return predicate()


def test_nmea_and_modbus_carry_the_same_tracks_and_numbers() -> None:
    clock = Clock()
    health = HealthMonitor(standard_stages(OUTPUT_STAGES), clock=clock)
    port = VirtualSerialPort()
    nmea = NmeaSerialOutput("virtual", port=port, clock=clock)
    server = VirtualModbusServer()
    outputs = Outputs([nmea], health)
    outputs.add_modbus([server], Identity(firmware_version()), clock)
    outputs.start()
    fixes = [fix(5, 1500.0), fix(9, 2500.0)]
    outputs.publish(fixes, T_NS)
    assert wait_for(lambda: port.data().count(b"\r\n") >= 4)
    numbers = {}
    for line in port.data().decode().split("\r\n")[:-1]:
        msg = pynmea2.parse(line, check=True)
        if msg.sentence_type == "TTM":
            numbers[msg.name] = int(msg.target_number)
    slots = server.request(1, 4, 100, 20 * 2)  # FC4, the first two track slots
    assert isinstance(slots, list)
    image = [0] * 100 + slots
    for slot, fx in enumerate(fixes):
        assert read_field(image, "TRACK_ID", slot=slot) == fx.track_id
        assert read_field(image, "TARGET_NUMBER", slot=slot) == numbers[f"TRK{fx.track_id}"]
        assert read_field(image, "RANGE", slot=slot) == round(fx.range_m)
    stages = {s.name: s for s in health.snapshot().stages}
    assert stages["nmea"].fresh and stages["nmea"].fault is None
    assert stages["modbus"].fresh and stages["modbus"].fault is None
    outputs.close()


class RefusingServer(ModbusServer):
    """A Modbus server whose port is taken the first `refusals` times it is started."""

    def __init__(self, refusals: int) -> None:
        super().__init__("refusing")
        self.refusals = refusals
        self.attempts = 0
        self.images: list[tuple[int, ...]] = []

    def start(self) -> None:
        self.attempts += 1
        if self.attempts <= self.refusals:
            raise OSError(98, "Address already in use")

    def stop(self) -> None:
        pass

    def update(self, registers) -> None:
        self.images.append(tuple(registers))


def test_modbus_that_cannot_start_is_a_retried_fault_not_a_crash() -> None:
    clock = Clock()
    health = HealthMonitor(standard_stages(OUTPUT_STAGES), clock=clock)
    server = RefusingServer(refusals=2)
    outputs = Outputs([], health)
    outputs.add_modbus([server], Identity(firmware_version()), clock)
    outputs.start()  # attempt 1 fails
    outputs.publish([fix(1, 900.0)], T_NS)  # within back-off: no new attempt
    assert server.attempts == 1 and not server.images
    modbus = {s.name: s for s in health.snapshot().stages}["modbus"]
    assert "Address already in use" in modbus.fault and modbus.counters["start_failures"] == 1
    assert health.snapshot().state is not HealthState.OK
    clock.t_s = 1.5  # back-off 1 s elapsed: attempt 2 fails, back-off doubles
    outputs.publish([fix(1, 900.0)], T_NS)
    clock.t_s = 3.0  # 2 s back-off not yet over
    outputs.publish([fix(1, 900.0)], T_NS)
    assert server.attempts == 2
    clock.t_s = 3.6
    outputs.publish([fix(1, 900.0)], T_NS)
    assert server.attempts == 3 and len(server.images) == 1
    modbus = {s.name: s for s in health.snapshot().stages}["modbus"]
    assert modbus.fault is None


def test_health_stages_follow_the_configured_outputs() -> None:
    from edge.config.app import ModbusConfig, ModbusTcp, NmeaPort, OutputsConfig
    from edge.outputs.fanout import output_stages

    none = OutputsConfig(modbus=ModbusConfig(tcp=ModbusTcp(enabled=False)))
    assert output_stages(none) == []
    assert [n for n, _ in output_stages(none, extra_nmea=True)] == ["nmea"]
    full = OutputsConfig(nmea=(NmeaPort(url="loop://"),), tracks_csv="/tmp/x.csv")
    assert [n for n, _ in output_stages(full)] == ["nmea", "modbus", "tracks_csv"]


def test_tracks_csv_gets_every_fix_and_survives_a_missing_directory(tmp_path) -> None:
    import csv

    from edge.encode.tracks_csv import CSV_HEADER
    from edge.outputs.tracks_csv import TracksCsvOutput

    clock = Clock()
    health = HealthMonitor(standard_stages([("tracks_csv", Status(0))]), clock=clock)
    path = tmp_path / "later" / "tracks.csv"  # directory not there yet: a fault, retried
    csv_out = TracksCsvOutput(str(path))
    csv_out.file.retry_initial_s = csv_out.file.retry_max_s = 0.05
    outputs = Outputs([csv_out], health)
    outputs.start()
    outputs.publish([fix(1, 900.0)], T_NS)
    assert wait_for(lambda: csv_out.health()[0] is not None)
    outputs.publish([], T_NS)  # the writer found the fault asynchronously: the next step reports it
    assert {s.name: s for s in health.snapshot().stages}["tracks_csv"].fault
    path.parent.mkdir()
    outputs.publish([fix(1, 905.0), fix(2, 1800.0)], T_NS + 10**8)
    outputs.close()  # drains the queue
    rows = list(csv.DictReader(path.read_text().splitlines()))
    assert path.read_text().splitlines()[0] == CSV_HEADER
    assert [(r["track_id"], r["range_m"]) for r in rows] == [("1", "900.000"), ("1", "905.000"),
                                                             ("2", "1800.000")]
    assert outputs.sent["csv_rows"] == 3  # rows, not characters
    assert {s.name: s for s in health.snapshot().stages}["tracks_csv"].counters["csv_rows"] == 3


def test_every_output_keeps_the_contract_and_counts_in_its_own_unit(tmp_path) -> None:
    """Serial groups, UDP datagrams and CSV rows are counted apart (they were once summed into one
    'groups' counter), each output kind satisfies `Output`, and start() needs no kind checks."""
    import io

    from drivers.udp import VirtualUdpSender
    from edge.outputs.base import Output
    from edge.outputs.nmea_stream import NmeaStreamOutput
    from edge.outputs.nmea_udp import NmeaUdpOutput
    from edge.outputs.tracks_csv import TracksCsvOutput

    clock = Clock()
    health = HealthMonitor(standard_stages(OUTPUT_STAGES), clock=clock)
    port, udp = VirtualSerialPort(), VirtualUdpSender()
    outs = [NmeaSerialOutput("virtual", port=port, clock=clock), NmeaUdpOutput(sender=udp, clock=clock),
            NmeaStreamOutput(io.StringIO(), clock=clock), TracksCsvOutput(str(tmp_path / "t.csv"))]
    outputs = Outputs(outs, health)
    outputs.add_modbus([VirtualModbusServer()], Identity(firmware_version()), clock)
    assert all(isinstance(o, Output) for o in outputs.outputs)
    assert [o.stage for o in outputs.outputs] == ["nmea"] * 3 + ["tracks_csv", "modbus"]
    outputs.start()
    outputs.publish([fix(1, 900.0), fix(2, 1800.0)], T_NS)
    outputs.close()
    # two tracks: two TTM+TLL groups on serial and stream, four datagrams (one per sentence)
    assert dict(outputs.sent) == {"nmea_serial_groups": 2, "nmea_udp_datagrams": 4, "nmea_stream_groups": 2,
                                  "csv_rows": 2, "modbus_images": 1}
    nmea = {s.name: s for s in health.snapshot().stages}["nmea"].counters
    assert (nmea["nmea_serial_groups"], nmea["nmea_udp_datagrams"], nmea["nmea_stream_groups"]) == (2, 4, 2)


def test_refused_modbus_writes_are_counted_in_the_modbus_stage() -> None:
    clock = Clock()
    health = HealthMonitor(standard_stages(OUTPUT_STAGES), clock=clock)
    server = VirtualModbusServer()
    outputs = Outputs([], health)
    outputs.add_modbus([server], Identity(firmware_version()), clock)
    outputs.start()
    outputs.publish([fix(1, 900.0)], T_NS)
    assert server.request(1, 6, 0, values=[1]) == server.request(1, 16, 3, values=[1, 2]) == 2  # 02
    assert server.request(1, 4, 0, 2) is not None
    outputs.publish([fix(1, 900.0)], T_NS)
    modbus = {s.name: s for s in health.snapshot().stages}["modbus"]
    assert modbus.fault is None
    assert (modbus.counters["modbus_writes"], modbus.counters["modbus_requests"]) == (2, 3)
