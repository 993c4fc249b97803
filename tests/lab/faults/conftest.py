"""The fault cases' scene: a frame of the session's cached akashi-crossing recording, which the daemon
tests render anyway, instead of a render of its own (~5 s)."""

from __future__ import annotations

import cv2
import pytest

from edge.recording.format import image_paths
from lab.faults import _rig


@pytest.fixture(autouse=True, scope="session")
def _scene(recording) -> None:
    left, right = image_paths(recording("akashi-crossing", 30), 29)
    _rig.use_scene(cv2.imread(str(left), cv2.IMREAD_GRAYSCALE), cv2.imread(str(right), cv2.IMREAD_GRAYSCALE))
