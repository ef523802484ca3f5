import glob
import os
import tempfile

import numpy as np
import pytest

import antmaze_hirl  # noqa: F401  (registers the env ids)


class StillController:
    """A picklable low-level controller that outputs zero torques (stands in for a trained ant)."""

    def __call__(self, observation):
        return np.zeros(8)


@pytest.fixture
def still_controller():
    return StillController()


@pytest.fixture(autouse=True)
def no_leftover_maze_xml():
    """Every env must remove the temporary MuJoCo XML gymnasium-robotics writes."""
    pattern = os.path.join(tempfile.gettempdir(), "*_maze*.xml")
    before = set(glob.glob(pattern))
    yield
    assert set(glob.glob(pattern)) <= before
