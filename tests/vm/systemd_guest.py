"""Runs as root inside the appliance VM under real systemd (rootfs with udev): installs mast-stereo from
a bundle with tools/install and exercises the installed service; prints `MAST-STEP name {json}` lines.

Usage: python3 systemd_guest.py BUNDLE PROJECT RECORDING. Steps, each recorded (never aborting the
run, so the host test reports every finding): real LED class devices (uleds) and a GPIO chip
(gpio-sim) as on a mast; a rig's udev rules naming the vivid cameras and ttyS1 (/dev/mast/*), which
tools/install must keep; tools/install --from BUNDLE twice (the second changes nothing); a config
replaying a short simulator recording; systemctl start (Type=notify: returns after READY=1) and
status; the main process's user; the Modbus identity block via mbpoll on port 502; systemd-analyze
security; a probe unit with the service's exact sandbox that opens cameras, serial ports, GPIO and
LEDs (and again with other ReadWritePaths, PrivateDevices=, PrivateUsers=, to show why the unit
sets them as it does); SIGSTOP -> watchdog restart;
reload (SIGHUP); stop, and the pairs the daemon processed.
"""

from __future__ import annotations

import json
import os
import re
import struct
import subprocess
import sys
import time
from pathlib import Path

UNIT = "mast-stereo.service"
INSTALLED_UNIT = Path("/usr/local/lib/systemd/system") / UNIT
LEDS = ("mast:green:ok", "mast:red:fault")
result: dict = {"steps": {}}


def uptime_s() -> float:
    return float(Path("/proc/uptime").read_text().split()[0])


def sh(*cmd: str, timeout_s: float = 300) -> dict:
    t0 = time.monotonic()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s)
        out = {"rc": p.returncode, "out": p.stdout, "err": p.stderr[-3000:]}
    except (OSError, subprocess.TimeoutExpired) as exc:
        out = {"rc": -1, "out": "", "err": str(exc)}
    out["s"] = round(time.monotonic() - t0, 2)
    return out


def show(*props: str) -> dict[str, str]:
    text = sh("systemctl", "show", UNIT, "-p", ",".join(props))["out"]
    return dict(line.split("=", 1) for line in text.splitlines() if "=" in line)


def step(name: str, fn) -> None:
    """Run one step; print its result at once (`MAST-STEP name {json}`): a timeout keeps the earlier ones."""
    t0 = time.monotonic()
    try:
        value = fn()
    except Exception as exc:  # record and go on: the host test names the failing step
        value = {"exception": f"{type(exc).__name__}: {exc}"}
    result["steps"][name] = value
    elapsed = time.monotonic() - t0
    print(f"MAST-STEP {name} " + json.dumps({"s": round(elapsed, 1), "value": value}), flush=True)


def make_leds() -> dict:
    fds = []
    for name in LEDS:
        fd = os.open("/dev/uleds", os.O_RDWR)
        os.write(fd, struct.pack("64si", name.encode(), 255))
        fds.append(fd)  # kept open: the LEDs live as long as this process
    result["led_fds"] = fds
    return {"leds": sorted(os.listdir("/sys/class/leds"))}


def make_gpio_chip() -> dict:
    d = Path("/sys/kernel/config/gpio-sim/mast")
    (d / "gpio-bank0").mkdir(parents=True)
    (d / "gpio-bank0/num_lines").write_text("8")
    (d / "live").write_text("1")
    return {"chip": (d / "gpio-bank0/chip_name").read_text().strip()}


def rig_rules(project: Path) -> dict:
    shipped = (project / "systemd/60-mast-stereo.rules").read_text()
    rig = shipped.replace('LABEL="mast_stereo_end"', (
        # by ID_PATH (imported by the shipped file itself) and by the driver's name
        'SUBSYSTEM=="video4linux", ATTR{index}=="0", ENV{ID_PATH}=="platform-vivid.0", '
        'SYMLINK+="mast/cam-left"\n'
        'SUBSYSTEM=="video4linux", ATTR{name}=="vivid-001-vid-cap", SYMLINK+="mast/cam-right"\n'
        'SUBSYSTEM=="tty", KERNEL=="ttyS1", SYMLINK+="mast/nmea"\n'
        'LABEL="mast_stereo_end"'))
    Path("/etc/udev/rules.d").mkdir(parents=True, exist_ok=True)
    Path("/etc/udev/rules.d/60-mast-stereo.rules").write_text(rig)
    return {}


VM_CONFIG = """\
version: 1
# a short simulator recording (systemd_harness.ensure_recording): virtual cameras render ~10 s a pair
# under TCG, which leaves the daemon STALLED, sending no WATCHDOG=1, until the watchdog kills it
cameras: {kind: replay, path: RECORDING, pace: true, loop: true}
outputs:
  nmea: []
  modbus: {tcp: {enabled: true, host: 0.0.0.0, port: 502}}
  tracks_csv: /var/lib/mast-stereo/tracks.csv
health:
  stale_s: 30.0   # a pair may take over 2 s under TCG
  min_fps: 0.0
  require_clock_sync: false   # the guest has no NTP
  min_free_disk_mb: 50        # its disk is an overlay in 1 GiB of guest RAM
  leds: {kind: sysfs, ok: "mast:green:ok", fault: "mast:red:fault"}
"""

PROBE = r'''
import json, os, socket, sys
out = {}
def try_(name, fn):
    try:
        out[name] = fn() or "ok"
    except Exception as exc:
        out[name] = f"{type(exc).__name__}: {exc}"
def open_rw(path):
    os.close(os.open(path, os.O_RDWR | os.O_NONBLOCK | os.O_NOCTTY))
def write(path, text):
    with open(path, "w") as f:
        f.write(text)
out["uid"], out["groups"] = os.getuid(), sorted(os.getgroups())
for led in ("mast:green:ok", "mast:red:fault"):
    try_(f"led {led}", lambda: write(f"/sys/class/leds/{led}/brightness", "255"))
    try_(f"led {led} trigger", lambda: write(f"/sys/class/leds/{led}/trigger", "none"))
if sys.argv[1:] != ["leds-only"]:
    for dev in ("/dev/mast/cam-left", "/dev/mast/cam-right", "/dev/video0", "/dev/mast/nmea", "/dev/ttyS1",
                "/dev/ttyS2", "/dev/%s" % os.environ.get("GPIOCHIP", "gpiochip0"), "/dev/uleds", "/dev/mem"):
        try_(f"open {dev}", lambda: open_rw(dev))
    try_("write /var/lib/mast-stereo", lambda: write("/var/lib/mast-stereo/probe", "x"))
    try_("write /etc/mast-stereo", lambda: write("/etc/mast-stereo/probe", "x"))
    try_("write /opt/mast-stereo", lambda: write("/opt/mast-stereo/probe", "x"))
    try_("bind port 503", lambda: socket.create_server(("0.0.0.0", 503)).close())
    try_("netlink socket", lambda: socket.socket(socket.AF_NETLINK, socket.SOCK_RAW, 0).close())
    # numpy/OpenCV/scipy under MemoryDenyWriteExecute and the syscall filter: the daemon's own pairs
    try_("systemd.daemon", lambda: __import__("systemd.daemon") and None)
print(json.dumps(out))
'''


def launch_probe(name: str, *args: str, dropin: str = "") -> None:
    """Start PROBE (not waiting) in a oneshot unit with the installed unit's sandbox: its [Service]
    minus the daemon's own lines, plus `dropin`."""
    lines = []
    for line in INSTALLED_UNIT.read_text().splitlines():
        key = line.split("=", 1)[0]
        if key in ("Type", "NotifyAccess", "ExecStart", "ExecReload", "WatchdogSec", "Restart",
                   "RestartSec", "RestartPreventExitStatus", "WantedBy"):
            continue
        lines.append(line)
        if line == "[Service]":
            lines += ["Type=oneshot",
                      f"ExecStart=/opt/mast-stereo/venv/bin/python /run/mast-probe.py {' '.join(args)}",
                      f"StandardOutput=truncate:/run/{name}.json",
                      f"Environment=GPIOCHIP={result['gpiochip']}"]
    Path("/run/mast-probe.py").write_text(PROBE)
    unit = Path(f"/run/systemd/system/{name}.service")
    unit.parent.mkdir(parents=True, exist_ok=True)
    unit.write_text("\n".join(lines) + "\n")
    if dropin:
        (unit.parent / f"{name}.service.d").mkdir(exist_ok=True)
        (unit.parent / f"{name}.service.d/test.conf").write_text("[Service]\n" + dropin + "\n")
    sh("systemctl", "daemon-reload")
    sh("systemctl", "start", "--no-block", f"{name}.service")


def collect_probe(name: str) -> dict:
    t0 = time.monotonic()
    while time.monotonic() - t0 < 180:
        state = sh("systemctl", "show", f"{name}.service", "-p", "ActiveState", "--value")["out"].strip()
        if state in ("inactive", "failed"):
            break
        time.sleep(1)
    out = Path(f"/run/{name}.json")
    data = json.loads(out.read_text()) if out.is_file() and out.read_text().strip() else {}
    if state != "inactive":
        data["_state"] = state
        data["_journal"] = sh("journalctl", "-u", f"{name}.service", "-o", "cat", "--no-pager")["out"][-2000:]
    return data


def start() -> dict:
    run = sh("systemctl", "start", UNIT, timeout_s=240)
    props = show("ActiveState", "SubState", "StatusText", "MainPID", "NRestarts",
                 "ExecMainStartTimestampMonotonic", "ActiveEnterTimestampMonotonic")
    status = sh("systemctl", "status", "--no-pager", "--lines=5", UNIT)["out"]
    pid = int(props.get("MainPID", "0"))
    uid = None
    if pid:
        uid = int(re.search(r"^Uid:\s+(\d+)", Path(f"/proc/{pid}/status").read_text(), re.M).group(1))
    return {"start": run, "props": props, "status": status, "main_uid": uid,
            "user_uid": int(sh("id", "-u", "mast-stereo")["out"].strip() or -1)}


def daemon_leds(seconds: float = 5.0) -> dict:
    """Brightness changes of the uleds LEDs while the daemon runs (it owns them with kind sysfs)."""
    import select

    poller = select.poll()
    roles = dict(zip(result["led_fds"], LEDS, strict=True))
    for fd in roles:
        os.set_blocking(fd, False)
        poller.register(fd, select.POLLIN)
        try:
            os.read(fd, 4)  # drop a change left by the probes
        except BlockingIOError:
            pass
    events, t0 = [], time.monotonic()
    while time.monotonic() - t0 < seconds:
        for fd, _ in poller.poll(100):
            try:
                (value,) = struct.unpack("i", os.read(fd, 4))
            except BlockingIOError:
                continue
            events.append((round(time.monotonic() - t0, 3), roles[fd], value))
    return {"events": events, "status": show("StatusText")["StatusText"]}


def modbus() -> dict:
    attempts = []
    for _ in range(20):
        r = sh("mbpoll", "-m", "tcp", "-p", "502", "-a", "1", "-0", "-t", "3", "-r", "0", "-c", "10",
               "-1", "-o", "5", "127.0.0.1", timeout_s=30)
        attempts.append(r)
        if r["rc"] == 0:
            break
        time.sleep(1)
    regs = {int(m.group(1)): int(m.group(2))
            for m in re.finditer(r"^\[(\d+)\]:\s+(-?\d+)", attempts[-1]["out"], re.M)}
    return {"registers": regs, "attempts": len(attempts), "last": attempts[-1]}


def watchdog() -> dict:
    time.sleep(3)  # a few pairs and WATCHDOG=1s first
    before = show("MainPID", "NRestarts")
    pid = int(before["MainPID"])
    t_stop = time.monotonic()
    os.kill(pid, 19)  # SIGSTOP: the daemon hangs; only the watchdog can tell
    back = None
    while time.monotonic() - t_stop < 150:
        time.sleep(1)
        now = show("MainPID", "ActiveState", "NRestarts")
        if now["ActiveState"] == "active" and now["MainPID"] not in ("0", str(pid)):
            back = round(time.monotonic() - t_stop, 1)
            break
    journal = sh("journalctl", "-u", UNIT, "-o", "cat", "--no-pager")["out"]
    return {"pid_before": pid, "nrestarts_before": int(before["NRestarts"]), "after": show(
        "MainPID", "ActiveState", "NRestarts", "StatusText"), "back_after_s": back,
        "journal_watchdog": [line for line in journal.splitlines() if "atchdog" in line]}


def reload() -> dict:
    """`systemctl reload` with a changed configuration (another tracks CSV): applied, same process."""
    pid = show("MainPID")["MainPID"]
    config = Path("/etc/mast-stereo/config.yaml")
    config.write_text(config.read_text().replace("/var/lib/mast-stereo/tracks.csv",
                                                 "/var/lib/mast-stereo/tracks-reloaded.csv"))
    run = sh("systemctl", "reload", UNIT, timeout_s=120)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not Path("/var/lib/mast-stereo/tracks-reloaded.csv").exists():
        time.sleep(1)
    journal = sh("journalctl", "-u", UNIT, "-o", "cat", "--no-pager")["out"]
    return {"reload": run, "pid_before": pid, "after": show("MainPID", "ActiveState", "NRestarts"),
            "applied": Path("/var/lib/mast-stereo/tracks-reloaded.csv").exists(),
            "journal_reload": [line for line in journal.splitlines() if "reload" in line][-5:]}


def selftest() -> dict:
    """tools/selftest against the running unit; then with a corrupt calibration file named."""
    good = sh("/opt/mast-stereo/venv/bin/mast-stereo", "selftest", "--config", "/etc/mast-stereo/config.yaml",
              "--json", timeout_s=180)
    bad_dir = Path("/run/mast-selftest")
    bad_dir.mkdir(exist_ok=True)
    (bad_dir / "calibration.yaml").write_text("baseline_m: [8.14\n")
    (bad_dir / "config.yaml").write_text(Path("/etc/mast-stereo/config.yaml").read_text()
                                         + f"calibration: {bad_dir / 'calibration.yaml'}\n")
    bad = sh("/opt/mast-stereo/venv/bin/mast-stereo", "selftest", "--config", str(bad_dir / "config.yaml"),
             timeout_s=180)
    return {"good": good, "bad": bad}


def stop() -> dict:
    run = sh("systemctl", "stop", UNIT, timeout_s=60)
    journal = sh("journalctl", "-u", UNIT, "-o", "cat", "--no-pager")["out"]
    return {"stop": run, "after": show("ActiveState", "Result", "ExecMainStatus"),
            "stopped_lines": [line for line in journal.splitlines() if "stopped:" in line],
            "errors": [line for line in journal.splitlines()
                       if " ERROR " in line or "Traceback" in line][:20]}


def main() -> int:
    bundle, project, recording = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3]
    result["boot_s"] = uptime_s()
    # the venv's shared objects (~300 MB) come over 9p on first use: read them on the second vCPU
    # while tools/install runs, or the daemon's first start takes ~2 min of imports under TCG
    prefetch = subprocess.Popen(
        ["sh", "-c", "find /opt/mast-stereo/venv -name '*.so*' -type f -exec cat {} + >/dev/null"])
    step("leds", make_leds)
    step("gpio", make_gpio_chip)
    result["gpiochip"] = result["steps"]["gpio"].get("chip", "gpiochip0")
    step("rig_rules", lambda: rig_rules(project))
    # --no-check: check-config imports numpy and OpenCV, ~30 s under TCG; the daemon's start checks the same
    install = (str(bundle / "tools/install"), "--from", str(bundle), "--no-check")
    step("install", lambda: sh(*install, timeout_s=600))
    step("install_again", lambda: sh(*install))
    step("files", lambda: {
        "mast_links": sorted(os.listdir("/dev/mast")) if os.path.isdir("/dev/mast") else [],
        "led_group": {n: sh("stat", "-c", "%G %a", f"/sys/class/leds/{n}/brightness")["out"].strip()
                      for n in LEDS},
        "rules_kept": "vivid-001-vid-cap" in Path("/etc/udev/rules.d/60-mast-stereo.rules").read_text(),
        "video0": sh("udevadm", "info", "--query=property", "--name=/dev/video0")["out"],
        "enabled": sh("systemctl", "is-enabled", UNIT)["out"].strip()})
    Path("/etc/mast-stereo/config.yaml").write_text(VM_CONFIG.replace("RECORDING", recording))
    # imports take 30-120 s under TCG (~2 s on a mast): more than the unit's TimeoutStartSec=120s
    dropin = Path(f"/run/systemd/system/{UNIT}.d")
    dropin.mkdir(parents=True, exist_ok=True)
    (dropin / "vm.conf").write_text("[Service]\nTimeoutStartSec=300s\n")
    sh("systemctl", "daemon-reload")
    prefetch.wait()
    # the probes run while the daemon starts (two vCPUs; python imports dominate both)
    launch_probe("mast-probe")
    launch_probe("mast-probe-norw", "leds-only", dropin="ReadWritePaths=")
    launch_probe("mast-probe-class", "leds-only", dropin="ReadWritePaths=\nReadWritePaths=-/sys/class/leds")
    launch_probe("mast-probe-privdev", dropin="PrivateDevices=yes")  # options the unit leaves off: why
    launch_probe("mast-probe-privusers", dropin="PrivateUsers=yes")
    step("start", start)
    step("modbus", modbus)
    step("security", lambda: sh("systemd-analyze", "security", "--no-pager", UNIT, timeout_s=120))
    step("probe", lambda: collect_probe("mast-probe"))
    step("probe_no_rw", lambda: collect_probe("mast-probe-norw"))
    step("probe_class_only", lambda: collect_probe("mast-probe-class"))
    step("probe_private_devices", lambda: collect_probe("mast-probe-privdev"))
    step("probe_private_users", lambda: collect_probe("mast-probe-privusers"))
    step("daemon_leds", daemon_leds)
    step("watchdog", watchdog)
    step("reload", reload)
    step("selftest", selftest)
    step("stop", stop)
    print("MAST-STEP end " + json.dumps({"s": 0, "value": {"boot_s": result["boot_s"], "end_s": uptime_s()}}),
          flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
