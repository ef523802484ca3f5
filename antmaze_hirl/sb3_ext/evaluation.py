"""Success-rate evaluation of low-level policies on a fixed, seeded set of held-out subgoals."""

from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback

from antmaze_hirl.atomic_io import atomic_write_text
from antmaze_hirl.envs.controllers import as_batch_controller, as_controller
from antmaze_hirl.envs.profiles import SEEDS
from antmaze_hirl.envs.reach import ReachEnv
from antmaze_hirl.envs.vector import check_episodes_and_num_envs
from antmaze_hirl.sb3_ext.loading import save_policy


def evaluate_reach(
    policy: Any,
    env: ReachEnv,
    *,
    episodes: int,
    seed: int,
    num_envs: int = 1,
) -> dict[str, float | int]:
    """Runs ``episodes`` subgoal-reaching attempts, episode ``i`` reset with seed ``seed + i``.

    An attempt succeeds when the body comes within the env's ``success_radius_m`` of the subgoal
    at any step of the horizon (the high-level env stops there too).

    Args:
        policy: SB3 model or callable goal observation -> action (acting deterministically).
        env: The reach env; its ``sample_radius_m`` is the largest subgoal distance tested.
        episodes: Number of attempts (>= 1).
        seed: Base seed; the same seed gives the same subgoals. Sets overlap by construction
            (``seed=1`` shares episodes 1..n-1 of ``seed=0``), so disjoint test sets need base seeds at
            least ``episodes`` apart; a prefix is a subset (100 episodes are the first 100 of 200).
        num_envs: ``1`` plays the attempts one after another on ``env`` (exact replays of committed
            results). More plays up to that many at once on copies of ``env``, the policy acting for all of
            them in one batch per step (:func:`~antmaze_hirl.envs.controllers.as_batch_controller`): the
            same subgoals and seeds, but a batched forward pass may round the last bits differently, which
            the simulator can turn into another outcome now and then.

    Returns:
        ``{"success_rate", "episodes", "mean_steps"}``, steps counted to first success (H on failure).

    Raises:
        ValueError: If ``episodes`` or ``num_envs`` is below 1.
    """
    steps_used = reach_outcomes(policy, env, episodes=episodes, seed=seed, num_envs=num_envs)
    successes = sum(steps is not None for steps in steps_used)
    mean_steps = float(np.mean([env.horizon if steps is None else steps for steps in steps_used]))
    return {"success_rate": successes / episodes, "episodes": episodes, "mean_steps": mean_steps}


def reach_outcomes(policy: Any, env: ReachEnv, *, episodes: int, seed: int, num_envs: int = 1) -> list[int | None]:
    """Each attempt of :func:`evaluate_reach` (same arguments): its steps to the first success, ``None`` on failure.

    Raises:
        ValueError: If ``episodes`` or ``num_envs`` is below 1.
    """
    num_envs = check_episodes_and_num_envs(episodes, num_envs)
    if num_envs == 1:
        controller = as_controller(policy)
        return [_reach_once(env, controller, seed + episode) for episode in range(episodes)]
    return _reach_in_lockstep(policy, env, range(seed, seed + episodes), min(num_envs, episodes))


def _reach_once(env: ReachEnv, controller: Any, seed: int) -> int | None:
    # Steps to the first success, or None on failure.
    obs, info = env.reset(seed=seed)
    steps, done, reached = 0, False, info["is_success"]
    while not (done or reached):
        obs, _, terminated, truncated, info = env.step(controller(obs))
        steps += 1
        done, reached = terminated or truncated, info["is_success"]
    return steps if reached else None


def _reach_in_lockstep(policy: Any, env: ReachEnv, seeds: range, num_envs: int) -> list[int | None]:
    # The attempts of _reach_once, num_envs at a time on copies of env: one batched action per step.
    inner = env.unwrapped  # a gym.make env's wrappers carry no constructor arguments; the ReachEnv does
    envs = [type(inner)(*inner._ezpickle_args, **inner._ezpickle_kwargs) for _ in range(num_envs)]
    low_level = as_batch_controller(policy, num_envs)
    results: dict[int, int | None] = {}
    playing: dict[int, tuple[int, int]] = {}  # sub-env -> (seed, steps so far)
    observations: dict[int, dict[str, np.ndarray]] = {}
    queued = iter(seeds)

    def start_next(index: int) -> None:
        for seed in queued:
            observations[index], info = envs[index].reset(seed=seed)
            low_level.reset(index)
            if not info["is_success"]:
                playing[index] = (seed, 0)
                return
            results[seed] = 0  # reached at its reset: no step taken, as in _reach_once

    try:
        for index in range(num_envs):
            start_next(index)
        while playing:
            indices = sorted(playing)
            batch = {key: np.stack([observations[i][key] for i in indices]) for key in observations[indices[0]]}
            actions = low_level(batch, np.asarray(indices))
            for index, action in zip(indices, actions, strict=True):
                seed, steps = playing[index]
                observations[index], _, terminated, truncated, info = envs[index].step(action)
                playing[index] = (seed, steps + 1)
                if info["is_success"] or terminated or truncated:
                    results[seed] = steps + 1 if info["is_success"] else None
                    del playing[index]
                    start_next(index)
    finally:
        for sub_env in envs:
            sub_env.close()
    return [results[seed] for seed in seeds]


def snapshot_step(path: Path) -> int | None:
    """The training step of a ``snapshots/step_<n>.zip`` policy, or ``None`` for any other file."""
    step = path.stem.removeprefix("step_")
    return int(step) if path.suffix == ".zip" and path.stem.startswith("step_") and step.isdigit() else None


CURVE_COLUMNS = ["timesteps", "success_rate", "episodes", "mean_steps"]


def _csv_text(rows: list[dict[str, Any]]) -> str:
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=CURVE_COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return buffer.getvalue()


class SuccessRateCallback(BaseCallback):
    """Every ``eval_freq`` steps, logs ``eval/success_rate`` on held-out subgoals and appends a CSV row.

    Args:
        eval_env: A separate reach env (its own simulator) to evaluate on.
        eval_freq: Environment steps between evaluations.
        episodes: Attempts per evaluation.
        seed: Base seed of the held-out subgoals (the same set at every evaluation).
        csv_path: Learning-curve file (``timesteps,success_rate,episodes,mean_steps``), appended across resumes.
        snapshot_dir: If set, the policy evaluated at step ``n`` is also saved as ``snapshot_dir/step_<n>.zip``
            (model only, like ``policy.zip``): TD3's success rate swings between evaluations, so the best
            point of a run is picked afterwards, on another seed than the one it is reported on.

    """

    def __init__(
        self,
        eval_env: ReachEnv,
        *,
        eval_freq: int,
        episodes: int,
        seed: int = SEEDS.low_level_curve,
        csv_path: str | Path | None = None,
        snapshot_dir: str | Path | None = None,
        verbose: int = 0,
    ) -> None:
        super().__init__(verbose)
        for name, value in (("eval_freq", eval_freq), ("episodes", episodes)):
            if value < 1:
                raise ValueError(f"{name} must be >= 1, got {value}")
        self.eval_env = eval_env
        self.eval_freq = eval_freq
        self.episodes = episodes
        self.seed = seed
        self.csv_path = Path(csv_path) if csv_path is not None else None
        self.snapshot_dir = Path(snapshot_dir) if snapshot_dir is not None else None
        self._last_eval = 0

    def _init_callback(self) -> None:
        self._last_eval = self.model.num_timesteps
        if self.snapshot_dir is not None:
            # A resumed run retrains the steps after its checkpoint: later snapshots are of abandoned policies.
            for stale in self.snapshot_dir.glob("step_*.zip"):
                step = snapshot_step(stale)
                if step is not None and step > self._last_eval:  # other files there are the user's
                    stale.unlink()
        if self.csv_path is not None and self.csv_path.exists():
            # A resumed run repeats the steps after its checkpoint: drop the rows it will write again.
            with self.csv_path.open() as handle:
                rows = [row for row in csv.DictReader(handle) if int(row["timesteps"]) <= self._last_eval]
            atomic_write_text(self.csv_path, _csv_text(rows))

    def _on_step(self) -> bool:
        if self.model.num_timesteps - self._last_eval >= self.eval_freq:
            self.evaluate()
        return True

    def evaluate(self) -> dict[str, float | int]:
        """Evaluates now, logs and records the result."""
        self._last_eval = self.model.num_timesteps
        result = evaluate_reach(self.model, self.eval_env, episodes=self.episodes, seed=self.seed)
        row = {"timesteps": self.model.num_timesteps, **result}
        self.logger.record("eval/success_rate", result["success_rate"])
        self.logger.record("eval/mean_steps", result["mean_steps"])
        # Written now, at this step (as SB3's EvalCallback does): otherwise the values wait for the next
        # episode-end dump, which labels them with a later step and never comes after the last evaluation.
        self.logger.record("time/total_timesteps", row["timesteps"], exclude="tensorboard")
        self.logger.dump(row["timesteps"])
        if self.csv_path is not None:
            previous = self.csv_path.read_text() if self.csv_path.exists() else _csv_text([])
            atomic_write_text(self.csv_path, previous + _csv_text([row]).split("\n", 1)[1])
        if self.snapshot_dir is not None:
            save_policy(self.model, self.snapshot_dir / f"step_{self.model.num_timesteps}.zip")
        if self.verbose:
            print(f"eval at {row['timesteps']}: success_rate={result['success_rate']:.3f}")
        return row
