"""The `page:` block: the read-only maintenance page and /metrics (edge.appliance.page, docs/page.md).

Off by default. Bound to 127.0.0.1 unless `host` says otherwise; on any other address the page
needs a token (`token_file`), a file only the daemon's user can read: `check_page` refuses a
non-loopback bind without one, or with one that others can read or change, as a `ConfigError`
naming `page.token_file` (exit 78, before any device is opened). A token file on loopback is
honoured too (every request then needs it).
"""

from __future__ import annotations

import ipaddress
import os
import stat
from dataclasses import dataclass
from pathlib import Path

from edge.config.schema import setting
from edge.errors import ConfigError

MIN_TOKEN_CHARS = 16  # a shorter secret is guessable over a network


def _ip(value: str) -> str | None:
    try:
        ipaddress.ip_address(value)
    except ValueError:
        return "an IP address such as 127.0.0.1, 0.0.0.0 or 192.168.1.10"
    return None


@dataclass(frozen=True)
class PageConfig:
    enabled: bool = setting(False, doc="serve the maintenance page and /metrics (docs/page.md)")
    host: str = setting("127.0.0.1", check=_ip,
                        doc="listen address; anything but loopback needs token_file")
    port: int = setting(8080, min=1, max=65535, doc="TCP port")
    token_file: str | None = setting(
        None, doc="file holding the page's token (password), readable by the daemon's user only (0600); "
        "needed off loopback; relative to this file")
    docs_dir: str | None = setting(
        "/opt/mast-stereo/docs", doc="the built documentation site served under /docs/ (tools/install "
        "puts it here); null or missing: not served")
    image_hz: float = setting(2.0, positive=True, max=2.0, doc="live pictures per second at most")
    image_width: int = setting(640, min=160, max=1920, doc="width of the live pictures, px (scaled down)")
    max_clients: int = setting(8, min=1, max=64, doc="connections served at once; more are closed at once")


def is_loopback(host: str) -> bool:
    return ipaddress.ip_address(host).is_loopback


def read_token(cfg: PageConfig, file: str | Path | None) -> str | None:
    """The token the page requires (None: none, loopback only), checked as `check_page` says."""
    key = "page.token_file"
    if cfg.token_file is None:
        if cfg.enabled and not is_loopback(cfg.host):
            raise ConfigError(file, key, f"a token file (readable by the daemon's user only) when "
                              f"page.host is not loopback ({cfg.host})")
        return None
    path = Path(cfg.token_file)
    try:
        st = path.stat()
        text = path.read_text(encoding="utf-8").strip()
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(file, key, "a readable token file", f"{path}: {exc}") from None
    if st.st_uid != os.geteuid() or stat.S_IMODE(st.st_mode) & 0o077:
        raise ConfigError(file, key, "a token file only the daemon's user can read (owner it, chmod 600)",
                          f"mode {stat.S_IMODE(st.st_mode):04o}, uid {st.st_uid}: {path}")
    if len(text) < MIN_TOKEN_CHARS or any(c.isspace() or not c.isprintable() for c in text):
        raise ConfigError(file, key, f"a token of at least {MIN_TOKEN_CHARS} printable characters, "
                          "no spaces (e.g. openssl rand -hex 16)", f"{len(text)} characters: {path}")
    return text


def check_page(cfg: PageConfig, file: str | Path | None) -> str | None:
    """At start and on reload: the token (None: none needed) or a ConfigError naming the key."""
    return read_token(cfg, file) if cfg.enabled else None
