"""IEC 61162-1 ed. 5 alert sentences of a sensor: ALF, ALC, HBT, the legacy ALR, and ACN parsing.

Pure string functions on top of `edge.encode.nmea.sentence` (framing, checksum, the 82-character
rule, no reserved characters). Layouts (research/vts-ais-alerts.md section 3: go-nmea, Icom
GM600, Furuno BR-500, pynmea2):

    ALF  $--ALF,1,1,s,hhmmss.ss,c,p,st,mfr,id,inst,rev,esc,text    one sentence per alert
    ALC  $--ALC,nn,nn,ss,e,{mfr,id,inst,rev}...                      entries never split
    HBT  $--HBT,interval,A|V,seq
    ALR  $--ALR,hhmmss.ss,nnn,A|V,A|V,text                           legacy, one per alert
    ACN  $--ACN,hhmmss.ss,mfr,id,inst,cmd,C                          received (acknowledge etc.)

ALF's text is cut to what fits 82 characters (it carries the target numbers first, so they are
never cut); a second ALF for longer text is not used. ALR numbers are 3 digits: the standard ids
(190-193) are their own number, the proprietary ids 10001-10004 are ALR 901-904.
"""

from __future__ import annotations

from collections.abc import Sequence

from edge.encode.nmea import MAX_SENTENCE_CHARS, NmeaError, check_talker, checksum, fmt_utc, sentence

ALR_NUMBERS = {190: 190, 191: 191, 192: 192, 193: 193, 10001: 901, 10002: 902, 10003: 903, 10004: 904}
ACN_COMMANDS = frozenset("AQOS")  # acknowledge, request repeat, responsibility transfer, silence


def _fit_text(address: str, fields: list[str], text: str) -> str:
    """The longest prefix of `text` that lets the sentence keep within 82 characters."""
    fixed = len(sentence(address, [*fields, ""]))
    return text[: max(0, MAX_SENTENCE_CHARS - fixed)].rstrip()


def alf(talker: str, sequence: int, utc_ns: int, category: str, priority: str, state: str,
        manufacturer: str, alert_id: int, instance: int, revision: int, text: str,
        escalation: int = 0) -> str:
    """One ALF (alert) sentence; `manufacturer` empty for standard ids, `sequence` 0..9."""
    address = check_talker(talker) + "ALF"
    fields = ["1", "1", str(sequence % 10), fmt_utc(utc_ns), category, priority, state, manufacturer,
              str(alert_id), str(instance), str(revision), str(escalation)]
    return sentence(address, [*fields, _fit_text(address, fields, text)])


def alc(talker: str, sequence: int, entries: Sequence[tuple[str, int, int, int]]) -> list[str]:
    """The ALC (cyclic alert list) sentences for (manufacturer, id, instance, revision) entries,
    as many entries per sentence as fit 82 characters, at most 99 sentences (entries beyond,
    the last given, are left out: pass them most urgent first); `sequence` 0..99. No entries:
    one sentence with 0 entries."""
    address = check_talker(talker) + "ALC"
    groups: list[list[tuple[str, int, int, int]]] = [[]]
    for entry in entries:
        trial = groups[-1] + [entry]
        try:
            _alc_line(address, 99, 99, sequence, trial)  # the widest header: refused when too long
            groups[-1] = trial
        except NmeaError:
            if not groups[-1]:
                raise
            groups.append([entry])
    groups = groups[:99]  # the sentence count has 2 digits: the least urgent entries beyond are left out
    return [_alc_line(address, len(groups), k + 1, sequence, g) for k, g in enumerate(groups)]


def _alc_line(address: str, total: int, number: int, sequence: int,
              entries: Sequence[tuple[str, int, int, int]]) -> str:
    fields = [f"{total:02d}", f"{number:02d}", f"{sequence % 100:02d}", str(len(entries))]
    for mfr, alert_id, instance, revision in entries:
        fields += [mfr, str(alert_id), str(instance), str(revision)]
    return sentence(address, fields)


def hbt(talker: str, interval_s: int, ok: bool, sequence: int) -> str:
    """HBT (heartbeat): configured interval 1..999 s, A normal / V not, sequence 0..9."""
    if not 1 <= interval_s <= 999:
        raise ValueError(f"HBT interval must be 1..999 s, got {interval_s}")
    return sentence(check_talker(talker) + "HBT", [str(interval_s), "A" if ok else "V", str(sequence % 10)])


def alr(talker: str, utc_ns: int, alert_id: int, active: bool, acknowledged: bool, text: str) -> str:
    """Legacy ALR: time of change, 3-digit alarm number, condition A (exceeded) / V, ack A / V, text."""
    address = check_talker(talker) + "ALR"
    fields = [fmt_utc(utc_ns), f"{ALR_NUMBERS[alert_id]:03d}", "A" if active else "V",
              "A" if acknowledged else "V"]
    return sentence(address, [*fields, _fit_text(address, fields, text)])


def parse_acn(line: str) -> tuple[str, int, int, str] | None:
    """(manufacturer, alert id, instance, command) of a well-formed ACN line with a valid
    checksum; None for anything else (other sentences, bad checksum, unknown command)."""
    text = line.strip()
    if not text.startswith("$") or "*" not in text:
        return None
    body, _, given = text[1:].partition("*")
    if given.upper() != checksum(body) or len(body) < 5:
        return None
    fields = body.split(",")
    if fields[0][2:] != "ACN" or len(fields) != 7:
        return None
    _, _utc, mfr, alert_id, instance, command, _flag = fields
    if command not in ACN_COMMANDS or not alert_id.isdigit() or not instance.isdigit():
        return None
    return mfr, int(alert_id), int(instance), command
