"""Helpers shared by several test modules: the CLI as a subprocess, a free TCP port, band-limited test
textures."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np

# a TCP port on 127.0.0.1 nothing listens on: the fault rig's, re-exported for the tests
from lab.faults._rig import free_port as free_port

ROOT = Path(__file__).resolve().parents[1]


def run_cli(*args: str | Path, cwd: Path = ROOT, timeout_s: float = 120.0) -> subprocess.CompletedProcess:
    """`mast-stereo ARGS` in a fresh interpreter, output captured as text."""
    return subprocess.run([sys.executable, "-m", "edge.cli", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=timeout_s)


def band_texture(seed: int, h: int, w: int, sigma: float = 1.2) -> np.ndarray:
    """Band-limited random texture (float, ~0..255): sub-pixel shifts by interpolation stay honest."""
    rng = np.random.default_rng(seed)
    t = cv2.GaussianBlur(rng.normal(0.0, 1.0, (h, w)), (0, 0), sigma)
    return 128.0 + 60.0 * t / t.std()


def shifted_u8(tex: np.ndarray, dx: float, dy: float = 0.0) -> np.ndarray:
    """tex moved right by dx, down by dy (bicubic on a band-limited texture), as uint8."""
    m = np.float32([[1, 0, dx], [0, 1, dy]])
    out = cv2.warpAffine(tex.astype(np.float32), m, (tex.shape[1], tex.shape[0]), flags=cv2.INTER_CUBIC,
                         borderMode=cv2.BORDER_REFLECT)
    return np.clip(np.round(out), 0, 255).astype(np.uint8)
