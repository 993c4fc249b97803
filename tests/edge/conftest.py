"""Shared scenario builders for the simulator tests: small inline scenarios, real calibrations."""

from __future__ import annotations

from pathlib import Path

import pytest

from edge.config.schema import load_yaml

ROOT = Path(__file__).resolve().parents[2]
SITE = {"lat_deg": 34.63, "lon_deg": 135.02, "height_m": 25.0, "heading_deg": 180.0}


def pinhole(width, height, f, dist=(0.0,) * 5, rot=(0.0, 0.0, 0.0)):
    return {
        "model": "pinhole",
        "fx": f,
        "fy": f * 1.0005,
        "cx": (width - 1) / 2,
        "cy": (height - 1) / 2,
        "dist": list(dist),
        "rotation_deg": list(rot),
    }


def poly10(width, height, f, k1=-0.08, rot=(0.0, 0.0, 0.0)):
    """eq. 3.5 coefficients of a camera with focal f and barrel distortion k1 (first order inverse)."""
    a0, cubic = 1.0 / f, -k1 / f**3
    return {
        "model": "poly10",
        "cx": (width - 1) / 2,
        "cy": (height - 1) / 2,
        "coeffs": [a0, 0.0, 0.0, cubic, cubic, a0 * 1.0004, 0.0, 0.0, cubic, cubic],
        "rotation_deg": list(rot),
    }


def calibration(kind: str) -> dict:
    """Calibration mappings: the two Akashi files (720x480) and 2048x1536 ones of both models."""
    if kind == "akashi-pinhole":
        return load_yaml(ROOT / "config/calibration/akashi-pinhole.yaml")
    if kind == "akashi-poly10":
        return load_yaml(ROOT / "config/calibration/akashi-poly10.yaml")
    w, h, f = 2048, 1536, 2600.0
    if kind == "2048-pinhole":
        left = pinhole(w, h, f, (-0.08, 0.05, 0.0002, -0.0001, 0.0), (-1.0, 0.12, 0.05))
        right = pinhole(w, h, f + 1.5, (-0.075, 0.04, -0.0001, 0.0002, 0.0), (-0.95, -0.1, -0.04))
    elif kind == "2048-poly10":
        left, right = (
            poly10(w, h, f, -0.08, (-1.0, 0.12, 0.05)),
            poly10(w, h, f + 1.5, -0.07, (-0.95, -0.1, 0.0)),
        )
    elif kind == "ideal-720":
        w, h, f = 720, 480, 913.9
        left = right = {**pinhole(w, h, f), "fy": f}
    else:
        raise KeyError(kind)
    return {
        "baseline_m": 8.14,
        "image": {"width": w, "height": h},
        "cameras": {"left": left, "right": right},
        "site": SITE,
    }


def scenario(cal: dict | str, ships=(), **extra) -> dict:
    data = {"calibration": cal, "fps": 10, "duration_s": 1.0, "sea": {"components": 4}, **extra}
    data["ships"] = list(ships)
    return data


def ship(ship_id, kind, length, waypoints, speed_kn=10.0, **extra) -> dict:
    return {
        "id": ship_id,
        "kind": kind,
        "length_m": length,
        "track": {"waypoints_m": [list(p) for p in waypoints], "speed_kn": [speed_kn]},
        **extra,
    }


@pytest.fixture
def sim_tools():
    """The builders above, for tests in this directory."""

    class Tools:
        pass

    tools = Tools()
    tools.calibration, tools.scenario, tools.ship = calibration, scenario, ship
    return tools
