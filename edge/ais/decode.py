"""AIS lines -> position and static reports, with multi-part assembly and counted failures.

Input is one text line as received (serial, a UDP datagram's line, a recording's `ais.csv`),
with its receive time. What is accepted: `!xxVDM`/`!xxVDO` sentences, optionally behind an
IEC 61162-450 `UdPbC\\0` header and a `\\...\\` tag block. Decoding is pyais's (MIT); assembly of
multi-part messages is ours, because a live stream interleaves fragments of several messages and
loses some: fragments are keyed by (channel, sequence id, fragment count) and a message is
decoded once all its fragments have arrived; a partial message older than FRAGMENT_TIMEOUT_S,
or one whose key starts again at fragment 1, is dropped and counted.

Nothing here raises on bad input: every line ends in exactly one counter (`AisCounters`), so
garbage on the input costs a counter increment and never the tracking.

Used: types 1/2/3 (class A position), 18/19 (class B position; 19 also carries static data),
5 (class A static and voyage) and 24 (class B static, parts A and B). Other types decode but are
counted as `unused`. "Not available" values (SOG 102.3 kn, COG 360, heading 511, lat 91, lon 181)
become None; a position report without a position is counted as `no_position`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from pyais.exceptions import AISBaseException
from pyais.messages import AISSentence

FRAGMENT_TIMEOUT_S = 2.0  # the fragments of one message come within a few slots (ms)
MAX_LINE_CHARS = 200  # a VDM sentence is at most 82; room for a tag block
MAX_PARTIAL = 64  # messages being assembled at once (a flood of first fragments cannot grow memory)
POSITION_TYPES = {1: "A", 2: "A", 3: "A", 18: "B", 19: "B"}


@dataclass(frozen=True, slots=True)
class PositionReport:
    """One AIS position report, at its receive time `t_ns` (the input's clock)."""

    t_ns: int
    mmsi: int
    ais_class: str  # "A" or "B"
    lat_deg: float
    lon_deg: float
    sog_kn: float | None
    cog_deg: float | None
    heading_deg: float | None
    accurate: bool  # position accuracy flag: 1 = better than 10 m (DGNSS)


@dataclass(frozen=True, slots=True)
class StaticReport:
    """Static data (type 5, 19, 24): any of name and antenna offsets A/B/C/D (m) may be unknown."""

    t_ns: int
    mmsi: int
    name: str | None = None
    to_bow_m: float | None = None  # A
    to_stern_m: float | None = None  # B
    to_port_m: float | None = None  # C
    to_starboard_m: float | None = None  # D


Report = PositionReport | StaticReport


@dataclass
class AisCounters:
    lines: int = 0  # lines offered
    decoded: int = 0  # messages decoded and used (position or static)
    checksum_errors: int = 0
    malformed: int = 0  # not an AIS sentence, bad fields, payload pyais cannot decode
    unknown_type: int = 0  # a message type pyais does not know
    unused: int = 0  # a valid message of a type we do not use (4, 21, 27, ...)
    incomplete: int = 0  # multi-part messages dropped with fragments missing
    no_position: int = 0  # position reports whose lat/lon say "not available"
    too_old: int = 0  # position reports dropped for age (counted by the target table)
    input_errors: int = 0  # driver faults (port gone, queue full: lines lost)

    def as_dict(self) -> dict[str, int]:
        return dict(vars(self))


@dataclass
class _Partial:
    t_s: float
    parts: dict[int, AISSentence] = field(default_factory=dict)


def sentence_text(line: str | bytes) -> str | None:
    """The `!..VDM`/`!..VDO` sentence in a received line, or None: a 61162-450 header, a tag
    block and line endings are stripped."""
    if isinstance(line, bytes):
        line = line.decode("ascii", errors="replace")
    line = line.strip()
    if line.startswith("UdPbC"):
        line = line[5:].lstrip("\0")
    if line.startswith("\\"):
        end = line.find("\\", 1)
        line = line[end + 1:] if end > 0 else ""
    if len(line) > MAX_LINE_CHARS or not line.startswith("!") or line[3:6] not in ("VDM", "VDO"):
        return None
    return line


class AisDecoder:
    """Feed lines in receive order; get the reports they complete."""

    def __init__(self) -> None:
        self.counters = AisCounters()
        self._partial: dict[tuple[str, int | None, int], _Partial] = {}

    def feed(self, line: str | bytes, t_ns: int) -> list[Report]:
        c = self.counters
        c.lines += 1
        text = sentence_text(line)
        if text is None:
            c.malformed += 1
            return []
        try:
            sentence = AISSentence(text.encode("ascii", errors="replace"))
        except (AISBaseException, ValueError, IndexError, TypeError):
            c.malformed += 1
            return []
        if not sentence.is_valid:
            c.checksum_errors += 1
            return []
        t_s = t_ns / 1e9
        self._expire(t_s)
        if sentence.frag_cnt == 1:
            return self._decode(sentence, t_ns)
        key = (sentence.channel, sentence.seq_id, sentence.frag_cnt)
        partial = self._partial.get(key)
        if partial is not None and (sentence.frag_num == 1 or sentence.frag_num in partial.parts):
            c.incomplete += 1  # the key started over: the earlier message lost a fragment
            partial = None
        if partial is None:
            if len(self._partial) >= MAX_PARTIAL:
                oldest = min(self._partial, key=lambda k: self._partial[k].t_s)
                del self._partial[oldest]
                c.incomplete += 1
            partial = self._partial[key] = _Partial(t_s)
        partial.parts[sentence.frag_num] = sentence
        if len(partial.parts) < sentence.frag_cnt:
            return []
        del self._partial[key]
        try:
            whole = AISSentence.assemble_from_iterable([partial.parts[k] for k in sorted(partial.parts)])
        except (AISBaseException, ValueError, IndexError, TypeError):
            c.malformed += 1
            return []
        return self._decode(whole, t_ns)

    def flush(self) -> None:
        """Drop every message still being assembled (counted as incomplete)."""
        self.counters.incomplete += len(self._partial)
        self._partial.clear()

    def _expire(self, t_s: float) -> None:
        old = [k for k, p in self._partial.items() if t_s - p.t_s > FRAGMENT_TIMEOUT_S or t_s < p.t_s]
        for k in old:
            del self._partial[k]
        self.counters.incomplete += len(old)

    def _decode(self, sentence: AISSentence, t_ns: int) -> list[Report]:
        c = self.counters
        try:
            msg = sentence.decode()
        except AISBaseException as exc:
            if type(exc).__name__ == "UnknownMessageException":
                c.unknown_type += 1
            else:
                c.malformed += 1
            return []
        except (ValueError, IndexError, TypeError, KeyError, AttributeError):
            c.malformed += 1
            return []
        try:
            reports = _reports(msg, t_ns)
        except (ValueError, TypeError, AttributeError):
            c.malformed += 1
            return []
        if reports is None:
            c.unused += 1
            return []
        if not reports:
            c.no_position += 1
            return []
        c.decoded += 1
        return reports


def _known(value: object, na: float) -> float | None:
    if value is None or not isinstance(value, int | float):
        return None
    return None if abs(float(value) - na) < 1e-6 else float(value)


def _name(value: object) -> str | None:
    if not isinstance(value, str):
        return None
    name = value.replace("@", " ").strip()
    return name or None


def _dims(msg: object) -> dict[str, float | None]:
    """A/B/C/D; all zero means "not available" (ITU-R M.1371 reference point)."""
    a, b, c, d = (getattr(msg, k, None) for k in ("to_bow", "to_stern", "to_port", "to_starboard"))
    values = [float(v) if isinstance(v, int | float) else None for v in (a, b, c, d)]
    if all(v in (None, 0.0) for v in values):
        values = [None] * 4
    return dict(zip(("to_bow_m", "to_stern_m", "to_port_m", "to_starboard_m"), values, strict=True))


def _reports(msg: object, t_ns: int) -> list[Report] | None:
    """The reports in a decoded message: None for a type we do not use, [] for a position report
    without a position."""
    kind = int(getattr(msg, "msg_type", -1))
    mmsi = int(getattr(msg, "mmsi", 0))
    out: list[Report] = []
    if kind in POSITION_TYPES:
        lat, lon = _known(getattr(msg, "lat", None), 91.0), _known(getattr(msg, "lon", None), 181.0)
        if lat is None or lon is None or abs(lat) > 90.0 or abs(lon) > 180.0:
            return []
        cog = _known(getattr(msg, "course", None), 360.0)
        out.append(PositionReport(
            t_ns, mmsi, POSITION_TYPES[kind], lat, lon, _known(getattr(msg, "speed", None), 102.3),
            None if cog is None or cog > 360.0 else cog, _known(getattr(msg, "heading", None), 511.0),
            bool(getattr(msg, "accuracy", False))))
        if kind == 19:
            out.append(StaticReport(t_ns, mmsi, _name(getattr(msg, "shipname", None)), **_dims(msg)))
        return out
    if kind == 5:
        return [StaticReport(t_ns, mmsi, _name(getattr(msg, "shipname", None)), **_dims(msg))]
    if kind == 24:
        if int(getattr(msg, "partno", -1)) == 0:
            return [StaticReport(t_ns, mmsi, _name(getattr(msg, "shipname", None)))]
        return [StaticReport(t_ns, mmsi, None, **_dims(msg))]
    return None
