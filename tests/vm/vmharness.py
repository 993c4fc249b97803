"""Shared plumbing for host-side tests that boot the appliance VM (../shared/tools/appliance-vm).

`run_vm(command)` boots the VM once with two vivid cameras, gpio-sim and uleds
(V4L2VM_KMODS=1), the project shared read-write at its own path, runs
`command` there (cwd = the project) and returns its exit status and console
output. The guest's root is the host's, read-only, so the project's .venv
python works in the guest (`VENV_PYTHON`). `unavailable_reason()` says why the
VM cannot run here at all (no harness, no qemu, no artifacts and no way to
build them); tests skip with that reason only. tools/_setup.sh builds the
artifacts when it runs as root. V4L2VM_DIR (default /var/tmp/appliance-vm)
holds the artifacts outside the repository.

    from vm.vmharness import run_vm, unavailable_reason   # tests/ is on sys.path (tests/conftest.py)
    result = run_vm(["systemctl", "--version"], systemd=True)
"""

from __future__ import annotations

import os
import shutil
import subprocess
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
# the shared harness beside the checkout; a clone elsewhere (e.g. /tmp) finds the workplace's copy
HARNESS = next((p for p in (ROOT.parent / "shared" / "tools" / "appliance-vm",
                            Path("/work/shared/tools/appliance-vm")) if p.is_dir()),
               ROOT.parent / "shared" / "tools" / "appliance-vm")
RUN_SH = HARNESS / "run.sh"
VM_DIR = Path(os.environ.get("V4L2VM_DIR", "/var/tmp/appliance-vm"))
VENV_PYTHON = ROOT / ".venv" / "bin" / "python"


@dataclass(frozen=True)
class VmRun:
    returncode: int
    output: str  # the guest console (command stdout+stderr) and run.sh's own lines
    wall_s: float


def artifacts_present() -> bool:
    return (
        (VM_DIR / "vmlinuz").exists()
        and (VM_DIR / "initramfs.cpio.gz").exists()
        and (VM_DIR / "kmods" / "gpio-sim.ko").exists()
    )


def unavailable_reason() -> str | None:
    """None if the VM can boot here; else why not (the only reason to skip a VM test)."""
    if not RUN_SH.exists():
        return f"appliance VM harness not found at {RUN_SH}"
    if shutil.which("qemu-system-x86_64") is None:
        return "qemu-system-x86_64 is not installed (tools/_setup.sh installs it when run as root)"
    if not artifacts_present() and os.geteuid() != 0:
        return f"no VM artifacts in {VM_DIR} and not root to build them (run tools/test as root once)"
    return None


def run_vm(
    command: Sequence[str],
    *,
    timeout_s: float = 300.0,
    vivid: str | None = None,
    systemd: bool = False,
    env: Sequence[str] = (),
    extra_args: Sequence[str] = (),
) -> VmRun:
    """Boot the VM, run `command` in the project directory, return its status and output."""
    args = [str(RUN_SH), "--project", str(ROOT), "--timeout", str(round(timeout_s))]
    if vivid is not None:
        args += ["--vivid", vivid]
    if systemd:
        args.append("--systemd")
    for name in env:
        args += ["--env", name]
    args += [*extra_args, "--", *command]
    environ = os.environ | {"V4L2VM_DIR": str(VM_DIR), "V4L2VM_KMODS": "1"}
    t0 = time.monotonic()
    proc = subprocess.run(
        args,
        cwd=ROOT,
        env=environ,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        errors="replace",
        timeout=timeout_s + 60,
        stdin=subprocess.DEVNULL,
    )
    return VmRun(proc.returncode, proc.stdout, time.monotonic() - t0)


def guest_pytest(paths: Sequence[str], junit: Path, *, timeout_s: float = 300.0) -> VmRun:
    """Run pytest on `paths` in the guest with the project's venv, without plugin autoload (faster
    under TCG) and without the conftests above the tests' own directory; results in `junit`."""
    command = [
        "env",
        "PYTEST_DISABLE_PLUGIN_AUTOLOAD=1",
        str(VENV_PYTHON),
        "-m",
        "pytest",
        "-q",
        "-rA",
        "-p",
        "no:cacheprovider",
        "-o",
        "addopts=--import-mode=importlib",
        "-o",
        "timeout=0",
        "-o",
        "junit_logging=system-out",
        f"--confcutdir={paths[0]}",
        f"--junitxml={junit}",
        *paths,
    ]
    return run_vm(command, timeout_s=timeout_s)
