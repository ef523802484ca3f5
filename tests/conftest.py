import numpy as np
import pytest
import torch

import antmaze_hirl  # noqa: F401  (registers the env ids)

# One thread: small networks gain nothing from two, and results stay the same on every machine.
torch.set_num_threads(1)


class StillController:
    """A picklable low-level controller that outputs zero torques (stands in for a trained ant)."""

    def __call__(self, observation):
        return np.zeros(8)


@pytest.fixture
def still_controller():
    return StillController()
