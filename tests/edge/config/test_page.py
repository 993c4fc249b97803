"""The `page:` block: loopback by default; off loopback a token file only the daemon's user can read,
else a ConfigError naming page.token_file (and `mast-stereo run` exits 78 with that one line)."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from helpers import run_cli

from edge.config.app import config_from_dict
from edge.config.page import PageConfig, check_page
from edge.errors import EX_CONFIG, ConfigError

TOKEN = "0123456789abcdef0123"


def token_file(tmp_path: Path, text: str = TOKEN, mode: int = 0o600) -> Path:
    path = tmp_path / "page.token"
    path.write_text(text + "\n")
    path.chmod(mode)
    return path


def test_off_by_default_and_loopback() -> None:
    cfg = config_from_dict({}, "x.yaml").page
    assert not cfg.enabled and cfg.host == "127.0.0.1"
    assert check_page(cfg, "x.yaml") is None
    assert check_page(PageConfig(enabled=True), "x.yaml") is None  # loopback: no token needed


@pytest.mark.parametrize("host", ["0.0.0.0", "192.168.1.10", "::"])
def test_non_loopback_needs_a_token_file(host: str) -> None:
    with pytest.raises(ConfigError) as err:
        check_page(PageConfig(enabled=True, host=host), "site.yaml")
    assert err.value.key == "page.token_file" and "site.yaml: page.token_file" in str(err.value)


def test_a_private_token_file_is_read(tmp_path: Path) -> None:
    cfg = PageConfig(enabled=True, host="0.0.0.0", token_file=str(token_file(tmp_path)))
    assert check_page(cfg, "site.yaml") == TOKEN


@pytest.mark.parametrize(("text", "mode", "why"), [(TOKEN, 0o640, "mode 0640"), (TOKEN, 0o604, "mode 0604"),
                                                   ("short", 0o600, "5 characters"),
                                                   ("has a space in it ok?", 0o600, "characters")])
def test_unsafe_token_files_are_refused(tmp_path: Path, text: str, mode: int, why: str) -> None:
    cfg = PageConfig(enabled=True, host="0.0.0.0", token_file=str(token_file(tmp_path, text, mode)))
    with pytest.raises(ConfigError) as err:
        check_page(cfg, "site.yaml")
    assert err.value.key == "page.token_file" and why in str(err.value)


def test_missing_token_file_and_relative_path(tmp_path: Path) -> None:
    conf = tmp_path / "site.yaml"
    cfg = config_from_dict({"page": {"enabled": True, "host": "0.0.0.0", "token_file": "page.token"}}, conf)
    assert cfg.page.token_file == str(tmp_path / "page.token")  # relative to the configuration file
    with pytest.raises(ConfigError, match="page.token_file: expected a readable token file"):
        check_page(cfg.page, conf)


@pytest.mark.parametrize("token", [False, True])
def test_run_exits_78_naming_the_key(tmp_path: Path, token: bool) -> None:
    page = {"enabled": True, "host": "0.0.0.0", "port": 1}
    if token:
        page["token_file"] = str(token_file(tmp_path, mode=0o644))  # others may read it: unsafe
    conf = tmp_path / "site.yaml"
    conf.write_text(yaml.safe_dump({"page": page, "outputs": {"modbus": {"tcp": {"enabled": False}}}}))
    out = run_cli("run", "--config", conf, "--seconds", "1")
    lines = out.stderr.strip().splitlines()
    assert out.returncode == EX_CONFIG, out.stderr
    assert len(lines) == 1 and "page.token_file" in lines[0] and str(conf) in lines[0], lines
