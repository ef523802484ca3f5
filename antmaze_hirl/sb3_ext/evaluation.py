"""Success-rate evaluation of low-level policies on a fixed, seeded set of held-out subgoals."""

from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback

from antmaze_hirl.atomic_io import atomic_write_text
from antmaze_hirl.envs.controllers import as_controller
from antmaze_hirl.envs.profiles import SEEDS
from antmaze_hirl.envs.reach import ReachEnv
from antmaze_hirl.sb3_ext.loading import save_policy


def evaluate_reach(
    policy: Any,
    env: ReachEnv,
    *,
    episodes: int,
    seed: int,
) -> dict[str, float | int]:
    """Runs ``episodes`` subgoal-reaching attempts, episode ``i`` reset with seed ``seed + i``.

    An attempt succeeds when the body comes within the env's ``distance_threshold`` of the subgoal
    at any step of the horizon (the high-level env stops there too).

    Args:
        policy: SB3 model or callable goal observation -> action (acting deterministically).
        env: The reach env; its ``goal_radius`` is the largest subgoal distance tested.
        episodes: Number of attempts (>= 1).
        seed: Base seed; the same seed gives the same subgoals. Sets overlap by construction
            (``seed=1`` shares episodes 1..n-1 of ``seed=0``), so disjoint test sets need base seeds at
            least ``episodes`` apart; a prefix is a subset (100 episodes are the first 100 of 200).

    Returns:
        ``{"success_rate", "episodes", "mean_steps"}``, steps counted to first success (H on failure).

    """
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}")
    controller = as_controller(policy)
    successes, steps_used = 0, []
    for episode in range(episodes):
        obs, info = env.reset(seed=seed + episode)
        steps, done, reached = 0, False, info["is_success"]
        while not (done or reached):
            obs, _, terminated, truncated, info = env.step(controller(obs))
            steps += 1
            done, reached = terminated or truncated, info["is_success"]
        successes += int(reached)
        steps_used.append(steps if reached else env.horizon)
    return {"success_rate": successes / episodes, "episodes": episodes, "mean_steps": float(np.mean(steps_used))}


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
