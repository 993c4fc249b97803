"""edge.config.trust: `run` refuses configuration and calibration files that others can change.

Real files with real modes (the suite runs as root, so it can also chown to another uid); two
real `mast-stereo run` subprocesses show the exit status and the single line; the files that
tools/install lays out pass.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest
from helpers import ROOT, run_cli

from edge.config.trust import check_config_files, check_private
from edge.errors import EX_CONFIG, ConfigError

CALIBRATION = ROOT / "config/calibration/akashi-pinhole.yaml"


def config_with_calibration(directory: Path) -> tuple[Path, Path]:
    """A valid config naming a calibration file beside it (virtual cameras: no hardware)."""
    cal = directory / "calibration.yaml"
    shutil.copy(CALIBRATION, cal)
    cfg = directory / "config.yaml"
    cfg.write_text("version: 1\ncameras: {kind: virtual, scenario: akashi-crossing}\n"
                   "calibration: calibration.yaml\noutputs: {modbus: {tcp: {enabled: false}}}\n")
    return cfg, cal


@pytest.fixture
def site(tmp_path: Path) -> Path:
    d = tmp_path / "etc"
    d.mkdir(mode=0o755)
    return d


def test_private_files_pass(site: Path) -> None:
    cfg, cal = config_with_calibration(site)
    check_config_files(cfg)


@pytest.mark.parametrize("mode", [0o664, 0o646, 0o666])
def test_a_file_others_can_write_is_refused_naming_it(site: Path, mode: int) -> None:
    cfg, cal = config_with_calibration(site)
    for victim in (cfg, cal):
        victim.chmod(mode)
        with pytest.raises(ConfigError) as err:
            check_config_files(cfg)
        assert err.value.file == str(victim) and f"mode {mode:04o}" in err.value.message
        victim.chmod(0o644)


def test_the_symlink_target_is_what_counts(site: Path, tmp_path: Path) -> None:
    shared = tmp_path / "shared"
    shared.mkdir()
    cfg, cal = config_with_calibration(shared)
    cal.chmod(0o666)
    (site / "calibration.yaml").symlink_to(cal)  # the link itself is always 0777: irrelevant
    link_cfg = site / "config.yaml"
    link_cfg.write_text(cfg.read_text())
    with pytest.raises(ConfigError) as err:
        check_config_files(link_cfg)
    assert str(cal) in err.value.file and "0666" in err.value.message


def test_a_writable_directory_is_refused_but_a_sticky_one_is_not(site: Path) -> None:
    cfg, _ = config_with_calibration(site)
    site.chmod(0o777)
    with pytest.raises(ConfigError, match="mode 0777") as err:
        check_private(cfg)
    assert err.value.file == str(cfg) and str(err.value.found).startswith("mode 0777 of its directory")
    site.chmod(0o1777)  # like /tmp: others cannot rename or delete our file
    check_private(cfg)
    site.chmod(0o755)


@pytest.mark.skipif(os.geteuid() != 0, reason="chown to another user needs root")
def test_a_file_of_another_user_is_refused(site: Path) -> None:
    cfg, _ = config_with_calibration(site)
    os.chown(cfg, 54321, 54321)
    with pytest.raises(ConfigError, match="owned by uid 54321"):
        check_private(cfg)


def test_run_exits_78_with_one_line_naming_the_file(site: Path) -> None:
    cfg, cal = config_with_calibration(site)
    cal.chmod(0o666)
    out = run_cli("run", "--config", cfg, "--seconds", "1", timeout_s=60)
    lines = out.stderr.strip().splitlines()
    assert out.returncode == EX_CONFIG and len(lines) == 1, out.stderr
    assert str(cal) in lines[0] and "Traceback" not in out.stderr
    cal.chmod(0o644)
    cfg.chmod(0o606)
    out = run_cli("run", "--config", cfg, "--seconds", "1", timeout_s=60)
    assert out.returncode == EX_CONFIG and out.stderr.count("\n") == 1 and str(cfg) in out.stderr


@pytest.mark.skipif(not shutil.which("systemd-sysusers"), reason="needs systemd's tools")
def test_the_installed_files_pass(tmp_path: Path) -> None:
    proc = subprocess.run([str(ROOT / "tools/install"), "--root", str(tmp_path), "--files-only"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    check_private(tmp_path / "etc/mast-stereo/config.yaml")
    check_private(tmp_path / "opt/mast-stereo/examples/calibration/akashi-pinhole.yaml")
