"""NMEA target numbers (01-99) for internal track ids, with a quarantine before reuse.

ASTERIX I010/161 track numbers (1-4095) are lent by the same rules (edge.outputs.asterix).

TTM/TLL carry a 2-digit target number, but track ids are never reused and
grow without bound, so numbers must be lent out and taken back. OpenCPN keys a
target by ``199200000 + number``: a number reused too soon would join an old
ship's trail to a new one. So a number goes through

    free --assign--> live --release (drop)--> lost --retire (last L sent)--> quarantine --> free

and stays in quarantine for `quarantine_s` (default 60 s) after the last
sentence that used it. Free numbers are lent least-recently-used first (then
lowest first), which keeps reuse as rare as possible.

All numbers busy (99 live, lost or in quarantine): a new track gets **no**
number, and the caller does not send it on NMEA (it still appears in Modbus,
which has no such limit). Live tracks never lose their numbers and quarantine
is never shortened, because both would merge two ships in a receiver. The
caller counts and logs the wait; when a number frees, the caller's next
request gets it, and callers ask for waiting tracks in ascending track id, so
the oldest waiting track is served first.

A track that comes back while its number is lost or in quarantine gets the
same number again (it is the same ship).

Across a restart (`edge.appliance.state`): `held` lists what is not free, `hold` puts a number into
quarantine with no owner (the previous run's), and `version` changes whenever the set of
numbers lent or held changes, so the caller saves the state only then.
"""

from __future__ import annotations

import math


class TargetNumbers:
    """Lends target numbers 1..`max_number` to track ids; no I/O, the clock is passed in."""

    def __init__(self, max_number: int = 99, quarantine_s: float = 60.0) -> None:
        if not 1 <= max_number <= 4095:  # NMEA: up to 999 (3 digits); ASTERIX I010/161: 12 bits
            raise ValueError(f"max_number must be 1..4095, got {max_number}")
        if quarantine_s < 0:
            raise ValueError(f"quarantine_s must be >= 0, got {quarantine_s}")
        self.max_number = max_number
        self.quarantine_s = quarantine_s
        self.digits = 2 if max_number <= 99 else 3
        self._live: dict[int, int] = {}  # track id -> number
        self._lost: dict[int, int] = {}  # number -> track id (L being sent)
        self._quarantine: dict[int, tuple[int, float]] = {}  # number -> (track id, free at s)
        self._free_since = dict.fromkeys(range(1, max_number + 1), -math.inf)  # number -> last retired s
        self.version = 0  # bumped on every change of the lent or held numbers

    def number_of(self, track_id: int) -> int | None:
        """The number of a live track, or None."""
        return self._live.get(track_id)

    def reserved_for(self, track_id: int) -> int | None:
        """The number a track holds or held: live, lost (L being sent) or in quarantine; else None
        (alerts about a lost target keep showing its number: edge.alerts.port)."""
        if track_id in self._live:
            return self._live[track_id]
        for number, owner in self._lost.items():
            if owner == track_id:
                return number
        for number, (owner, _) in self._quarantine.items():
            if owner == track_id:
                return number
        return None

    def assign(self, track_id: int, now_s: float) -> int | None:
        """The track's number: its current one, its old one back, a free one, or None if all are busy."""
        if track_id in self._live:
            return self._live[track_id]
        self._expire(now_s)
        number = self._take_back(track_id)
        if number is None and self._free_since:
            number = min(self._free_since, key=lambda n: (self._free_since[n], n))
            del self._free_since[number]
        if number is None:
            return None
        self._live[track_id] = number
        self.version += 1
        return number

    def release(self, track_id: int) -> int | None:
        """The track was dropped: its number is now lost (still reserved) until `retire`."""
        number = self._live.pop(track_id, None)
        if number is not None:
            self._lost[number] = track_id
            self.version += 1
        return number

    def retire(self, number: int, now_s: float) -> None:
        """The last sentence for a lost number went out at `now_s`: start its quarantine."""
        track_id = self._lost.pop(number)
        self._quarantine[number] = (track_id, now_s + self.quarantine_s)
        self.version += 1

    def hold(self, number: int, seconds: float, now_s: float) -> None:
        """Quarantine a free `number` for `seconds` from `now_s`, owned by no track (a previous
        run's number): nobody gets it sooner. A number not free now is left as it is."""
        if number in self._free_since and seconds > 0:
            del self._free_since[number]
            self._quarantine[number] = (-1, now_s + seconds)
            self.version += 1

    def held(self, now_s: float) -> dict[int, float | None]:
        """Numbers not free now: None for live or lost ones, else the quarantine's seconds left."""
        self._expire(now_s)
        out: dict[int, float | None] = {n: None for n in self._live.values()}
        out.update(dict.fromkeys(self._lost, None))
        out.update({n: free_at - now_s for n, (_, free_at) in self._quarantine.items()})
        return out

    def busy(self) -> int:
        """Numbers that cannot be lent now (live + lost + in quarantine)."""
        return self.max_number - len(self._free_since)

    def _take_back(self, track_id: int) -> int | None:
        for number, owner in self._lost.items():
            if owner == track_id:
                del self._lost[number]
                return number
        for number, (owner, _) in self._quarantine.items():
            if owner == track_id:
                del self._quarantine[number]
                return number
        return None

    def _expire(self, now_s: float) -> None:
        for number, (_, free_at_s) in list(self._quarantine.items()):
            if now_s >= free_at_s:
                del self._quarantine[number]
                self._free_since[number] = free_at_s
                self.version += 1
