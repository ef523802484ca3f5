"""Active-learning query strategies: where episodes start, and which labels are kept.

:class:`QueryStrategy` is the base: its hooks do nothing, which is plain DAgger (:class:`DAggerQuery`,
corner starts, every label kept). The paper's three strategies override one hook each and compose with
any trainer setting.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from antmaze_hirl.dagger.dataset import DemonstrationDataset
from antmaze_hirl.dagger.features import SYMMETRIES, EncodedBatch
from antmaze_hirl.dagger.gating import QuantileThreshold, ReferenceStates, RiskModel, disagreement
from antmaze_hirl.dagger.protocols import Learner, OffsetLearner
from antmaze_hirl.dagger.symmetric_views import (
    class_directions,
    class_permutations,
    learner_planar_feature_dim,
    offsets_in_original_frame,
    probabilities_in_original_frame,
    symmetric_views,
)
from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.envs.layouts import bfs_distances
from antmaze_hirl.envs.protocol import MazeEnvProtocol
from antmaze_hirl.envs.state_layout import STATE_LAYOUT


@dataclass(frozen=True)
class StartQuery:
    """What a strategy may look at to pick an episode's start.

    Attributes:
        walls: The episode's wall grid.
        goal_xy: The episode's goal, metres.
        candidates: Candidate start positions, ``(n, 2)`` metres (free cell centres).
        body_observation: The body's observation at rest (the non-position part of the state).
        learner: The current learner.
    """

    walls: np.ndarray
    goal_xy: np.ndarray
    candidates: np.ndarray
    body_observation: np.ndarray
    learner: OffsetLearner

    def encode(self, agent_xy: np.ndarray, body_observations: np.ndarray) -> EncodedBatch:
        """Encodes the agent at each of ``agent_xy`` with the matching body observation."""
        n = len(agent_xy)
        return self.learner.encoder.encode(
            [self.walls] * n, list(agent_xy), [self.goal_xy] * n, list(body_observations)
        )


class QueryStrategy:
    """Base of the active-learning strategies: hooks the trainer calls, each a no-op here.

    A subclass sets :attr:`name` and overrides the hooks it needs; plain DAgger is :class:`DAggerQuery`.
    """

    name: ClassVar[str] = ""
    reads_policy_outputs: ClassVar[bool] = False
    """Whether the strategy reads the learner's offsets (then the learner must be an :class:`OffsetLearner`)."""
    updates_every_step: ClassVar[bool] = False
    """Whether the trainer updates after every high-level step (Alg. 4) instead of every K episodes.

    Each such update is a full one: :attr:`step_gradient_steps` gradient steps (``None``: the trainer's
    N), :meth:`on_update`, and one step of the beta schedule, so beta decays per step."""
    step_gradient_steps: int | None = None
    """Gradient steps of each per-step update (read only when :attr:`updates_every_step`)."""
    gates: ClassVar[bool] = False
    """Whether the trainer asks :meth:`wants_label` at each high-level step (an uncertainty gate).

    Then an unasked step executes the learner's subgoal and adds nothing to D, and an asked step executes
    the expert's own subgoal (the expert takes over for that step, as in HG-DAgger and ThriftyDAgger):
    the beta mix does not apply. Otherwise every step is asked and executes the beta mix."""
    label_failures: bool = False
    """Whether, after a failed episode, the expert labels its unasked states (read only when :attr:`gates`)."""

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

    def wants_label(self, observation: dict[str, np.ndarray], learner_subgoal: np.ndarray, learner: Learner) -> bool:
        """Whether the expert is asked at this step (called only when :attr:`gates`); here always.

        Args:
            observation: The high-level observation.
            learner_subgoal: The learner's proposal, clipped to the maze (what runs if the expert is not asked).
            learner: The trainer's learner.
        """
        return True

    def on_step(self, observation: dict[str, np.ndarray], subgoal: np.ndarray, info: dict[str, Any]) -> None:
        """Called after each executed step with the observation it started from, the subgoal sent and the env's info."""

    def label_target(
        self, maze: MazeEnvProtocol, observation: dict[str, np.ndarray], expert_subgoal: np.ndarray
    ) -> np.ndarray:
        """The subgoal stored in D for ``observation``; here the expert's own (what every method but AggreVaTe keeps).

        Args:
            maze: The trainer's maze env (:attr:`~antmaze_hirl.dagger.trainer.DAggerTrainer.maze`): the
                episode's layout, goal and geometry.
            observation: The labelled observation.
            expert_subgoal: The expert's answer, which the executed mix still uses.
        """
        return expert_subgoal


class DAggerQuery(QueryStrategy):
    """Plain DAgger: start in the layout's corner, aggregate every label."""

    name = "dagger"


def spread(outputs: np.ndarray) -> float:
    """Trace of the covariance of ``(n, d)`` outputs (offsets, or class distributions): how much they vary."""
    return float(np.var(outputs, axis=0).sum())


def information_radius(distributions: np.ndarray) -> float:
    """Jensen-Shannon divergence of ``(n, classes)`` distributions: their mean's entropy less their mean entropy, nats.

    Zero only where all ``n`` agree; it weighs a shift of probability by how much it changes the
    distributions' information, where :func:`spread` weighs every class alike.
    """
    distributions = np.asarray(distributions, dtype=np.float64)

    def entropy(p: np.ndarray) -> np.ndarray:
        return -(p * np.log(np.clip(p, 1e-300, None))).sum(axis=-1)

    return float(max(0.0, entropy(distributions.mean(axis=0)) - entropy(distributions).mean()))


MEASURES = ("js", "variance")
"""How :class:`NoiseQuery` measures the spread of its views' outputs: ``"js"`` (class distributions only),
:func:`information_radius`; ``"variance"``, :func:`spread`."""


SIGNALS = ("probabilities", "offsets")
"""What a variance-based start score measures the spread of (:class:`NoiseQuery`, :class:`MultiPolicyQuery`).

``"probabilities"`` (the default): the learner's softmax distribution over its classes (the 9 next cells,
or the heading bins): continuous in the network's inputs and weights, so its spread is never identically
zero. ``"offsets"``: the subgoal offsets, the score of protocol 1 (the committed results). With a next-cell
head the offset is a function of the argmax class, piecewise constant, so its spread under body noise is
zero up to rounding (~1e-32) almost everywhere, and the argmax then picks by rounding residue (a cell
next to the goal) or index 0."""


def check_signal(signal: str) -> str:
    """Returns ``signal`` if it is one of :data:`SIGNALS`.

    Raises:
        ValueError: Naming the value and the choices.
    """
    if signal not in SIGNALS:
        raise ValueError(f"signal must be one of {list(SIGNALS)}, got {signal!r}")
    return signal


def class_probabilities(learner: Any, batch: EncodedBatch) -> np.ndarray:
    """The learner's softmax distribution over its classes for an encoded batch, ``(B, classes)`` float64.

    Read from the learner's own ``class_probabilities(batch)`` if it has one, else from its torch network
    (``learner.network``, a :class:`~antmaze_hirl.dagger.HighLevelPolicy`'s): the next-cell logits, or the
    heading logits of a heading head (its distance output is left out).

    Raises:
        ValueError: For a learner with neither (name its type; ``signal="offsets"`` needs only ``offsets``).
    """
    own = getattr(learner, "class_probabilities", None)
    if callable(own):
        return np.asarray(own(batch), dtype=np.float64)
    network = getattr(learner, "network", None)
    import torch  # here: this module is imported where torch is not needed (the method names)

    if not isinstance(network, torch.nn.Module):
        raise ValueError(
            f"{type(learner).__name__} has no class distribution (no class_probabilities, no network): "
            "use signal='offsets'"
        )
    network.eval()
    with torch.no_grad():
        outputs = network(torch.from_numpy(batch.grids), torch.from_numpy(batch.vectors))
    logits = outputs[0] if isinstance(outputs, tuple) else outputs
    return torch.softmax(logits.double(), dim=1).numpy()


def argmax_ties_random(scores: np.ndarray, rng: np.random.Generator) -> int:
    """Index of the largest score, ties (to 1e-12 of the largest) broken by ``rng``, not by position.

    Before the first update, or with a signal that is flat, every candidate ties: index 0 would then
    always start the episode in the same cell.
    """
    scores = np.asarray(scores, dtype=np.float64)
    best = np.flatnonzero(scores >= scores.max() - 1e-12 * max(1.0, abs(scores.max())))
    return int(best[rng.integers(len(best))]) if len(best) > 1 else int(best[0])


class NoiseQuery(QueryStrategy):
    """Noise-based start selection (Alg. 2, eq. 1).

    Each candidate's state gets ``n_noises`` uniform perturbations of its non-position part (the
    body observation, ``±noise_scale``); the episode starts at the candidate whose perturbed states
    make the current policy's outputs vary most.

    With ``shared_noise`` (the default, as the paper has it) one buffer of ``n_noises`` perturbations
    is drawn per start and applied to every candidate, so candidates differ only in where they are,
    not in the luck of their noise. ``shared_noise=False`` draws fresh noise for each candidate: the
    first behaviour, with which the oldest committed ``noise`` results were made (the default changes
    the method's numbers).

    The output whose spread is measured is ``signal`` (:data:`SIGNALS`): by default the learner's softmax
    distribution over its classes, which varies continuously with the body observation; the subgoal
    offsets (``"offsets"``, protocol 1) of a next-cell head do not vary at all. Ties (a flat score, e.g.
    before the learner depends on the body) are broken at random (:func:`argmax_ties_random`).

    With ``symmetries`` (the default) each noisy state is also seen in the 8 symmetries of
    the square, the learner's own augmentation group, and each view's output is read back in the state's
    frame (:mod:`~antmaze_hirl.dagger.symmetric_views`): the spread is over all ``8 * n_noises`` views.
    The learner has learnt to answer a trained state's images alike, not an unseen state's, so this
    spread ranks unseen states above trained ones; body noise alone does not (docs/guides/protocol.md,
    ``scripts/alg2_signal.py``). The spread is ``measure`` (:data:`MEASURES`): by default the
    Jensen-Shannon divergence of the views' class distributions (:func:`information_radius`), which
    ranked better than their variance. Protocol 1's score is ``signal="offsets", symmetries=False``;
    protocol 2's first runs, before the symmetric views, ``symmetries=False, measure="variance"``.

    Args:
        n_noises: Perturbations per candidate.
        noise_scale: Half-width of the uniform noise, in body-observation units.
        shared_noise: One noise buffer for all candidates (the paper's Alg. 2), else fresh noise per candidate.
        signal: ``"probabilities"`` or ``"offsets"`` (:data:`SIGNALS`).
        symmetries: Also perturb by the 8 symmetries of the square (needs a learner that states its
            ``planar_feature_dim`` and, for ``"probabilities"``, a next-cell or heading head).
        measure: ``"js"`` or ``"variance"`` (:data:`MEASURES`); ``None``: ``"js"`` for class
            distributions, ``"variance"`` for offsets.

    Raises:
        ValueError: If ``n_noises`` is below 2, ``noise_scale`` is negative, ``signal`` or ``measure`` is
            unknown, or ``measure="js"`` is asked of offsets.
    """

    name = "noise"
    reads_policy_outputs = True

    def __init__(
        self,
        n_noises: int = 10,
        noise_scale: float = 1.0,
        *,
        shared_noise: bool = True,
        signal: str = "probabilities",
        symmetries: bool = True,
        measure: str | None = None,
    ) -> None:
        signal = check_signal(signal)
        measure = measure if measure is not None else ("js" if signal == "probabilities" else "variance")
        if measure not in MEASURES:
            raise ValueError(f"measure must be one of {list(MEASURES)}, got {measure!r}")
        if measure == "js" and signal != "probabilities":
            raise ValueError(f"measure 'js' compares class distributions: use signal='probabilities', not {signal!r}")
        if n_noises < 2:
            raise ValueError(f"n_noises must be >= 2 to measure a spread, got {n_noises}")
        if not noise_scale >= 0:
            raise ValueError(f"noise_scale must be >= 0, got {noise_scale}")
        self.n_noises = n_noises
        self.noise_scale = noise_scale
        self.shared_noise = shared_noise
        self.signal = signal
        self.symmetries = bool(symmetries)
        self.measure = measure

    def scores(self, query: StartQuery, rng: np.random.Generator) -> np.ndarray:
        """Spread of the policy's outputs (``signal``) at each candidate, over its noisy (and symmetric) views."""
        body = query.body_observation
        if self.shared_noise:
            buffer = rng.uniform(-self.noise_scale, self.noise_scale, size=(self.n_noises, *body.shape))
            noisy = body + np.broadcast_to(buffer, (len(query.candidates), *buffer.shape))
        else:
            noisy = body + rng.uniform(
                -self.noise_scale, self.noise_scale, size=(len(query.candidates), self.n_noises, *body.shape)
            )
        agents = np.repeat(query.candidates, self.n_noises, axis=0)
        batch = query.encode(agents, noisy.reshape(-1, *body.shape))
        outputs = self._outputs(query.learner, batch)  # (candidates * noises, views, d)
        blocks = outputs.reshape(len(query.candidates), -1, outputs.shape[-1])
        measure = information_radius if self.measure == "js" else spread
        return np.array([measure(block) for block in blocks])

    def _outputs(self, policy: OffsetLearner, batch: EncodedBatch) -> np.ndarray:
        # The measured output of every sample, (B, views, d): one view, or the 8 symmetric ones.
        def read(encoded: EncodedBatch) -> np.ndarray:
            return class_probabilities(policy, encoded) if self.signal == "probabilities" else policy.offsets(encoded)

        if not self.symmetries:
            return read(batch)[:, None]
        views = read(symmetric_views(batch, learner_planar_feature_dim(policy)))
        views = views.reshape(len(SYMMETRIES), len(batch), views.shape[-1])
        if self.signal == "probabilities":
            back = probabilities_in_original_frame(views, class_permutations(class_directions(policy)))
        else:
            back = offsets_in_original_frame(views)
        return back.transpose(1, 0, 2)

    def choose_start(self, query: StartQuery, rng: np.random.Generator) -> np.ndarray | None:
        """The candidate with the largest output spread (ties broken at random)."""
        return query.candidates[argmax_ties_random(self.scores(query, rng), rng)]


class BaggedEnsemble:
    """Learners like the trainer's, each trained after every update on its own bootstrap resample of D.

    Warm-started, as the main learner is. Where its members' subgoals disagree the data say little:
    :class:`MultiPolicyQuery` starts episodes there, :class:`GatedQuery` asks the expert there.

    Its defaults are the ``multi_policy`` method's ensemble settings, stated in :class:`MultiPolicyQuery`.

    Args:
        n_policies: Ensemble size.
        make_policy: Factory ``rng -> learner`` for the members (left ``None``: the trainer's learner's
            :meth:`~antmaze_hirl.dagger.protocols.OffsetLearner.spawn`).
        member_steps: Gradient steps per member per update. Default: the trainer's N divided by
            ``n_policies`` (rounded up), so the whole ensemble costs about as much as the learner;
            disagreement only has to rank states, and full-length member training made a trial
            several times slower for no measured gain.

    Raises:
        ValueError: If ``n_policies`` is below 2 or ``member_steps`` below 1.
    """

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
            raise ValueError(f"{type(self).__name__} needs make_policy (the trainer sets it)")
        if not self.members:
            self.members = [
                self.make_policy(np.random.default_rng(rng.integers(2**63))) for _ in range(self.n_policies)
            ]
        steps = self.member_steps if self.member_steps is not None else -(-gradient_steps // self.n_policies)
        for member in self.members:
            member.fit_dataset(dataset, steps, rng.integers(len(dataset), size=len(dataset)))

    def member_offsets(self, batch: EncodedBatch) -> np.ndarray:
        """Every member's normalised offsets for an encoded batch, ``(B, members, 2)``."""
        return np.stack([member.offsets(batch) for member in self.members], axis=1)

    def member_probabilities(self, batch: EncodedBatch) -> np.ndarray:
        """Every member's class distribution (:func:`class_probabilities`), ``(B, members, classes)``."""
        return np.stack([class_probabilities(member, batch) for member in self.members], axis=1)


class MultiPolicyQuery(BaggedEnsemble, QueryStrategy):
    """Multi-policy start selection (Alg. 3, eq. 2).

    Keeps a :class:`BaggedEnsemble` of ``n_policies`` extra learners; after every update each trains on a
    fresh bootstrap resample of D (warm-started, as the main learner is). The episode starts at the
    candidate where their subgoals disagree most.

    The ``multi_policy`` method's ensemble settings (these defaults; the one place they are stated):
    5 members, each made like the learner (its ``spawn``) and trained after every update for
    ``ceil(N / 5)`` gradient steps (40 at the experiments' N = 200), a fifth of the learner's, on a
    bootstrap resample of D the size of D. The paper trains its policies fully; see ``member_steps``.

    Disagreement is the spread across members of ``signal`` (:data:`SIGNALS`): by default their class
    distributions, which differ wherever their weights do; the members' argmax offsets (``"offsets"``,
    protocol 1) tie on most candidates. Ties are broken at random.

    Args:
        n_policies: Ensemble size.
        make_policy: Factory ``rng -> learner`` for the ensemble members (``None``: the learner's ``spawn``).
        member_steps: Gradient steps per member per update (``None``: ``ceil(N / n_policies)``).
        signal: ``"probabilities"`` or ``"offsets"``.

    Raises:
        ValueError: As :class:`BaggedEnsemble`, or for an unknown ``signal``.
    """

    name = "multi_policy"
    reads_policy_outputs = True

    def __init__(
        self,
        n_policies: int = 5,
        make_policy: Callable[[np.random.Generator], OffsetLearner] | None = None,
        member_steps: int | None = None,
        *,
        signal: str = "probabilities",
    ) -> None:
        super().__init__(n_policies, make_policy, member_steps)
        self.signal = check_signal(signal)

    def scores(self, query: StartQuery) -> np.ndarray:
        """Disagreement (spread across members of ``signal``) at each candidate."""
        if not self.members:
            return np.zeros(len(query.candidates))
        bodies = np.repeat(query.body_observation[None], len(query.candidates), axis=0)
        batch = query.encode(query.candidates, bodies)
        # (candidates, members, classes or 2)
        outputs = self.member_probabilities(batch) if self.signal == "probabilities" else self.member_offsets(batch)
        return np.array([spread(block) for block in outputs])

    def choose_start(self, query: StartQuery, rng: np.random.Generator) -> np.ndarray | None:
        """The candidate with the largest ensemble disagreement (corner start before the first update)."""
        if not self.members:
            return None
        return query.candidates[argmax_ties_random(self.scores(query), rng)]


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


class RewardPerStepQuery(RewardBasedQuery):
    """Alg. 4 as the paper writes it: reward-based filtering with an update after every high-level step.

    The trainer (:attr:`QueryStrategy.updates_every_step`) runs, after each label is aggregated, N
    gradient steps on D (``step_gradient_steps``; ``None`` keeps the trainer's N, the paper's
    "train pi on D" inside the step loop) and one step of the beta schedule, so beta is divided by d
    after every step rather than every episode. The step's executed mix uses the beta it was labelled
    with (and the learner's proposal from before the update, the one a person is shown); the next step
    sees the decayed beta. No update runs at the episode's end: the pruning of a failed episode is seen
    by the next step's update; an episode's record carries its first step's beta. With d = 2, beta is
    below 0.001 after ten labels, so rollouts are the learner's almost from the first episode on: that
    is the algorithm as written. A trial costs about the mean episode length times the gradient steps
    of ``reward``; ``step_gradient_steps`` trades that against fidelity.
    :class:`RewardBasedQuery` (method ``reward``) keeps the per-episode updates of Alg. 1.

    Args:
        step_gradient_steps: Gradient steps after every step; ``None``: the trainer's ``gradient_steps``.

    Raises:
        ValueError: If ``step_gradient_steps`` is below 1.
    """

    name = "reward_per_step"
    updates_every_step = True

    def __init__(self, step_gradient_steps: int | None = None) -> None:
        if step_gradient_steps is not None and step_gradient_steps < 1:
            raise ValueError(f"step_gradient_steps must be >= 1, got {step_gradient_steps}")
        self.step_gradient_steps = step_gradient_steps


def cost_to_go(walls: np.ndarray, geometry: MazeGeometry, goal_xy: np.ndarray, xy: np.ndarray) -> float:
    """The oracle's cost-to-go from ``xy``: metres along the maze grid's shortest path to the goal.

    In the goal's cell it is the straight-line distance to the goal; elsewhere it is the BFS distance
    (:func:`~antmaze_hirl.envs.layouts.bfs_distances`) from ``xy``'s cell to the goal's cell, in cells
    times the cell side, plus the distance from ``xy`` to its cell's centre. A point in a wall, outside
    the map or cut off from the goal costs ``inf``.
    """
    if not geometry.is_free(walls, xy):
        return math.inf
    cell, goal_cell = geometry.xy_to_cell(xy), geometry.xy_to_cell(goal_xy)
    if cell == goal_cell:
        return float(np.linalg.norm(np.asarray(xy) - goal_xy))
    cells = int(bfs_distances(walls, goal_cell)[cell])
    if cells < 0:
        return math.inf
    return cells * geometry.scale + float(np.linalg.norm(np.asarray(xy) - geometry.cell_to_xy(cell)))


class AggreVaTeQuery(QueryStrategy):
    """AggreVaTe(D) with the oracle's cost-to-go as the expert's Q (the paper's failed baseline).

    Rolls in as DAgger does (the beta mix of learner and expert, every state labelled, one expert query
    each), but the learner is not trained to copy the expert's subgoal: at each labelled state the
    ``n_directions`` heading-bin subgoals at the expert's step length are scored by ``Q = step + c``,
    the step's own length (``inf`` where the straight step touches a wall) plus :func:`cost_to_go`, and
    D stores the lowest-Q candidate. The learner's heading cross-entropy then trains it towards the
    argmin-Q bin, the hard-target reduction of AggreVaTe's cost-sensitive classification (Ross & Bagnell
    2014; a softmax of ``-Q`` would be the soft one); its distance head towards the expert's step length.

    How it differs from the paper's AggreVaTeD (Sun et al. 2017): there the expert's Q came from the
    environment's sparse reward (success or not), which is flat almost everywhere, so the learner had
    nothing to descend and failed. Here Q is the oracle's dense shortest-path cost-to-go, which no
    sparse-reward setting gives; it is close to DAgger with the labels snapped to the best heading bin,
    so it is an optimistic AggreVaTe, not the paper's. It is not a policy-gradient method (AggreVaTeD's
    "D"): the learner is trained by the same supervised update as every other method.

    Args:
        n_directions: Candidate headings; ``None``: the learner's heading bins (16 if it has none).

    Raises:
        ValueError: If ``n_directions`` is below 4.
    """

    name = "aggrevate"

    def __init__(self, n_directions: int | None = None) -> None:
        if n_directions is not None and n_directions < 4:
            raise ValueError(f"n_directions must be >= 4, got {n_directions}")
        self.n_directions = n_directions

    def attach(self, learner: Learner) -> None:
        """Takes the learner's heading bins, so each candidate is exactly one of its classes."""
        if self.n_directions is None:
            self.n_directions = int(getattr(getattr(learner, "settings", None), "n_directions", 16))

    def candidate_costs(
        self, walls: np.ndarray, geometry: MazeGeometry, goal_xy: np.ndarray, agent_xy: np.ndarray, distance: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """The heading-bin candidates ``(n, 2)`` at ``distance`` from ``agent_xy`` and their Q ``(n,)``."""
        n = self.n_directions if self.n_directions is not None else 16
        angles = np.arange(n) * (2 * np.pi / n)
        candidates = agent_xy + distance * np.stack([np.cos(angles), np.sin(angles)], axis=1)
        costs = [
            distance + cost_to_go(walls, geometry, goal_xy, c)
            if geometry.segment_is_free(walls, agent_xy, c)
            else math.inf
            for c in candidates
        ]
        return candidates, np.array(costs)

    def label_target(
        self, maze: MazeEnvProtocol, observation: dict[str, np.ndarray], expert_subgoal: np.ndarray
    ) -> np.ndarray:
        """The lowest-Q heading candidate at the expert's step length (the expert's subgoal if none is finite)."""
        agent_xy = np.asarray(STATE_LAYOUT.agent_xy(observation["state"]), dtype=np.float64)
        distance = float(np.linalg.norm(expert_subgoal - agent_xy))
        if distance == 0:
            return expert_subgoal
        candidates, costs = self.candidate_costs(maze.layout.walls, maze.geometry, maze.goal_xy, agent_xy, distance)
        if not np.isfinite(costs).any():
            return expert_subgoal
        return candidates[int(np.argmin(costs))]


class GatedQuery(QueryStrategy):
    """Uncertainty-gated queries: the expert is asked only where the learner is unsure (method ``gated``).

    At each high-level step the learner proposes a subgoal; the gate opens, and the expert is asked, where
    a :class:`BaggedEnsemble`'s members disagree on the state (their mean distance from their mean
    subgoal, in units of the learner's ``subgoal_reach_m``: :func:`~antmaze_hirl.dagger.gating.disagreement`)
    more than the threshold. An asked step's label is aggregated and the expert's subgoal is executed (the
    expert takes over for the step, as in ThriftyDAgger and HG-DAgger; the trainer's beta mix does not
    apply); an unasked step executes the learner's subgoal, adds nothing to D and costs nothing. The
    trainer also opens the gate before D holds any label and wherever the learner's clipped subgoal is a
    no-op (it would loop in place), so ``expert_cost`` counts asked steps and ``attempts`` all steps.

    The threshold is set from ``target_rate`` as ThriftyDAgger sets its own
    (:class:`~antmaze_hirl.dagger.gating.QuantileThreshold`): after every update it is the
    ``1 - target_rate`` quantile of the new ensemble's disagreement over the last ``reference_size``
    states the episodes visited, asked or not, so about ``target_rate`` of the states like those ask, and
    the threshold falls with the disagreement as the learner improves. Before the first update (no
    ensemble yet) the gate is open everywhere.

    With ``risk``, the gate also opens where a :class:`~antmaze_hirl.dagger.gating.RiskModel` (trained
    after every update on every executed step's outcome) gives the low level a probability above
    ``risk_threshold`` of missing the learner's subgoal: novelty OR risk, as ThriftyDAgger combines them.
    With ``label_failures``, after a failed episode the expert labels its unasked states (each label
    counts; in ask/tell these requests have ``executes=False``).

    Composition: ``inner`` picks starts and keeps or prunes labels (its ``choose_start``,
    ``on_episode_end``, ``label_target`` and ``on_update``): ``GatedQuery(inner=RewardBasedQuery())`` is
    method ``gated+reward`` and prunes the asked labels of failed episodes (``t_d`` counts the episode's
    labels back from its last); an inner :class:`MultiPolicyQuery` lends its ensemble to the gate.

    Args:
        inner: The start-selection or pruning strategy it wraps (default plain DAgger's corner starts).
        target_rate: The share of states that should ask, in ``(0, 1)``.
        reference_size: Recent states whose disagreement sets the threshold.
        n_policies: Ensemble size (ignored when ``inner`` is a :class:`MultiPolicyQuery`).
        member_steps: Gradient steps per member per update (as :class:`BaggedEnsemble`; ignored likewise).
        risk: Also gate on the learned risk of missing the subgoal.
        risk_threshold: Failure probability above which the risk opens the gate, in ``(0, 1)``.
        risk_steps: Gradient steps of the risk model per update.
        label_failures: Ask for labels of a failed episode's unasked states after it ends.

    Raises:
        ValueError: For an ``inner`` that gates or updates every step, or a setting out of range (named).
    """

    name = "gated"
    reads_policy_outputs = True
    gates = True

    def __init__(
        self,
        inner: QueryStrategy | None = None,
        *,
        target_rate: float = 0.2,
        reference_size: int = 200,
        n_policies: int = 5,
        member_steps: int | None = None,
        risk: bool = False,
        risk_threshold: float = 0.5,
        risk_steps: int = 100,
        label_failures: bool = False,
    ) -> None:
        inner = inner if inner is not None else DAggerQuery()
        if inner.gates or inner.updates_every_step:
            raise ValueError(f"GatedQuery cannot wrap {inner.name!r}: it gates or updates every step itself")
        if not 0.0 < risk_threshold < 1.0:
            raise ValueError(f"risk_threshold must be in (0, 1), got {risk_threshold!r}")
        if risk_steps < 1:
            raise ValueError(f"risk_steps must be >= 1, got {risk_steps}")
        self.inner = inner
        self.threshold = QuantileThreshold(target_rate)
        self.reference = ReferenceStates(reference_size)
        # One ensemble serves both where an inner multi-policy strategy already trains one.
        self.ensemble = inner if isinstance(inner, BaggedEnsemble) else BaggedEnsemble(n_policies, None, member_steps)
        self.risk = risk
        self.risk_threshold = float(risk_threshold)
        self.risk_steps = risk_steps
        self.label_failures = label_failures
        self.risk_model: RiskModel | None = None
        self.outcomes: list[tuple[np.ndarray, bool]] = []  # (risk features, failed) of every executed step
        self.subgoal_reach_m = 1.0
        self._last: tuple[int, EncodedBatch] | None = None  # the encoding of the observation gated last

    @property
    def method(self) -> str:
        """The method name: ``gated``, or ``gated+<inner>`` for a start-selecting or pruning inner strategy."""
        return "gated" if isinstance(self.inner, DAggerQuery) else f"gated+{self.inner.name}"

    def attach(self, learner: Learner) -> None:
        """Attaches the inner strategy and the ensemble to the learner; reads its ``subgoal_reach_m``."""
        self.inner.attach(learner)
        if self.ensemble is not self.inner:
            self.ensemble.attach(learner)
        self.subgoal_reach_m = float(getattr(learner, "subgoal_reach_m", 1.0))

    def novelty(self, encoded: EncodedBatch) -> np.ndarray:
        """The ensemble's disagreement at each encoded state (``inf`` before the first update: ask)."""
        if not self.ensemble.members:
            return np.full(len(encoded), np.inf)
        return disagreement(self.ensemble.member_offsets(encoded))

    def wants_label(self, observation: dict[str, np.ndarray], learner_subgoal: np.ndarray, learner: Learner) -> bool:
        """Whether the novelty (or, with ``risk``, the risk of the learner's subgoal) passes its threshold.

        The state joins the reference set whatever the answer.
        """
        encoded = self._encode(observation, learner)
        self.reference.add(encoded)
        if self.threshold.opens(float(self.novelty(encoded)[0])):
            return True
        if self.risk and self.risk_model is not None:
            features = RiskModel.features(encoded, self._offset(observation, learner_subgoal))
            return bool(self.risk_model.predict(features)[0] > self.risk_threshold)
        return False

    def on_step(self, observation: dict[str, np.ndarray], subgoal: np.ndarray, info: dict[str, Any]) -> None:
        """With ``risk``: keeps the step's features and whether the low level missed the subgoal."""
        if self.risk and self._last is not None and self._last[0] == id(observation):
            failed = not (info["subgoal_reached"] or info["is_success"])
            self.outcomes.append((RiskModel.features(self._last[1], self._offset(observation, subgoal))[0], failed))

    def on_update(self, dataset: DemonstrationDataset, gradient_steps: int, rng: np.random.Generator) -> None:
        """The inner strategy's update, the ensemble's training, the risk model's, then the new threshold."""
        self.inner.on_update(dataset, gradient_steps, rng)
        if self.ensemble is not self.inner:
            self.ensemble.on_update(dataset, gradient_steps, rng)
        if self.risk and self.outcomes:
            if self.risk_model is None:
                self.risk_model = RiskModel(rng=np.random.default_rng(rng.integers(2**63)))
            features, failed = zip(*self.outcomes, strict=True)
            self.risk_model.fit(np.stack(features), np.array(failed), self.risk_steps)
        if len(self.reference):
            self.threshold.fit(self.novelty(self.reference.batch()))

    def choose_start(self, query: StartQuery, rng: np.random.Generator) -> np.ndarray | None:
        """The inner strategy's start."""
        return self.inner.choose_start(query, rng)

    def on_episode_end(
        self, dataset: DemonstrationDataset, episode: int, success: bool, rng: np.random.Generator
    ) -> list[int]:
        """The inner strategy's pruning (of the episode's asked labels)."""
        return self.inner.on_episode_end(dataset, episode, success, rng)

    def label_target(
        self, maze: MazeEnvProtocol, observation: dict[str, np.ndarray], expert_subgoal: np.ndarray
    ) -> np.ndarray:
        """The inner strategy's stored label."""
        return self.inner.label_target(maze, observation, expert_subgoal)

    def _encode(self, observation: dict[str, np.ndarray], learner: Learner) -> EncodedBatch:
        if not isinstance(learner, OffsetLearner):
            raise ValueError(f"GatedQuery reads a HighLevelPolicy's encoder; got {type(learner).__name__}")
        encoded = learner.encoder.encode_observations([observation])
        self._last = (id(observation), encoded)
        return encoded

    def _offset(self, observation: dict[str, np.ndarray], subgoal: np.ndarray) -> np.ndarray:
        agent = np.asarray(STATE_LAYOUT.agent_xy(observation["state"]), dtype=np.float64)
        return ((np.asarray(subgoal, dtype=np.float64) - agent) / self.subgoal_reach_m)[None]


STRATEGIES: dict[str, type[QueryStrategy]] = {
    "dagger": DAggerQuery,
    "noise": NoiseQuery,
    "multi_policy": MultiPolicyQuery,
    "reward": RewardBasedQuery,
    "reward_per_step": RewardPerStepQuery,
    "aggrevate": AggreVaTeQuery,
    "gated": GatedQuery,
}
"""Strategy classes by method name (the ``--methods`` of ``antmaze-hirl experiment``)."""

GATED_INNER = ("noise", "multi_policy", "reward", "aggrevate")
"""The strategies ``gated`` composes with: method ``gated+<name>`` is ``GatedQuery(inner=<name>'s strategy)``."""

METHODS = (*STRATEGIES, *(f"gated+{name}" for name in GATED_INNER))
"""Every method name :func:`make_strategy` takes."""


def make_strategy(name: str) -> QueryStrategy:
    """A strategy with default settings by method name (one of :data:`METHODS`).

    ``gated+<inner>`` gates the queries of ``inner`` (one of :data:`GATED_INNER`): :class:`GatedQuery`.

    Raises:
        ValueError: For an unknown name.
    """
    if name not in METHODS:
        raise ValueError(f"unknown method {name!r}; choose from {list(METHODS)}")
    if name.startswith("gated+"):
        return GatedQuery(inner=make_strategy(name.removeprefix("gated+")))
    return STRATEGIES[name]()
