"""Distil a teacher low level (an action ensemble) into one actor network, DAgger-style, on the states it will meet.

Why: the shipped ant is a seven-head :class:`~antmaze_hirl.sb3_ext.ensemble.EnsemblePolicy`; every serial path
pays its forward pass. One network of a member's size acts several times faster, but a member alone flips far
more often than the ensemble (docs/results/ant-in-mazes.md). Regression onto the ensemble's actions on the
student's *own* states (DAgger: Ross et al., 2011) aims at the ensemble's behaviour in one network, where
behaviour cloning on the teacher's states alone would leave the student in states it never saw labelled.

The loop, per iteration ``i``:

1. **Collect.** Episodes are played by episode sources (:class:`HighLevelEpisodes`: a high-level policy, such as
   the scripted oracle, choosing subgoals in a maze env whose low level is this module's
   :class:`RecordingController`; :class:`ReachEpisodes`: chained random subgoals of a :class:`ReachEnv`). Each
   episode is driven by the teacher with probability ``beta0 * beta_decay**i``, else by the student (with
   optional Gaussian action noise); every low-level observation is recorded, whoever drives.
2. **Label.** The teacher's deterministic action (squashed, in ``[-1, 1]``) for every recorded state. States in
   the last ``flip_window`` steps before an episode's flip weigh ``flip_weight`` in the loss (1: no weighting).
3. **Aggregate and fit.** The rows join the data set (the newest ``max_rows`` kept); the student's actor is
   fitted by weighted mean-squared error to the labels, ``gradient_steps`` minibatches of ``batch_size``, with
   its own Adam (the actor optimiser SB3 saves in the zip, so a resumed run continues it).

The student is an ordinary SB3 TD3 model with a plain single actor (the teacher's network settings, its actor
started from one teacher head, the teacher's critic copied), saved as a normal zip: ``load_low_level``,
``eval-low``, the lab's in-maze runs and ``train-low --init-from`` (a TD3+HER fine-tune with a flip or tilt penalty)
all take it.

A run folder (:func:`distill`) holds ``state.json`` (settings, teacher fingerprint, completed iterations, the
per-iteration history), ``shards/iter_NNNNN.npz`` (each iteration's features, labels and weights) and
``students/iter_NNNNN.zip``. ``state.json`` is written last and atomically, so a run killed at any moment resumes
(``resume=True``) from its last completed iteration, and every random draw is seeded by ``(seed, iteration)``:
a resumed run repeats what an uninterrupted one would have done.
"""

from __future__ import annotations

import dataclasses
import json
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import torch as th
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm
from stable_baselines3.td3.policies import MultiInputPolicy

from antmaze_hirl.atomic_io import atomic_write_json, atomic_write_with
from antmaze_hirl.envs.reach import ReachEnv
from antmaze_hirl.rollout import play_episode
from antmaze_hirl.sb3_ext.action_penalty import ActionPenaltyPolicy
from antmaze_hirl.sb3_ext.ensemble import BatchedMeanOfHeads, MeanOfHeads
from antmaze_hirl.sb3_ext.loading import load_low_level, policy_fingerprint, save_policy
from antmaze_hirl.sb3_ext.numpy_actor import NumpyActor

STATE_FORMAT = "antmaze_hirl.distill/1"
"""``state.json``'s ``format``: a folder of another format is not resumed."""
EPISODE_SEED_BASE = 100_000_000
"""Episode ``k`` of iteration ``i`` resets with ``EPISODE_SEED_BASE + seed * 10_000_000 + i * 10_000 + k``: far from
every seed range of :data:`~antmaze_hirl.envs.profiles.SEEDS` (and training mazes come from the ``train`` part
of the layout partition anyway)."""
LABEL_ROWS = 4096
"""Rows the teacher labels per call (bounds the ``(heads, rows, 256)`` activations' memory)."""


@dataclass(frozen=True)
class DistillSettings:
    """The distillation's settings (all recorded in ``state.json``; a resume must give the same).

    Attributes:
        iterations: DAgger iterations in all (a resumed run counts the finished ones).
        steps_per_iteration: Low-level steps collected per iteration (the last episode finishes past it).
        beta0: Chance that the teacher drives an episode in iteration 0 (1: behaviour cloning first).
        beta_decay: Factor on that chance per iteration.
        action_noise_std: Std of Gaussian noise on the student's actions while it drives (clipped to the
            action bounds); widens the states seen near its own path. 0: none.
        gradient_steps: Minibatch updates of the student per iteration.
        batch_size: Rows per minibatch.
        learning_rate: Adam's step size for the regression.
        max_rows: Most rows kept in the data set (the oldest are dropped first).
        flip_window: Steps before an episode's flip whose states get ``flip_weight``.
        flip_weight: Loss weight of those states (1: every state alike).
        init_head: The teacher head the student's actor starts from (``None``: SB3's fresh initialisation).
        snapshot_every: Keep the student of every this many iterations (the latest is always kept).
        seed: Seeds every draw (episodes, drivers, noise, minibatches), with the iteration.
    """

    iterations: int = 100
    steps_per_iteration: int = 20_000
    beta0: float = 1.0
    beta_decay: float = 0.5
    action_noise_std: float = 0.0
    gradient_steps: int = 2_000
    batch_size: int = 256
    learning_rate: float = 3e-4
    max_rows: int = 1_500_000
    flip_window: int = 25
    flip_weight: float = 1.0
    init_head: int | None = 0
    snapshot_every: int = 5
    seed: int = 0

    def __post_init__(self) -> None:
        positive = ("iterations", "steps_per_iteration", "gradient_steps", "batch_size", "max_rows", "snapshot_every")
        for name in positive:
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
        if not 0 <= self.beta0 <= 1 or not 0 <= self.beta_decay <= 1:
            raise ValueError(f"beta0 and beta_decay must lie in [0, 1], got {self.beta0} and {self.beta_decay}")
        if not self.action_noise_std >= 0 or not self.learning_rate > 0 or not self.flip_weight > 0:
            raise ValueError(
                "action_noise_std must be >= 0, learning_rate and flip_weight > 0; got "
                f"{self.action_noise_std}, {self.learning_rate}, {self.flip_weight}"
            )
        if self.flip_window < 0:
            raise ValueError(f"flip_window must be >= 0, got {self.flip_window}")

    def beta(self, iteration: int) -> float:
        """The chance that the teacher drives an episode of ``iteration``."""
        return self.beta0 * self.beta_decay**iteration


@dataclass(frozen=True)
class Episode:
    """How one collected episode went.

    Attributes:
        steps: Low-level steps played.
        success: Whether it reached its (final) goal.
        flipped: Whether the ant turned over (which ends it).
    """

    steps: int
    success: bool
    flipped: bool


class EpisodeSource(Protocol):
    """Plays one episode with the :class:`RecordingController` it was built around."""

    def play(self, seed: int) -> Episode:
        """Plays the episode that ``seed`` draws."""
        ...

    def close(self) -> None:
        """Releases the env."""
        ...


class RecordingController:
    """A low-level controller that records every goal observation it is asked about and acts with the driver.

    :func:`distill` sets the driver (student or teacher, a numpy actor) before each episode. It is stateless
    between calls, so a maze env may call it directly.
    """

    def __init__(self) -> None:
        self.driver: Callable[[dict[str, np.ndarray]], np.ndarray] | None = None
        self.noise_std = 0.0
        self.rng = np.random.default_rng(0)
        self.action_low = -np.ones(1)
        self.action_high = np.ones(1)
        self.observations: list[np.ndarray] = []
        self.achieved: list[np.ndarray] = []
        self.desired: list[np.ndarray] = []

    def __call__(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """Records ``observation`` and returns the driver's action (plus noise, if set)."""
        if self.driver is None:
            raise RuntimeError("RecordingController has no driver: distill() sets one before each episode")
        self.observations.append(np.asarray(observation["observation"], dtype=np.float64).copy())
        self.achieved.append(np.asarray(observation["achieved_goal"], dtype=np.float64).copy())
        self.desired.append(np.asarray(observation["desired_goal"], dtype=np.float64).copy())
        action = np.asarray(self.driver(observation), dtype=np.float64)
        if self.noise_std > 0:
            noisy = action + self.rng.normal(0.0, self.noise_std, action.shape)
            action = np.clip(noisy, self.action_low, self.action_high)
        return action

    @property
    def rows(self) -> int:
        """Observations recorded so far."""
        return len(self.observations)

    def take(self) -> dict[str, np.ndarray]:
        """The recorded observations as a batch (rows, ...), and forgets them."""
        batch = {
            "observation": np.array(self.observations),
            "achieved_goal": np.array(self.achieved),
            "desired_goal": np.array(self.desired),
        }
        self.observations, self.achieved, self.desired = [], [], []
        return batch


class HighLevelEpisodes:
    """Episodes of a high-level maze env (its low level: the recording controller), subgoals from ``high_level``.

    Args:
        env: A high-level maze env made with ``low_level=`` the run's :class:`RecordingController`.
        high_level: ``observation -> subgoal`` (e.g. the scripted oracle), or any policy that
            :func:`~antmaze_hirl.rollout.play_episode` plays (an object with ``predict``). A subgoal outside the
            maze is clipped to it, as ``play_episode`` does, not refused by ``env.step`` (as it was before
            these episodes were played by ``play_episode``).
        step_limit: Optional ``env -> low-level step budget`` set after every reset (e.g. scaled to the path).
    """

    def __init__(self, env: Any, high_level: Any, step_limit: Callable[[Any], int] | None = None) -> None:
        self.env = env
        self.high_level = high_level
        self.step_limit = step_limit

    def play(self, seed: int) -> Episode:
        """One episode from ``env.reset(seed=seed)`` to its end (:func:`~antmaze_hirl.rollout.play_episode`)."""
        episode = play_episode(self.env, self.high_level, seed=seed, after_reset=self._limit_steps)
        return Episode(int(episode.info["total_low_level_steps"]), episode.success, bool(episode.info["flipped"]))

    def _limit_steps(self) -> None:
        # The budget depends on the layout, which only the reset draws.
        if self.step_limit is not None:
            self.env.unwrapped.max_steps = int(self.step_limit(self.env.unwrapped))

    def close(self) -> None:
        """Closes the env."""
        self.env.close()


class ReachEpisodes:
    """Episodes of chained random subgoals on a :class:`ReachEnv` (``eval-low``'s kind of subgoal, from rest first).

    An episode resets with the seed, then walks to ``subgoals`` subgoals in a row (each later one drawn without
    resetting the body, from wherever the walk left it), each until reached or ``env.horizon`` steps; a flip
    ends it. Success: every subgoal reached.

    Args:
        env: The reach env.
        controller: The run's :class:`RecordingController`.
        subgoals: Subgoals per episode.
    """

    def __init__(self, env: ReachEnv, controller: RecordingController, subgoals: int = 5) -> None:
        if subgoals < 1:
            raise ValueError(f"subgoals must be >= 1, got {subgoals}")
        self.env = env
        self.controller = controller
        self.subgoals = subgoals

    def play(self, seed: int) -> Episode:
        """One episode: ``subgoals`` chained subgoals after ``env.reset(seed=seed)``."""
        obs, _ = self.env.reset(seed=seed)
        steps, reached = 0, 0
        for index in range(self.subgoals):
            if index > 0:
                obs = self.env.set_subgoal(self.env.sample_subgoal())
            for _ in range(self.env.horizon):
                obs, _, _, _, info = self.env.step(self.controller(obs))
                steps += 1
                if info["flipped"]:
                    return Episode(steps, False, True)
                if info["is_success"]:
                    reached += 1
                    break
        return Episode(steps, reached == self.subgoals, False)

    def close(self) -> None:
        """Closes the env."""
        self.env.close()


def make_student(teacher_path: str | Path, body: str = "ant", *, init_head: int | None = 0) -> OffPolicyAlgorithm:
    """A TD3 model with a plain single actor of the teacher's network settings, ready for :func:`distill`.

    Its actor starts from the teacher's head ``init_head`` (``None``: a fresh initialisation), its twin critic
    is the teacher's (an ensemble's is its first member's), so a TD3 fine-tune can start from it.

    Raises:
        ValueError: If the teacher is not a TD3 ``MultiInputPolicy`` model (plain or ensemble), or has no head
            ``init_head``.
    """
    teacher = load_low_level(body, teacher_path)
    student = load_low_level(body, teacher_path)  # a second copy, whose policy is replaced
    if not isinstance(teacher.policy, MultiInputPolicy):
        raise ValueError(f"{teacher_path} holds a {type(teacher.policy).__name__}; the student is a TD3 actor")
    settings = {key: value for key, value in teacher.policy_kwargs.items() if key not in ("n_members", "batched_heads")}
    policy_class = ActionPenaltyPolicy if isinstance(teacher.policy, ActionPenaltyPolicy) else MultiInputPolicy
    policy = policy_class(teacher.observation_space, teacher.action_space, teacher.lr_schedule, **settings)
    if init_head is not None:
        mu = teacher.policy.actor.mu
        heads = mu.head_states() if isinstance(mu, MeanOfHeads | BatchedMeanOfHeads) else [mu.state_dict()]
        if not 0 <= init_head < len(heads):
            raise ValueError(f"init_head {init_head}: the teacher has heads 0..{len(heads) - 1}")
        policy.actor.mu.load_state_dict(heads[init_head])
        policy.actor_target.load_state_dict(policy.actor.state_dict())
    policy.critic.load_state_dict(teacher.policy.critic.state_dict())
    policy.critic_target.load_state_dict(teacher.policy.critic_target.state_dict())
    student.policy = policy
    student.policy_class = policy_class
    student.policy_kwargs = settings
    student._create_aliases()  # TD3's actor/critic attributes point into the new policy
    return student


def label(teacher: NumpyActor, features: np.ndarray) -> np.ndarray:
    """The teacher's squashed actions (float32 ``(rows, action_dim)``) for features, :data:`LABEL_ROWS` at a time."""
    return np.concatenate(
        [teacher.squashed(features[start : start + LABEL_ROWS]) for start in range(0, len(features), LABEL_ROWS)]
        or [np.zeros((0, teacher.weights[-1].shape[-1]), np.float32)]
    )


def flip_weights(episodes: Sequence[Episode], window: int, weight: float) -> np.ndarray:
    """Per recorded row of ``episodes`` (in order): ``weight`` in the last ``window`` steps before a flip, else 1."""
    parts = []
    for episode in episodes:
        weights = np.ones(episode.steps, np.float32)
        if episode.flipped and window > 0:
            weights[-window:] = weight
        parts.append(weights)
    return np.concatenate(parts) if parts else np.zeros(0, np.float32)


def fit_student(
    student: OffPolicyAlgorithm,
    features: np.ndarray,
    labels: np.ndarray,
    weights: np.ndarray,
    *,
    gradient_steps: int,
    batch_size: int,
    learning_rate: float,
    rng: np.random.Generator,
) -> float:
    """Fits the student's actor output network to ``labels`` (weighted MSE); returns the mean loss of the last tenth.

    Uses the actor's own optimiser (SB3's Adam, saved in the zip) with its step size set to ``learning_rate``.
    """
    actor = student.policy.actor
    actor.set_training_mode(True)
    optimizer = actor.optimizer
    for group in optimizer.param_groups:
        group["lr"] = learning_rate
    features_t, labels_t, weights_t = (th.as_tensor(array) for array in (features, labels, weights))
    losses = []
    for _ in range(gradient_steps):
        rows = th.as_tensor(rng.integers(len(features), size=batch_size))
        predicted = actor.mu(features_t[rows])
        loss = (weights_t[rows] * (predicted - labels_t[rows]).pow(2).mean(dim=1)).sum() / weights_t[rows].sum()
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        losses.append(loss.item())
    actor.set_training_mode(False)
    student.policy.actor_target.load_state_dict(actor.state_dict())
    tail = losses[-max(1, gradient_steps // 10) :]
    return float(np.mean(tail))


def collect(
    sources: Sequence[EpisodeSource],
    controller: RecordingController,
    drivers: dict[str, Callable[[dict[str, np.ndarray]], np.ndarray]],
    *,
    steps: int,
    beta: float,
    noise_std: float,
    rng: np.random.Generator,
    first_seed: int,
) -> tuple[dict[str, np.ndarray], list[Episode], list[str]]:
    """Plays episodes, cycling through ``sources``, until at least ``steps`` low-level steps are recorded.

    Returns:
        The recorded observations, the episodes in order and who drove each (``"teacher"``/``"student"``).
    """
    episodes: list[Episode] = []
    drivers_used: list[str] = []
    while controller.rows < steps:
        index = len(episodes)
        name = "teacher" if rng.random() < beta else "student"
        controller.driver = drivers[name]
        controller.noise_std = noise_std if name == "student" else 0.0
        before = controller.rows
        episode = sources[index % len(sources)].play(first_seed + index)
        if controller.rows - before != episode.steps:  # a source that skips the recorder would misalign weights
            raise RuntimeError(f"episode recorded {controller.rows - before} rows for {episode.steps} steps")
        episodes.append(episode)
        drivers_used.append(name)
    return controller.take(), episodes, drivers_used


def episode_stats(episodes: Sequence[Episode], drivers: Sequence[str]) -> dict[str, Any]:
    """Per driver: episodes, steps, successes, flips and flips per 10,000 low-level steps."""
    stats = {}
    for name in ("teacher", "student"):
        mine = [episode for episode, driver in zip(episodes, drivers, strict=True) if driver == name]
        steps = sum(episode.steps for episode in mine)
        flips = sum(episode.flipped for episode in mine)
        stats[name] = {
            "episodes": len(mine),
            "steps": steps,
            "successes": sum(episode.success for episode in mine),
            "flips": flips,
            "flips_per_10k_steps": 1e4 * flips / steps if steps else None,
        }
    return stats


class Dataset:
    """The aggregate: features, labels and weights of every iteration's shard, the newest ``max_rows`` rows."""

    def __init__(self, max_rows: int) -> None:
        self.max_rows = max_rows
        self.parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []

    def add(self, features: np.ndarray, labels: np.ndarray, weights: np.ndarray) -> None:
        """Appends one shard's rows and drops the oldest rows beyond ``max_rows``."""
        self.parts.append((features, labels, weights))
        excess = sum(len(part[0]) for part in self.parts) - self.max_rows
        while excess > 0:
            first = self.parts[0]
            if len(first[0]) <= excess:
                self.parts.pop(0)
                excess -= len(first[0])
            else:
                self.parts[0] = tuple(array[excess:] for array in first)  # type: ignore[assignment]
                excess = 0

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """All kept rows: ``(features, labels, weights)``."""
        return tuple(np.concatenate([part[k] for part in self.parts]) for k in range(3))  # type: ignore[return-value]

    def __len__(self) -> int:
        return sum(len(part[0]) for part in self.parts)


def _save_npz(path: Path, **arrays: np.ndarray) -> Path:
    def write(tmp: Path) -> None:
        with open(tmp, "wb") as handle:
            np.savez(handle, **arrays)

    return atomic_write_with(path, write)


def _shard_path(out_dir: Path, iteration: int) -> Path:
    return out_dir / "shards" / f"iter_{iteration:05d}.npz"


def _student_path(out_dir: Path, iteration: int) -> Path:
    return out_dir / "students" / f"iter_{iteration:05d}.zip"


def distill(
    teacher_path: str | Path,
    out_dir: str | Path,
    make_sources: Callable[[RecordingController], Sequence[EpisodeSource]],
    settings: DistillSettings,
    *,
    body: str = "ant",
    resume: bool = False,
    init_student: str | Path | None = None,
    description: dict[str, Any] | None = None,
    log: Callable[[str], None] = print,
) -> Path:
    """Runs (or resumes) the distillation in ``out_dir`` (module docstring); returns the latest student's path.

    Args:
        teacher_path: The teacher low level's zip (an ensemble or any TD3 actor).
        out_dir: The run folder.
        make_sources: Builds the episode sources around the run's controller (called once per process).
        settings: The run's settings.
        body: The body.
        resume: Continue the run in ``out_dir`` (its settings, teacher and ``description`` must match).
        init_student: Start a new run from this plain single-actor TD3 zip (e.g. an earlier run's student, when that
            run's folder is gone) instead of from a teacher head (``settings.init_head`` is then unused). Recorded
            in ``state.json``; on resume it must be the one the run started from.
        description: What ``make_sources`` builds (maze sizes, the high level, ...), recorded and checked on resume.
        log: Where the per-iteration line goes.

    Raises:
        FileExistsError: If ``out_dir`` holds a run and ``resume`` is False.
        FileNotFoundError: If ``resume`` and ``out_dir`` holds no run.
        ValueError: If the run in ``out_dir`` was made with other settings, teacher, body or description.
    """
    out_dir = Path(out_dir)
    state_path = out_dir / "state.json"
    teacher_model = load_low_level(body, teacher_path)
    identity = {
        "format": STATE_FORMAT,
        "body": body,
        "teacher": str(teacher_path),
        "teacher_fingerprint": policy_fingerprint(teacher_model),
        "settings": dataclasses.asdict(settings),
        "description": description or {},
        "init_student": None if init_student is None else str(init_student),
    }
    if resume:
        if not state_path.is_file():
            raise FileNotFoundError(f"no distillation run to resume in {out_dir} (no state.json)")
        state = json.loads(state_path.read_text())
        differ = _differences(state, identity)
        if differ:
            raise ValueError(f"{state_path} was made with other settings: {'; '.join(differ)}")
        student = load_low_level(body, out_dir / state["student"])
    else:
        if state_path.exists():
            raise FileExistsError(f"{out_dir} already holds a distillation run; resume it or choose another folder")
        state = {**identity, "completed_iterations": 0, "rows": 0, "student": None, "history": []}
        student = (
            make_student(teacher_path, body, init_head=settings.init_head)
            if init_student is None
            else _plain_student(body, init_student)
        )
    teacher = NumpyActor.from_model(teacher_model)
    dataset = Dataset(settings.max_rows)
    for iteration in range(state["completed_iterations"]):
        with np.load(_shard_path(out_dir, iteration)) as shard:
            dataset.add(shard["features"], shard["labels"], shard["weights"])
    controller = RecordingController()
    controller.action_low = teacher.action_low.astype(np.float64)
    controller.action_high = teacher.action_high.astype(np.float64)
    sources = list(make_sources(controller))
    try:
        for iteration in range(state["completed_iterations"], settings.iterations):
            started = time.perf_counter()
            rng = np.random.default_rng([settings.seed, iteration])
            th.manual_seed(int(rng.integers(2**31)))
            controller.rng = np.random.default_rng([settings.seed, iteration, 1])
            beta = settings.beta(iteration)
            student_actor = NumpyActor.from_model(student)
            observations, episodes, drivers = collect(
                sources,
                controller,
                {"teacher": teacher, "student": student_actor},
                steps=settings.steps_per_iteration,
                beta=beta,
                noise_std=settings.action_noise_std,
                rng=rng,
                first_seed=EPISODE_SEED_BASE + settings.seed * 10_000_000 + iteration * 10_000,
            )
            collected = time.perf_counter()
            features = teacher.features(observations)
            labels = label(teacher, features)
            weights = flip_weights(episodes, settings.flip_window, settings.flip_weight)
            on_policy_mse = float(np.mean((student_actor.squashed(features) - labels) ** 2))
            _save_npz(_shard_path(out_dir, iteration), features=features, labels=labels, weights=weights)
            dataset.add(features, labels, weights)
            loss = fit_student(
                student,
                *dataset.arrays(),
                gradient_steps=settings.gradient_steps,
                batch_size=settings.batch_size,
                learning_rate=settings.learning_rate,
                rng=rng,
            )
            student_path = save_policy(student, _student_path(out_dir, iteration))
            previous = state["student"]
            record = {
                "iteration": iteration,
                "beta": beta,
                "rows_new": len(features),
                "rows_kept": len(dataset),
                "on_policy_mse_before_fit": on_policy_mse,
                "fit_loss": loss,
                **episode_stats(episodes, drivers),
                "seconds_collect": round(collected - started, 1),
                "seconds": round(time.perf_counter() - started, 1),
            }
            state.update(
                completed_iterations=iteration + 1,
                rows=state["rows"] + len(features),
                student=str(student_path.relative_to(out_dir)),
                student_fingerprint=policy_fingerprint(student),
                history=[*state["history"], record],
            )
            atomic_write_json(state_path, state)  # the commit point: the iteration counts from here on
            _drop_student(out_dir, previous, settings.snapshot_every)
            log(json.dumps(record))
    finally:
        for source in sources:
            source.close()
    return out_dir / state["student"]


def _plain_student(body: str, path: str | Path) -> OffPolicyAlgorithm:
    # A student to continue from: a TD3 actor with one output network (an ensemble's heads cannot be fitted as one).
    model = load_low_level(body, path)
    if not isinstance(model.policy, MultiInputPolicy) or isinstance(
        model.policy.actor.mu, MeanOfHeads | BatchedMeanOfHeads
    ):
        raise ValueError(
            f"init_student {path} is not a plain single-actor TD3 policy (an ensemble, or another algorithm)"
        )
    return model


def _differences(state: dict[str, Any], identity: dict[str, Any]) -> list[str]:
    # What a resume may not change, named one by one: everything recorded but the teacher's path (its
    # fingerprint is checked) and the iteration count (a run may be extended).
    found, now = dict(state.get("settings") or {}), dict(identity["settings"])
    found.pop("iterations", None)
    now.pop("iterations", None)
    differ = [f"{key} {found.get(key)!r} there, {value!r} now" for key, value in now.items() if found.get(key) != value]
    for key, value in identity.items():
        if key not in ("teacher", "settings") and state.get(key) != value:
            differ.append(f"{key} {state.get(key)!r} there, {value!r} now")
    return differ


def _drop_student(out_dir: Path, relative: str | None, snapshot_every: int) -> None:
    # The previous latest student goes once a newer one is committed, unless it is a snapshot.
    if relative is None:
        return
    iteration = int(Path(relative).stem.split("_")[1])
    if (iteration + 1) % snapshot_every != 0:
        (out_dir / relative).unlink(missing_ok=True)


__all__ = [
    "Dataset",
    "DistillSettings",
    "Episode",
    "EpisodeSource",
    "HighLevelEpisodes",
    "ReachEpisodes",
    "RecordingController",
    "distill",
    "fit_student",
    "flip_weights",
    "label",
    "make_student",
]
