"""tools/install under --root (a temp dir, never the real system), files only: what it writes, that a
second run changes nothing, that the rig's config and udev rules are never overwritten, and that
--uninstall keeps configuration and recordings. The venv and the running system: tests/vm."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
INSTALL = ROOT / "tools" / "install"
UNIT = "usr/local/lib/systemd/system/mast-stereo.service"
RULES = "etc/udev/rules.d/60-mast-stereo.rules"
CONFIG = "etc/mast-stereo/config.yaml"

pytestmark = pytest.mark.skipif(not shutil.which("systemd-sysusers"), reason="needs systemd's tools")


def install(root: Path, *args: str) -> list[str]:
    proc = subprocess.run([str(INSTALL), "--root", str(root), "--files-only", *args],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return proc.stdout.splitlines()


def snapshot(root: Path) -> dict[str, tuple[int, int]]:
    return {str(p.relative_to(root)): (p.lstat().st_mtime_ns, p.lstat().st_size)
            for p in root.rglob("*") if not p.is_dir()}


def test_first_install_writes_the_files_users_and_enables_the_unit(tmp_path: Path) -> None:
    out = install(tmp_path)
    for rel in (UNIT, RULES, CONFIG, "usr/local/lib/sysusers.d/mast-stereo.conf",
                "usr/local/lib/tmpfiles.d/mast-stereo.conf", "opt/mast-stereo/README.md",
                "opt/mast-stereo/examples/calibration/akashi-pinhole.yaml"):
        assert (tmp_path / rel).is_file(), rel
    assert (tmp_path / UNIT).read_text() == (ROOT / "systemd/mast-stereo.service").read_text()
    assert (tmp_path / CONFIG).read_text() == (ROOT / "config/mast.example.yaml").read_text()
    wants = tmp_path / "etc/systemd/system/multi-user.target.wants/mast-stereo.service"
    assert os.readlink(wants) == "/" + UNIT
    passwd = (tmp_path / "etc/passwd").read_text()
    assert "mast-stereo:x:" in passwd and ":/var/lib/mast-stereo:/usr/sbin/nologin" in passwd
    assert any(line.startswith("gpio:") and "mast-stereo" in line
               for line in (tmp_path / "etc/group").read_text().splitlines())
    assert (tmp_path / "var/lib/mast-stereo/recordings").is_dir()
    assert "install: skip systemctl daemon-reload and udevadm (--root " + str(tmp_path) + ")" in out
    assert "install: + mast-stereo.service enabled (starts at boot)" in out


def test_a_second_run_changes_nothing(tmp_path: Path) -> None:
    install(tmp_path)
    before = snapshot(tmp_path)
    out = install(tmp_path)
    assert snapshot(tmp_path) == before
    assert not [line for line in out if line.startswith("install: +")], out
    assert "install: = mast-stereo.service already enabled" in out


def test_the_rigs_config_and_rules_are_kept_but_our_unit_is_replaced(tmp_path: Path) -> None:
    install(tmp_path)
    (tmp_path / CONFIG).write_text("version: 1  # this rig\n")
    (tmp_path / RULES).write_text("# this rig's cameras\n")
    (tmp_path / UNIT).write_text("[Service]\n")
    out = install(tmp_path)
    assert (tmp_path / CONFIG).read_text() == "version: 1  # this rig\n"
    assert (tmp_path / RULES).read_text() == "# this rig's cameras\n"
    assert (tmp_path / UNIT).read_text() == (ROOT / "systemd/mast-stereo.service").read_text()
    assert any(line.startswith("install: - /etc/mast-stereo/config.yaml exists and differs") for line in out)
    assert "install: + /usr/local/lib/systemd/system/mast-stereo.service written" in out


def test_uninstall_keeps_configuration_recordings_and_edited_rules(tmp_path: Path) -> None:
    install(tmp_path)
    (tmp_path / "var/lib/mast-stereo/recordings/r1").mkdir()
    (tmp_path / RULES).write_text("# this rig's cameras\n")
    out = install(tmp_path, "--uninstall")
    assert not (tmp_path / UNIT).exists() and not (tmp_path / "opt/mast-stereo").exists()
    assert not (tmp_path / "etc/systemd/system/multi-user.target.wants/mast-stereo.service").is_symlink()
    assert (tmp_path / CONFIG).is_file() and (tmp_path / RULES).is_file()
    assert (tmp_path / "var/lib/mast-stereo/recordings/r1").is_dir()
    assert "install: = kept /etc/udev/rules.d/60-mast-stereo.rules (edited for this rig)" in out
    install(tmp_path, "--uninstall")  # twice is fine too
    install(tmp_path)
    assert (tmp_path / CONFIG).read_text() == (ROOT / "config/mast.example.yaml").read_text()


def test_a_bundle_for_another_python_is_refused(tmp_path: Path) -> None:
    bundle = tmp_path / "bundle"
    shutil.copytree(ROOT / "systemd", bundle / "systemd")
    (bundle / "wheels").mkdir()
    (bundle / "BUNDLE").write_text("python: cpython-39 riscv64\n")
    proc = subprocess.run([str(INSTALL), "--root", str(tmp_path / "r"), "--from", str(bundle)],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 1 and "the bundle is for 'cpython-39 riscv64'" in proc.stderr
