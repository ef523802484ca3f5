import numpy as np
import pytest
import torch
from stable_baselines3 import SAC, HerReplayBuffer

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


def tiny_sac_her(env, learning_starts=100):
    """A small SB3 SAC with HER on a reach env, as a user would bring one (no antmaze_hirl glue)."""
    return SAC(
        "MultiInputPolicy",
        env,
        replay_buffer_class=HerReplayBuffer,
        learning_starts=learning_starts,
        batch_size=32,
        policy_kwargs={"net_arch": [32, 32]},
        seed=0,
    )
