"""Interop with ``imitation``: export labels as its transitions, and use its BC as the DAgger learner.

``imitation`` is an optional extra installed with ``pip install --no-deps imitation==1.0.1`` plus
``datasets`` and ``jsonpickle`` (its own pins predate this stack; see the README).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch as th
from imitation.algorithms import bc
from imitation.data import types
from imitation.util import logger as imitation_logger
from stable_baselines3.common.policies import MultiInputActorCriticPolicy

from antmaze_hirl.dagger.dataset import DemonstrationDataset
from antmaze_hirl.envs.protocol import maze_env


def to_transitions(dataset: DemonstrationDataset) -> types.Transitions:
    """The aggregated labels as ``imitation`` transitions: dict observations, expert subgoals as actions.

    ``next_obs`` is the next label's observation from the same episode; the last label of an episode
    kept in D points to itself with ``dones=True`` (DAgger stores no observation after it).
    (``imitation`` 1.0.1's data loader needs ``next_obs`` even for ``TransitionsMinimal``.)

    Raises:
        ValueError: If the dataset is empty.
    """
    if len(dataset) == 0:
        raise ValueError("the dataset is empty")
    episodes = dataset.episodes
    follows = np.append(episodes[1:] == episodes[:-1], False)
    following = np.where(follows, np.arange(len(dataset)) + 1, np.arange(len(dataset)))
    images, states = dataset.images, dataset.states

    def dict_obs(order: np.ndarray) -> types.DictObs:
        return types.DictObs({"image": images[order], "state": states[order]})

    return types.Transitions(
        obs=dict_obs(np.arange(len(dataset))),
        acts=dataset.subgoals().astype(np.float32),
        infos=np.array([{}] * len(dataset)),
        next_obs=dict_obs(following),
        dones=~follows,
    )


class BCLearner:
    """``imitation``'s behaviour cloning as the DAgger learner (SB3 ``MultiInputActorCriticPolicy``).

    Works with plain DAgger and the reward-based strategy; the start-selecting strategies read the
    offsets of an :class:`~antmaze_hirl.dagger.protocols.OffsetLearner` and do not apply.

    Args:
        env: The high-level env (for its spaces and geometry).
        rng: Seeds the policy initialisation and each fit's shuffling. ``imitation``'s data loader
            shuffles with torch's global RNG (it takes no generator of its own), so both run inside
            ``torch.random.fork_rng``: seeded there, and the caller's global RNG is left as it was.
        batch_size: BC minibatch size.
        net_arch: Policy MLP sizes after SB3's image/vector extractor.
    """

    def __init__(self, env: Any, *, rng: np.random.Generator, batch_size: int = 32, net_arch: list[int] | None = None):
        maze = maze_env(env)
        self.rng = rng
        with th.random.fork_rng(devices=[]):
            th.manual_seed(int(rng.integers(2**31)))
            policy = MultiInputActorCriticPolicy(
                maze.observation_space, maze.action_space, lr_schedule=lambda _: 1e-3, net_arch=net_arch or [64, 64]
            )
        self.bc = bc.BC(
            observation_space=maze.observation_space,
            action_space=maze.action_space,
            rng=rng,
            policy=policy,
            batch_size=batch_size,
            custom_logger=imitation_logger.configure(format_strs=[]),
        )

    def fit_dataset(self, dataset: DemonstrationDataset, steps: int) -> None:
        """Runs ``steps`` BC minibatches on all labels so far (none while D is smaller than a minibatch)."""
        if steps <= 0 or len(dataset) < self.bc.batch_size:
            return
        with th.random.fork_rng(devices=[]):
            th.manual_seed(int(self.rng.integers(2**31)))
            self.bc.set_demonstrations(to_transitions(dataset))
            self.bc.train(n_batches=steps, progress_bar=False)

    def predict(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """The cloned policy's deterministic subgoal."""
        action, _ = self.bc.policy.predict(observation, deterministic=True)
        return np.asarray(action, dtype=np.float64)
