"""Test-suite set-up: `tests/` on sys.path so test modules share `helpers` (importlib mode adds nothing),
and short simulator recordings for the pipeline, detection, replay and tools tests, rendered once per
session."""

from __future__ import annotations

import copy
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from edge.config.schema import load_yaml
from edge.sim.render_recording import write_recording
from edge.sim.scenario import scenario_from_dict, scenario_path
from edge.sim.simulator import Simulation

sys.path.insert(0, str(Path(__file__).resolve().parent))


def _no_ships(data: dict) -> dict:
    return {**data, "ships": []}


EDITS: dict[str, Callable[[dict], dict]] = {"no-ships": _no_ships}


@pytest.fixture(scope="session")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Callable[..., Path]:
    """`recording(scenario, frames, edit=None, seed=0)` -> a recording directory (cached per session).

    `edit` names a change to the scenario mapping in EDITS (e.g. "no-ships")."""
    cache: dict[tuple, Path] = {}

    def render(scenario: str, frames: int, edit: str | None = None, seed: int = 0) -> Path:
        key = (scenario, frames, edit, seed)
        if key not in cache:
            path = scenario_path(scenario)
            data = copy.deepcopy(load_yaml(path))
            if edit is not None:
                data = EDITS[edit](data)
            sim = Simulation(scenario_from_dict(data, path, scenario), seed=seed)
            out = tmp_path_factory.mktemp(f"{scenario}-{edit or 'as-is'}-{frames}")
            write_recording(sim, out / "rec", frames=frames, jobs=1)
            cache[key] = out / "rec"
        return cache[key]

    return render
