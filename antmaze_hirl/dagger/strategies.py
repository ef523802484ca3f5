"""Active-learning query strategies: where episodes start, and which labels are kept.

:class:`QueryStrategy` is the base: its hooks do nothing, which is plain DAgger (:class:`DAggerQuery`,
corner starts, every label kept). The paper's three strategies override one hook each and compose with
any trainer setting.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from antmaze_hirl.dagger.dataset import DemonstrationDataset
from antmaze_hirl.dagger.features import EncodedBatch
from antmaze_hirl.dagger.protocols import Learner, OffsetLearner


@dataclass(frozen=True)
class StartQuery:
    """What a strategy may look at to pick an episode's start.

    Attributes:
        walls: The episode's wall grid.
        goal_xy: The episode's goal, metres.
        candidates: Candidate start positions, ``(n, 2)`` metres (free cell centres).
        body_observation: The body's observation at rest (the non-position part of the state).
        policy: The current learner.
    """

    walls: np.ndarray
    goal_xy: np.ndarray
    candidates: np.ndarray
    body_observation: np.ndarray
    policy: OffsetLearner

    def encode(self, agent_xy: np.ndarray, body_observations: np.ndarray) -> EncodedBatch:
        """Encodes the agent at each of ``agent_xy`` with the matching body observation."""
        n = len(agent_xy)
        return self.policy.encoder.encode([self.walls] * n, list(agent_xy), [self.goal_xy] * n, list(body_observations))


class QueryStrategy:
    """Base of the active-learning strategies: hooks the trainer calls, each a no-op here.

    A subclass sets :attr:`name` and overrides the hooks it needs. Instantiating the base itself is
    deprecated (it used to be plain DAgger): it warns and gives a :class:`DAggerQuery`.
    """

    name: ClassVar[str] = ""
    reads_policy_outputs: ClassVar[bool] = False
    """Whether the strategy reads the learner's offsets (then the learner must be an :class:`OffsetLearner`)."""

    def __new__(cls, *args: Any, **kwargs: Any) -> QueryStrategy:
        """A new strategy; ``QueryStrategy()`` itself gives a :class:`DAggerQuery`, with a warning."""
        if cls is QueryStrategy:
            warnings.warn(
                "QueryStrategy() as plain DAgger is deprecated: use DAggerQuery() (QueryStrategy is the base now)",
                DeprecationWarning,
                stacklevel=2,
            )
            cls = DAggerQuery
        return super().__new__(cls)

    def attach(self, learner: Learner) -> None:
        """Called once by the trainer with its learner (for strategies that build models like it)."""

    def choose_start(self, query: StartQuery, rng: np.random.Generator) -> np.ndarray | None:
        """Start xy for the next episode, or ``None`` for the env's own corner start."""
        return None

    def on_episode_end(
        self, dataset: DemonstrationDataset, episode: int, success: bool, rng: np.random.Generator
    ) -> list[int]:
        """Adjusts the dataset after an episode; returns the removed positions."""
        return []

    def on_update(self, dataset: DemonstrationDataset, gradient_steps: int, rng: np.random.Generator) -> None:
        """Called after each learner update (for strategies that train models of their own)."""


class DAggerQuery(QueryStrategy):
    """Plain DAgger: start in the layout's corner, aggregate every label."""

    name = "dagger"


def spread(outputs: np.ndarray) -> float:
    """Trace of the covariance of ``(n, 2)`` outputs: how much they vary."""
    return float(np.var(outputs, axis=0).sum())


class NoiseQuery(QueryStrategy):
    """Noise-based start selection (Alg. 2, eq. 1).

    Each candidate's state gets ``n_noises`` uniform perturbations of its non-position part (the
    body observation, ``±noise_scale``); the episode starts at the candidate whose perturbed states
    make the current policy's outputs vary most.

    Args:
        n_noises: Perturbations per candidate.
        noise_scale: Half-width of the uniform noise, in body-observation units.
    """

    name = "noise"
    reads_policy_outputs = True

    def __init__(self, n_noises: int = 10, noise_scale: float = 1.0) -> None:
        if n_noises < 2:
            raise ValueError(f"n_noises must be >= 2 to measure a spread, got {n_noises}")
        self.n_noises = n_noises
        self.noise_scale = noise_scale

    def scores(self, query: StartQuery, rng: np.random.Generator) -> np.ndarray:
        """Spread of the policy's outputs at each candidate."""
        body = query.body_observation
        noisy = body + rng.uniform(
            -self.noise_scale, self.noise_scale, size=(len(query.candidates), self.n_noises, *body.shape)
        )
        agents = np.repeat(query.candidates, self.n_noises, axis=0)
        outputs = query.policy.offsets(query.encode(agents, noisy.reshape(-1, *body.shape)))
        return np.array([spread(block) for block in outputs.reshape(len(query.candidates), self.n_noises, 2)])

    def choose_start(self, query: StartQuery, rng: np.random.Generator) -> np.ndarray | None:
        """The candidate with the largest output spread."""
        return query.candidates[int(np.argmax(self.scores(query, rng)))]


class MultiPolicyQuery(QueryStrategy):
    """Multi-policy start selection (Alg. 3, eq. 2).

    Keeps ``n_policies`` extra learners; after every update each trains on a fresh bootstrap resample
    of D (warm-started, as the main learner is). The episode starts at the candidate where their
    subgoals disagree most.

    Args:
        n_policies: Ensemble size.
        make_policy: Factory ``rng -> learner`` for the ensemble members (left ``None``: the trainer's
            learner's :meth:`~antmaze_hirl.dagger.protocols.OffsetLearner.spawn`).
        member_steps: Gradient steps per member per update. Default: the trainer's N divided by
            ``n_policies`` (rounded up), so the whole ensemble costs about as much as the learner;
            disagreement only has to rank start cells, and full-length member training made a trial
            ~5x slower for no measured gain.
    """

    name = "multi_policy"
    reads_policy_outputs = True

    def __init__(
        self,
        n_policies: int = 5,
        make_policy: Callable[[np.random.Generator], OffsetLearner] | None = None,
        member_steps: int | None = None,
    ) -> None:
        if n_policies < 2:
            raise ValueError(f"n_policies must be >= 2 to measure disagreement, got {n_policies}")
        if member_steps is not None and member_steps < 1:
            raise ValueError(f"member_steps must be >= 1, got {member_steps}")
        self.n_policies = n_policies
        self.make_policy = make_policy
        self.member_steps = member_steps
        self.members: list[OffsetLearner] = []

    def attach(self, learner: Learner) -> None:
        """Makes the members with ``learner``'s ``spawn`` unless :attr:`make_policy` was given."""
        if self.make_policy is None and isinstance(learner, OffsetLearner):
            self.make_policy = learner.spawn

    def on_update(self, dataset: DemonstrationDataset, gradient_steps: int, rng: np.random.Generator) -> None:
        """Trains every member on its own bootstrap resample of the dataset."""
        if self.make_policy is None:
            raise ValueError("MultiPolicyQuery needs make_policy (the trainer sets it)")
        if not self.members:
            self.members = [
                self.make_policy(np.random.default_rng(rng.integers(2**63))) for _ in range(self.n_policies)
            ]
        steps = self.member_steps if self.member_steps is not None else -(-gradient_steps // self.n_policies)
        for member in self.members:
            member.fit_dataset(dataset, steps, rng.integers(len(dataset), size=len(dataset)))

    def scores(self, query: StartQuery) -> np.ndarray:
        """Disagreement (spread across members) at each candidate."""
        if not self.members:
            return np.zeros(len(query.candidates))
        bodies = np.repeat(query.body_observation[None], len(query.candidates), axis=0)
        encoded = query.encode(query.candidates, bodies)
        outputs = np.stack([member.offsets(encoded) for member in self.members], axis=1)  # (candidates, members, 2)
        return np.array([spread(block) for block in outputs])

    def choose_start(self, query: StartQuery, rng: np.random.Generator) -> np.ndarray | None:
        """The candidate with the largest ensemble disagreement (corner start before the first update)."""
        if not self.members:
            return None
        return query.candidates[int(np.argmax(self.scores(query)))]


class RewardBasedQuery(QueryStrategy):
    """Reward-based filtering (Alg. 4): after a failed episode, drop the labels that led to the failure.

    Each label ``t_d`` high-level steps before the end of a failed episode is removed with
    probability ``exp(-t_d)`` (the last one always); successful episodes keep everything.
    """

    name = "reward"

    def on_episode_end(
        self, dataset: DemonstrationDataset, episode: int, success: bool, rng: np.random.Generator
    ) -> list[int]:
        """Removes labels of a failed episode with probability ``exp(-t_d)``; returns their indices."""
        if success:
            return []
        indices = dataset.episode_indices(episode)
        steps_before_end = np.arange(len(indices))[::-1]
        removed = [index for index, t_d in zip(indices, steps_before_end, strict=True) if rng.random() < np.exp(-t_d)]
        dataset.remove(removed)
        return removed


STRATEGIES: dict[str, type[QueryStrategy]] = {
    "dagger": DAggerQuery,
    "noise": NoiseQuery,
    "multi_policy": MultiPolicyQuery,
    "reward": RewardBasedQuery,
}
"""Strategy classes by method name (the ``--methods`` of ``antmaze-hirl experiment``)."""


def make_strategy(name: str) -> QueryStrategy:
    """A strategy with default settings by method name.

    Raises:
        ValueError: For an unknown name.
    """
    if name not in STRATEGIES:
        raise ValueError(f"unknown method {name!r}; choose from {sorted(STRATEGIES)}")
    return STRATEGIES[name]()
