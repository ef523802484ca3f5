"""DAgger for the high level (the paper's Alg. 1) with pluggable active-learning query strategies."""

from __future__ import annotations

from collections.abc import Callable, Generator
from dataclasses import asdict, dataclass, replace
from typing import Any, Literal

import numpy as np
from tqdm.auto import tqdm

from antmaze_hirl.dagger.dataset import Demonstration, DemonstrationDataset
from antmaze_hirl.dagger.protocols import Learner, OffsetLearner
from antmaze_hirl.dagger.schedules import BetaSchedule, InverseDecayBetaSchedule
from antmaze_hirl.dagger.strategies import DAggerQuery, QueryStrategy, StartQuery
from antmaze_hirl.dagger.streams import trainer_streams
from antmaze_hirl.envs.layouts import bfs_distances
from antmaze_hirl.envs.protocol import MazeEnvProtocol, maze_env
from antmaze_hirl.envs.reach import as_finite_vector
from antmaze_hirl.envs.state_layout import STATE_LAYOUT
from antmaze_hirl.experts.base import Expert

Mixing = Literal["blend", "switch"]


@dataclass(frozen=True)
class EpisodeRecord:
    """Measures of one training episode.

    Attributes:
        episode: Index, from 0.
        success: Whether the goal was reached.
        expert_cost: Expert labels queried in the episode: one per high-level step, except with a gating
            strategy (``gated``), where only asked steps (and labels after a failure) count.
        attempts: Subgoals executed (the paper's "attempts"), asked or not.
        low_level_steps: Low-level steps used.
        beta: Expert weight used in the episode (1.0 with a gating strategy: asked steps run the expert's subgoal).
        dataset_size: Labels in D after the episode (and any removal).
        removed: Labels removed after the episode (reward-based strategy).
    """

    episode: int
    success: bool
    expert_cost: int
    attempts: int
    low_level_steps: int
    beta: float
    dataset_size: int
    removed: int

    def to_dict(self) -> dict[str, Any]:
        """Plain dict, for CSV rows."""
        return asdict(self)


@dataclass(frozen=True)
class LabelRequest:
    """A high-level state where the trainer waits for the expert's subgoal.

    Attributes:
        observation: The high-level observation to label.
        learner_subgoal: What the learner proposes here (a page may show it).
        episode: Training episode index, from 0.
        label_index: Label index within the episode, from 0 (the expert cost so far; not the high-level
            step, which a gating strategy may have walked unasked).
        beta: The expert's weight in the executed mix this episode.
        executes: Whether the label is executed; ``False`` for the labels a gating strategy asks for after
            a failed episode (of states the learner passed unasked), which only join D.
    """

    observation: dict[str, np.ndarray]
    learner_subgoal: np.ndarray
    episode: int
    label_index: int
    beta: float
    executes: bool = True


@dataclass(frozen=True)
class ExecutedStep:
    """One high-level step the env executed.

    Attributes:
        subgoal: The subgoal sent to the env (the mix of expert and learner, or the learner's unasked).
        expert_subgoal: The expert's label it came from; ``None`` for a step a gating strategy did not ask.
        info: The env's step ``info`` (``agent_path``, ``subgoal_reached``, ``flipped``, ...).
        done: Whether the episode ended with this step.
        observation: The high-level observation the step started from.
    """

    subgoal: np.ndarray
    expert_subgoal: np.ndarray | None
    info: dict[str, Any]
    done: bool
    observation: dict[str, np.ndarray]

    @property
    def asked(self) -> bool:
        """Whether the expert labelled this step."""
        return self.expert_subgoal is not None


class EpisodeRun:
    """A training episode in progress, driven by ask/tell: read :attr:`request`, call :meth:`answer`.

    Made by :meth:`DAggerTrainer.start_episode`. Between two answers the trainer is idle, so the label
    may come from anywhere, at any time (a click over HTTP). Once :attr:`done`, :meth:`finish` runs the
    learner update that is due. An unanswered run can be dropped: the trainer's aggregated data then
    holds the labels of its answered steps.

    With a gating strategy (``gated``) the learner may walk unasked steps before a request, or the whole
    episode: :attr:`executed` holds the steps run before the current request (or the end), so a page can
    show them; a run may be :attr:`done` as soon as it is made.
    """

    def __init__(
        self,
        steps: Callable[[list[ExecutedStep]], Generator[LabelRequest, Any, EpisodeRecord]],
        update: Callable[[], None],
    ) -> None:
        self._update = update
        self._executed: list[ExecutedStep] = []
        self._steps = steps(self._executed)
        self.request: LabelRequest | None = None
        self.record: EpisodeRecord | None = None
        self._advance(None)

    @property
    def executed(self) -> list[ExecutedStep]:
        """The steps executed since the last answer (since the start before the first), in order."""
        return list(self._executed)

    @property
    def done(self) -> bool:
        """Whether the episode has ended (then :attr:`record` holds its measures)."""
        return self.record is not None

    def answer(self, subgoal: np.ndarray) -> list[ExecutedStep]:
        """Gives the expert's subgoal for :attr:`request`; runs the env to the next request or the end.

        Returns:
            The steps executed since the label, in order (as :attr:`executed`; none for a label that
            does not execute, :attr:`LabelRequest.executes`).

        Raises:
            RuntimeError: If the episode has already ended.
            ValueError: If ``subgoal`` is not two finite numbers (nothing is executed then).
        """
        if self.done:
            raise RuntimeError("the episode has ended; start another with DAggerTrainer.start_episode()")
        try:  # checked before the coroutine runs, so a bad label leaves the run as it was
            label = as_finite_vector(subgoal, 2, "expert subgoal")
        except (TypeError, ValueError) as error:
            raise ValueError(f"expert subgoal must be two finite numbers (x, y metres), got {subgoal!r}") from error
        self._executed.clear()
        self._advance(label)
        return self.executed

    def finish(self) -> None:
        """Runs the learner update due after this episode (a no-op when none is due, or run already).

        :meth:`answer` returns as soon as the env has run, so the expert sees the episode end at once;
        the update (gradient steps, the strategy's ensemble) runs here, e.g. while a page animates the
        last walk. :meth:`DAggerTrainer.start_episode` runs it too if it is still due.

        Raises:
            RuntimeError: If the episode has not ended.
        """
        if not self.done:
            raise RuntimeError("the episode is still running: answer its requests first")
        self._update()

    def _advance(self, value: Any) -> None:
        try:
            self.request = self._steps.send(value)
        except StopIteration as stop:
            self.request, self.record = None, stop.value


class DAggerTrainer:
    """Trains a learner (:class:`~antmaze_hirl.dagger.HighLevelPolicy` or any :class:`Learner`) by DAgger.

    Per episode: sample a task with the env's ``sample_task`` (maze and goal; the strategy may choose
    the start, else the env's reset places it); at each high-level step
    query the expert for ``pi*(s)``, execute the mix of learner and expert subgoals with the env's
    low-level controller, and aggregate ``(s, pi*(s))`` into D (the strategy's ``label_target``, which
    only AggreVaTe changes). Every ``episodes_per_update`` episodes, run ``gradient_steps`` of regression
    on D and advance beta (``beta <- beta / d`` by default); a strategy with ``updates_every_step``
    (Alg. 4 as written) does both after every step instead.

    Beta is the *expert's* weight, as in Ross et al. and ``imitation``: beta = 1 executes the expert's
    subgoal, beta = 0 the learner's. A mix that is still a no-op after clipping to the maze (the env's
    ``is_no_op_subgoal``: within ``min_subgoal_distance_m`` of the agent, as a learner pointing into a
    border corner, or two opposite proposals blended) is replaced by the expert's subgoal: it would be
    "reached" without moving, so every low-level step would cost a label and add the same sample to D.

    Args:
        env: High-level env (``antmaze_hirl/...Maze-v0``), possibly wrapped: the trainer resets and steps it,
            and reads the rest through :attr:`maze`.
        expert: Labels observations (:class:`~antmaze_hirl.experts.base.Expert`); each label costs one.
        learner: The high-level learner it trains (start-selecting strategies need an
            :class:`~antmaze_hirl.dagger.protocols.OffsetLearner`, such as ``HighLevelPolicy``).
        rng: Spawns the trainer's three independent streams (:attr:`streams`): tasks (maze, goal, the env's
            reset seed), the strategy's draws and ``"switch"`` mixing. Spawning draws nothing from ``rng``
            (unless it has no seed sequence: see :func:`~antmaze_hirl.dagger.streams.spawn_generators`), so
            it may also be the learner's, and a strategy's draws never shift the tasks. Two trainers built
            from equal fresh Generators (``default_rng(seed)`` each, as ``make_trainer`` does) train on the
            same mazes and goals (the start is the strategy's choice); two built from one Generator object
            do not, since each spawn advances its spawn counter.
        strategy: Active-learning strategy; default plain DAgger.
        beta_schedule: Beta after ``k`` updates; default :class:`InverseDecayBetaSchedule` with d = 2.
        mixing: ``"blend"`` executes ``beta * expert + (1 - beta) * learner`` (the paper); ``"switch"``
            executes the expert's subgoal with probability beta, else the learner's (``imitation``).
        episodes_per_update: K, episodes between updates.
        gradient_steps: N, gradient steps per update.
        per_step_gradient_steps: Gradient steps after every high-level step, beta unchanged; 0 disables
            them. Alg. 4 as written (updates and beta decay after every step) is the strategy's
            :attr:`~antmaze_hirl.dagger.strategies.QueryStrategy.updates_every_step` (method
            ``reward_per_step``).

    Raises:
        TypeError: If ``env`` is no high-level maze env (:func:`~antmaze_hirl.envs.protocol.maze_env`).
        ValueError: If ``mixing``, a count or the strategy does not fit (names the value).
    """

    # What the learner's fit_dataset returned at the last update (None before any): read by loggers such as
    # TensorBoard's. A class default, so trainers pickled before it existed still have it.
    last_loss: float | None = None

    def __init__(
        self,
        *,
        env: Any,
        expert: Expert,
        learner: Learner,
        rng: np.random.Generator,
        strategy: QueryStrategy | None = None,
        beta_schedule: BetaSchedule | None = None,
        mixing: Mixing = "blend",
        episodes_per_update: int = 1,
        gradient_steps: int = 200,
        per_step_gradient_steps: int = 0,
    ) -> None:
        if mixing not in ("blend", "switch"):
            raise ValueError(f"mixing must be 'blend' or 'switch', got {mixing!r}")
        if episodes_per_update < 1:
            raise ValueError(f"episodes_per_update must be >= 1, got {episodes_per_update}")
        if gradient_steps < 0 or per_step_gradient_steps < 0:
            raise ValueError("gradient step counts must be >= 0")
        maze_env(env)  # a wrong env fails here, not at the first episode
        self.env = env
        self.expert = expert
        self.learner = learner
        self.rng = rng
        self.streams = trainer_streams(rng)
        self.strategy = strategy if strategy is not None else DAggerQuery()
        if self.strategy.reads_policy_outputs and not isinstance(learner, OffsetLearner):
            raise ValueError(
                f"strategy {self.strategy.name!r} reads a HighLevelPolicy's outputs; got {type(learner).__name__}"
            )
        self.strategy.attach(learner)
        self.beta_schedule = beta_schedule if beta_schedule is not None else InverseDecayBetaSchedule()
        self.mixing = mixing
        self.episodes_per_update = episodes_per_update
        self.gradient_steps = gradient_steps
        self.per_step_gradient_steps = per_step_gradient_steps
        self.dataset = DemonstrationDataset()
        self.updates = 0
        self.episodes_done = 0
        self.total_expert_cost = 0
        self._rest_body: np.ndarray | None = None
        self._update_due = False

    @property
    def maze(self) -> MazeEnvProtocol:
        """The maze env under :attr:`env`'s wrappers: the episode's maze, task draws and subgoal checks.

        Looked up on every call rather than kept, since a study checkpoint detaches :attr:`env` and attaches
        a rebuilt one.
        """
        return maze_env(self.env)

    @property
    def beta(self) -> float:
        """The current expert weight."""
        return float(self.beta_schedule(self.updates))

    def train(
        self,
        episodes: int,
        *,
        callback: Callable[[EpisodeRecord], None] | None = None,
        progress_bar: bool = False,
    ) -> list[EpisodeRecord]:
        """Runs ``episodes`` training episodes.

        Args:
            episodes: Number of episodes.
            callback: Called with each episode's record (e.g. to evaluate every M episodes).
            progress_bar: Show a tqdm bar.
        """
        records = []
        for _ in tqdm(range(episodes), disable=not progress_bar, desc="DAgger", unit="episode"):
            record = self.run_episode()
            records.append(record)
            if callback is not None:
                callback(record)
        return records

    def run_episode(self) -> EpisodeRecord:
        """Runs one training episode with :attr:`expert`, aggregates its labels and updates the learner when due."""
        run = self.start_episode()
        while not run.done:
            run.answer(self.expert.label(run.request.observation))
        run.finish()
        return run.record

    def start_episode(self) -> EpisodeRun:
        """Starts a training episode that its expert drives by ask/tell (a person answering over HTTP).

        The trainer does not call :attr:`expert` here: the caller answers each
        :attr:`EpisodeRun.request` with :meth:`EpisodeRun.answer`, whenever the label arrives.
        :meth:`run_episode` is this loop with :attr:`expert` answering at once, so both paths run the
        same code and give the same numbers.
        """
        self._update_if_due()
        return EpisodeRun(self._episode_steps, self._update_if_due)

    def _update_if_due(self) -> None:
        # The episode-end update, every episodes_per_update episodes (set at the end of _episode_steps).
        if self._update_due:
            self._update_due = False
            self._update(self.gradient_steps)

    def _update(self, steps: int) -> None:
        # One update: gradient steps on D, the strategy's own models, beta's next step.
        self._fit(steps)
        self.strategy.on_update(self.dataset, steps, self.streams.strategy)
        self.updates += 1

    def _episode_steps(self, executed: list[ExecutedStep]) -> Generator[LabelRequest, Any, EpisodeRecord]:
        # One episode as a coroutine: it yields where it needs a label and receives the expert's subgoal.
        # The task stream draws layout, goal and reset seed; the start is the strategy's, else the env's reset
        # places it. The strategy draws from its own stream, so it never shifts the next episode's task.
        task = self.maze.sample_task(self.streams.tasks, draw_start=False)
        reset_seed = int(self.streams.tasks.integers(2**31))
        if self._rest_body is not None:
            query = self._start_query(task.layout.walls, task.goal_xy)
            start = self.strategy.choose_start(query, self.streams.strategy)
            if start is not None:
                task = replace(task, start_xy=start)
        obs, _ = self.env.reset(seed=reset_seed, options=task.reset_options())
        if self._rest_body is None:
            self._rest_body = np.asarray(STATE_LAYOUT.body_observation(obs["state"]), dtype=np.float64)
        gating = self.strategy.gates
        beta = 1.0 if gating else self.beta  # a gating strategy's asked steps run the expert's subgoal
        episode, cost, step, done, info = self.episodes_done, 0, 0, False, {}
        unasked: list[tuple[dict[str, np.ndarray], np.ndarray, int]] = []  # for labels after a failure
        observe_step = getattr(self.learner, "observe_step", None)  # optional: HighLevelPolicy's draws nothing
        while not done:
            # The learner's proposal is computed before the label so a person can be shown it; it is
            # deterministic and draws no randomness, so the order leaves the numbers unchanged.
            learner_subgoal = np.asarray(self.learner.predict(obs), dtype=np.float64)
            if gating:
                own = self._clip(learner_subgoal)
                # The strategy is asked first, always: it keeps every state for its threshold.
                asked = (
                    self.strategy.wants_label(obs, own, self.learner)
                    or len(self.dataset) == 0
                    or self.maze.is_no_op_subgoal(own)
                )
            else:
                asked = True
            expert_subgoal = None
            if asked:
                expert_subgoal = yield LabelRequest(obs, learner_subgoal, episode, cost, beta)  # checked by answer()
                cost += 1
                self._aggregate(obs, expert_subgoal, episode, step)
                if self.per_step_gradient_steps:
                    self._fit(self.per_step_gradient_steps)
                if gating:
                    subgoal = self._clip(expert_subgoal)
                elif self.strategy.updates_every_step:
                    # Alg. 4: the step is executed with the beta it was labelled with; the update decays the next one.
                    step_beta = self.beta
                    self._update(self.strategy.step_gradient_steps or self.gradient_steps)
                    subgoal = self._mix(expert_subgoal, learner_subgoal, step_beta)
                else:
                    subgoal = self._mix(expert_subgoal, learner_subgoal, beta)
            else:
                subgoal = own
                unasked.append((obs, learner_subgoal, step))
            before = obs
            obs, _, terminated, truncated, info = self.env.step(subgoal)
            done = terminated or truncated
            step += 1
            self.strategy.on_step(before, subgoal, info)
            if observe_step is not None:  # what the step did, for a learner that learns blocked moves from it
                observe_step(before, subgoal, info)
            executed.append(ExecutedStep(subgoal, expert_subgoal, info, done, before))
        success = bool(info["is_success"])
        # Pruning sees the labels that were executed (those that led to the failure), not the ones asked after it.
        removed = self.strategy.on_episode_end(self.dataset, episode, success, self.streams.strategy)
        if gating and self.strategy.label_failures and not success:
            for observation, proposal, at in unasked:
                label = yield LabelRequest(observation, proposal, episode, cost, beta, executes=False)
                cost += 1
                self._aggregate(observation, label, episode, at)
        self.episodes_done += 1
        self.total_expert_cost += cost
        # The update itself waits for EpisodeRun.finish() (or the next start_episode()), so a person sees the
        # episode's end at once; its draws are the learner's and the strategy's streams, not the tasks', so the
        # numbers stay the same whenever it runs.
        # A strategy that updates after every step has no episode-end update (Alg. 4).
        self._update_due = (
            not self.strategy.updates_every_step
            and self.episodes_done % self.episodes_per_update == 0
            and len(self.dataset) > 0
        )
        return EpisodeRecord(
            episode=episode,
            success=success,
            expert_cost=cost,
            attempts=int(info["attempts"]),
            low_level_steps=int(info["total_low_level_steps"]),
            beta=beta,
            dataset_size=len(self.dataset),
            removed=len(removed),
        )

    def _aggregate(
        self, observation: dict[str, np.ndarray], expert_subgoal: np.ndarray, episode: int, step: int
    ) -> None:
        # D gets the strategy's target for the label (the expert's own but for AggreVaTe).
        label = self.strategy.label_target(self.maze, observation, expert_subgoal)
        self.dataset.add(Demonstration(observation["image"], observation["state"], label, episode, step))

    def _clip(self, subgoal: np.ndarray) -> np.ndarray:
        space = self.maze.action_space
        return np.clip(subgoal, space.low, space.high)

    def _mix(self, expert_subgoal: np.ndarray, learner_subgoal: np.ndarray, beta: float) -> np.ndarray:
        if self.mixing == "switch":
            chosen = expert_subgoal if self.streams.mixing.random() < beta else learner_subgoal
        else:
            chosen = beta * expert_subgoal + (1 - beta) * learner_subgoal
        chosen = self._clip(chosen)
        if self.maze.is_no_op_subgoal(chosen):
            return self._clip(expert_subgoal)
        return chosen

    def _fit(self, steps: int) -> None:
        self.last_loss = self.learner.fit_dataset(self.dataset, steps)

    def _start_query(self, walls: np.ndarray, goal_xy: np.ndarray) -> StartQuery:
        maze = self.maze
        geometry = maze.geometry
        goal_cell = geometry.xy_to_cell(goal_xy)
        # A chosen start obeys the env's min_goal_cells as its corner start does (else a start one step
        # from the goal makes a cheap episode); the corner meets it, so some cell always does.
        steps = bfs_distances(walls, goal_cell)
        least = max(1, int(maze.min_goal_cells))
        cells = [tuple(cell) for cell in np.argwhere(steps >= least)]
        if not cells:
            cells = [tuple(cell) for cell in np.argwhere(~walls) if tuple(cell) != goal_cell]
        candidates = np.stack([geometry.cell_to_xy(cell) for cell in cells])
        return StartQuery(walls, goal_xy, candidates, self._rest_body, self.learner)
