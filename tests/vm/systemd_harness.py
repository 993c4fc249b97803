"""Plumbing for the tests that boot the appliance VM (../shared/tools/appliance-vm): run a command in it,
optionally under real systemd on a Debian rootfs with udev, and build what such a boot needs once.

- `run_vm(cmd, ...)` boots run.sh (V4L2VM_DIR=/var/tmp/appliance-vm, V4L2VM_KMODS=1 unless set) and
  returns the console output, exit status and wall time (and the guest journal with `keep_ctl`).
- `ensure_rootfs()` builds the systemd+udev rootfs with make-rootfs.sh once and caches it by its
  package list (`ROOTFS_DEBS`); `ensure_bundle(rootfs)` puts tools/bundle's directory in it (the
  dependencies rebuilt per pyproject.toml hash) and `ensure_venv()` installs its venv in a chroot.
- `tagged_json(output, TAG)` reads the `TAG {json}` line a guest script printed; `steps()` the
  `MAST-STEP name {json}` lines.

Skips (not fails) when the harness is not beside the project, so a checkout without shared/ still
runs the rest of the suite. Another engineer's tests/vm/vmharness.py does the same for plain
capture VMs; the two are to be unified.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path

import pytest
from vmharness import HARNESS as SHARED_HARNESS

ROOT = Path(__file__).resolve().parents[2]
HARNESS = Path(os.environ["APPLIANCE_VM"]) if "APPLIANCE_VM" in os.environ else SHARED_HARNESS
VM_DIR = Path(os.environ.get("V4L2VM_DIR", "/var/tmp/appliance-vm"))
ROOTFS_DEBS = "systemd udev dbus libnss-systemd python3-venv mbpoll procps"  # procps: /bin/kill (ExecReload)
ROOTFS = Path(os.environ.get("MAST_VM_ROOTFS", VM_DIR / "rootfs-systemd"))


@dataclass(frozen=True)
class VmRun:
    rc: int
    output: str  # the guest console (the command's stdout and stderr) and run.sh's own lines
    wall_s: float
    journal: str = ""  # with keep_ctl and systemd: journalctl -b of the guest


def require_vm() -> None:
    """Skip the calling test when the appliance VM harness is not available here."""
    if not (HARNESS / "run.sh").is_file():
        pytest.skip(f"no appliance VM harness at {HARNESS} (set APPLIANCE_VM)")
    if os.geteuid() != 0 and not shutil.which("qemu-system-x86_64"):
        pytest.skip("qemu-system-x86_64 missing and not root to install it")


def run_vm(
    command: list[str], *, systemd: bool = False, rootfs: Path | None = None, vivid: str | None = "none",
    timeout_s: float = 300.0, keep_ctl: bool = False, mem_mb: int = 1024,
) -> VmRun:
    """Boot the VM with the project shared at its own path and run `command` in it (cwd = project)."""
    env = {**os.environ, "V4L2VM_DIR": str(VM_DIR)}
    env.setdefault("V4L2VM_KMODS", "1")
    args = [str(HARNESS / "run.sh"), "--project", str(ROOT), "--mem", str(mem_mb),
            "--timeout", str(int(timeout_s))]
    if vivid is not None:  # None: run.sh's default (two vivid capture+output instances)
        args += ["--vivid", vivid]
    if systemd:
        args.append("--systemd")
    if rootfs is not None:
        args += ["--rootfs", str(rootfs)]
    if keep_ctl:
        args.append("--keep-ctl")
    t0 = time.monotonic()
    proc = subprocess.run([*args, "--", *command], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=timeout_s + 30)
    wall_s = time.monotonic() - t0
    output = proc.stdout + proc.stderr
    journal = ""
    if keep_ctl:
        kept = [line.split("control dir kept at ", 1)[1].strip()
                for line in proc.stderr.splitlines() if "control dir kept at " in line]
        if kept:
            ctl = Path(kept[-1])
            if (ctl / "journal.txt").is_file():
                journal = (ctl / "journal.txt").read_text(errors="replace")
            shutil.rmtree(ctl, ignore_errors=True)
    return VmRun(proc.returncode, output, wall_s, journal)


def tagged_json(output: str, tag: str) -> dict:
    """The JSON of the last console line starting with `tag ` (fails the test with the output if none)."""
    lines = [line[len(tag) + 1:] for line in output.splitlines() if line.startswith(tag + " ")]
    if not lines:
        pytest.fail(f"the guest printed no {tag} line; console:\n{output[-6000:]}")
    return json.loads(lines[-1])


def ensure_rootfs() -> Path:
    """A Debian rootfs with systemd, udev and python3-venv for `run_vm(systemd=True)` (~75 s once)."""
    stamp = ROOTFS / ".mast-stereo-debs"
    if stamp.is_file() and stamp.read_text() == ROOTFS_DEBS and (ROOTFS / "usr/bin/python3").exists():
        return ROOTFS
    if ROOTFS.exists():  # built with another package list: make-rootfs.sh only builds a fresh dir
        shutil.rmtree(ROOTFS)
    ROOTFS.parent.mkdir(parents=True, exist_ok=True)
    subprocess.run([str(HARNESS / "make-rootfs.sh"), str(ROOTFS)], check=True, capture_output=True,
                   env={**os.environ, "V4L2VM_DEBS": ROOTFS_DEBS}, timeout=900)
    stamp.write_text(ROOTFS_DEBS)
    return ROOTFS


GUEST_BUNDLE = "/var/cache/mast-stereo/bundle"  # inside the rootfs: the chroot and the VM both see it


def ensure_bundle(rootfs: Path) -> str:
    """tools/bundle's offline install directory for this tree, inside `rootfs`; returns its guest path.

    The dependencies' wheels are rebuilt only when pyproject.toml changes (minutes without a local
    wheel cache); the package's own wheel on every call (seconds), so the VM runs this tree."""
    bundle = rootfs / GUEST_BUNDLE.lstrip("/")
    stamp = bundle / ".pyproject-sha256"
    want = hashlib.sha256((ROOT / "pyproject.toml").read_bytes()).hexdigest()
    fresh = not (stamp.is_file() and stamp.read_text() == want and (bundle / "BUNDLE").is_file())
    if fresh:
        shutil.rmtree(bundle, ignore_errors=True)
    subprocess.run([str(ROOT / "tools" / "bundle"), *([] if fresh else ["--package-only"]), str(bundle)],
                   check=True, capture_output=True, timeout=900)
    stamp.write_text(want)
    return GUEST_BUNDLE


def ensure_venv(rootfs: Path, bundle: str) -> str:
    """`tools/install --from BUNDLE --venv-only` natively in a chroot of `rootfs`; returns its output.

    pip unpacking and byte-compiling numpy/scipy/OpenCV takes ~4.5 min under TCG and ~30 s natively;
    the VM's own tools/install run then finds the venv up to date (same bundle) and does the rest."""
    proc = subprocess.run(["chroot", str(rootfs), f"{bundle}/tools/install", "--from", bundle, "--venv-only"],
                          capture_output=True, text=True, timeout=900,
                          env={"PATH": "/usr/sbin:/usr/bin:/sbin:/bin", "HOME": "/root", "LANG": "C.UTF-8"})
    if proc.returncode:
        pytest.fail(f"tools/install --venv-only in a chroot of {rootfs} failed:\n{proc.stdout}{proc.stderr}")
    return proc.stdout


GUEST_RECORDING = "/var/cache/mast-stereo/recording"


def ensure_recording(rootfs: Path, frames: int = 20) -> str:
    """A short simulator recording inside `rootfs` for the VM's daemon (replay cameras); its guest path.

    The virtual cameras render a pair in ~0.3 s natively, ~10 s under TCG: the daemon would be STALLED
    (no WATCHDOG=1) before its first pair and killed by the watchdog. Replaying PNGs keeps it healthy."""
    from edge.sim.render_recording import write_recording
    from edge.sim.scenario import load_scenario
    from edge.sim.simulator import Simulation

    out = rootfs / GUEST_RECORDING.lstrip("/")
    if not (out / "frames.csv").is_file():
        shutil.rmtree(out, ignore_errors=True)
        write_recording(Simulation(load_scenario("akashi-crossing"), seed=0), out, frames=frames)
    return GUEST_RECORDING


def steps(output: str, tag: str = "MAST-STEP") -> dict[str, dict]:
    """The `TAG name {json}` lines a guest script printed, by name ({"s": seconds, "value": ...})."""
    found = {}
    for line in output.splitlines():
        if line.startswith(tag + " "):
            name, _, data = line[len(tag) + 1:].partition(" ")
            found[name] = json.loads(data)
    return found
