"""Refuse configuration and calibration files that someone other than their owner could change.

The daemon acts on what these files say (serial ports, listening addresses, the rig's geometry),
so a file that a group or every user may write, or that lives in a directory they may write
(and could swap it in), or that belongs to another unprivileged user, would let them steer
the appliance. `mast-stereo run` (and a reload) checks the configuration file and the
calibration file it names before using them; each check follows symlinks to the file that is
really read, and a refusal is a `ConfigError` naming that file (exit 78, one line).

Accepted: owned by root or by the user the daemon runs as, not writable by group or others,
in a directory with the same properties (or a sticky one such as /tmp, where others cannot
rename or delete it). The installed unit's files pass: /etc/mast-stereo is root's, 0755, and
tools/install writes config.yaml 0644.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path
from typing import Any

from edge.config.calibration import resolve_path
from edge.config.schema import load_yaml
from edge.errors import ConfigError

GROUP_OR_OTHER_WRITE = stat.S_IWGRP | stat.S_IWOTH


def _problem(path: Path, is_dir: bool) -> str | None:
    st = path.stat()
    of = f" of its directory {path}" if is_dir else ""  # the file itself is named by the error
    if st.st_uid not in (0, os.geteuid()):
        return f"owned by uid {st.st_uid}{of}"
    if st.st_mode & GROUP_OR_OTHER_WRITE and not (is_dir and st.st_mode & stat.S_ISVTX):
        return f"mode {stat.S_IMODE(st.st_mode):04o}{of}"
    return None


def check_private(path: str | Path) -> None:
    """Raise `ConfigError` naming `path` unless only its owner (root or us) can change it."""
    given = Path(path)
    try:
        real = given.resolve(strict=True)
    except (OSError, RuntimeError):
        return  # missing or a symlink loop: the loader reports it, with its own message
    problem = _problem(real, False) or _problem(real.parent, True)
    if problem is not None:
        target = f" (-> {real})" if real != given.absolute() else ""
        raise ConfigError(f"{given}{target}", "",
                          "a file only its owner (root or the daemon's user) can change "
                          "(chmod go-w, chown, or a private directory)", problem)


def referenced_calibration(config_file: str | Path) -> Path | None:
    """The calibration file a configuration names (`calibration: PATH`), if any."""
    data: Any = load_yaml(config_file)
    ref = data.get("calibration") if isinstance(data, dict) else None
    return resolve_path(config_file, ref) if isinstance(ref, str) else None


def check_config_files(config_file: str | Path) -> None:
    """The checks `run` makes: the configuration file, then the calibration file it names."""
    check_private(config_file)
    calibration = referenced_calibration(config_file)
    if calibration is not None:
        check_private(calibration)
