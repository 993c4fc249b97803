"""Regular superstructure detail for the simulator's ships (issue 16, a scenario's `detail: periodic`).

`periodic_detail(model, pitch_m)` repaints a `ShipModel` as real ships are built: windows on one
regular pitch, the same paint in every cell, dark glass against white, and a railing (stanchions
on the same pitch) along the deck edge. At kilometres that pitch is 1-2 px at 2048 px: finer than
two pixels it aliases on optics without blur (`imaging.psf_sigma_px: 0`), the case the matcher's
window cross-check (edge.measure.aliascheck) is there for. Opt-in: the presets are unchanged.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from edge.sim.ships import Part, ShipModel, Style, box


def periodic_detail(model: ShipModel, pitch_m: float = 2.0) -> ShipModel:
    """The model with regular superstructure detail (module doc): every windowed part gets windows
    on `pitch_m` along the ship with no per-cell variation, and a railing band (stanchions on
    the same pitch, 2 m high) stands on the deck edge. Geometry and tracked point are unchanged."""
    parts = []
    for part in model.parts:
        st = part.style
        if st.window[0] > 0.0:
            st = dataclasses.replace(st, cell_m=(pitch_m, st.cell_m[1], pitch_m), cell_variation=0.0,
                                     window=(0.5, max(st.window[1], 0.45)), window_albedo=0.05,
                                     albedo=max(st.albedo, 0.8), noise=0.02)
        parts.append(dataclasses.replace(part, style=st))
    hull_part = parts[0]
    top = float(hull_part.planes[hull_part.planes[:, 2] > 0.5, 3].min())  # the freeboard
    rail = Part("railing", _railing_planes(model, top), Style(
        0.85, (pitch_m, 2.0, pitch_m), 0.0, window=(0.75, 0.8), window_albedo=0.12, noise=0.02))
    return dataclasses.replace(model, parts=(*parts, rail))


def _railing_planes(model: ShipModel, freeboard_m: float) -> np.ndarray:
    """A thin box along the ship's side above the deck edge: the railing (its open spaces are
    painted dark, so the sea behind need not be cast)."""
    half_l, half_b = 0.30 * model.length_m, model.beam_m / 2.0
    return box(-half_l, half_l, -half_b, half_b, freeboard_m, freeboard_m + 2.0)
