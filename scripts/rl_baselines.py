"""Leaderboard rows for reward alone on ``point5`` (or ``ant4``): SB3 on the high level, and a flat SAC+HER.

Three baselines, each trained on the held-out protocol's training mazes (random mazes of the body family's
layout-partition ``train`` part only: 5x5 for the point, 4x4 for the ant with ``--body ant``; sparse reward
1 at the final goal) and scored on the family's suite (``point5`` or ``ant4``) exactly as
``antmaze-hirl benchmark SUITE`` scores any policy:

* ``ppo`` and ``sac``: SB3's ``MultiInputPolicy`` picks subgoals on the lockstep high-level vector env
  (:class:`~antmaze_hirl.envs.vector.HighLevelVectorEnv`, ``--num-envs`` mazes, ``"SameStep"`` autoreset),
  the body's shipped low level walking to each subgoal; ``clip_subgoals=True`` (Gaussian actions leave the
  maze). The episode ends at the goal or after 500 low-level steps (the suite's budget).
* ``flat-sac-her``: SB3 SAC with a ``HerReplayBuffer`` drives the body directly, every low-level step,
  with the episode's final goal as its goal (:class:`FlatMazeEnv`): no subgoals, no map in the observation
  (the body's state and the goal xy, as the low level sees). Scored on the suite as the low
  level of a high-level policy that always proposes the final goal (:class:`FinalGoalPolicy`): the
  hierarchy then only re-issues the goal every H low-level steps (the body's horizon: 50 for the point,
  100 for the ant), so the body's actions are the flat policy's (a goal nearer than twice the success
  radius at such a re-issue, 0.4 m for the point, is pushed out along the same line, which the walk
  crosses on its way; ``mean subgoals`` of that row counts re-issues).

Training stops at ``--steps`` or after ``--max-minutes`` of wall time, whichever comes first; the report
gives the steps reached (``training.steps_reached``), never the steps asked for: the steps trained on, with a
rollout cut by the cap left out (``training.steps_dropped``). ``--steps 0`` scores the untrained model (where
each curve starts; ``<suite>_<algo>_rl_s<seed>_untrained.json``). ``--score-only`` scores a saved model again
(with its training record) without training.

Long runs outlive a session. Every ``--checkpoint-every`` steps, at the next rollout start, the model (and an
off-policy model's replay buffer) is written atomically under ``--out``, with a record of the steps and the
training seconds so far; ``--resume`` continues from the last one after a stop or a ``kill -9``. A fresh run
refuses a checkpoint folder that holds files (pass ``--resume``, or remove it), and ``--resume`` on a run
already at ``--steps`` trains nothing and leaves its record as it was. A resumed run is not bit-identical to
an unbroken one (the envs are reseeded, and a rollout cut by a kill is collected again), and its record lists
the steps it resumed at. ``--score-checkpoints`` scores every checkpoint short of the final model as
``<suite>_<algo>_rl_s<seed>_at_<steps>.json``: the points of the learning curve. ``--tensorboard DIR`` logs
SB3's training curves (episode reward and length, losses) there; a resumed run continues the same log.

Usage: python scripts/rl_baselines.py --algo ppo|sac|flat-sac-her [--body point|ant] [--steps N]
       [--max-minutes 20] [--num-envs 8] [--seed 0] [--score-num-envs 8] [--checkpoint-every 25000] [--resume]
       [--score-only] [--score-checkpoints] [--tensorboard DIR]
Writes the model and its training record under --out, and results/leaderboard/<suite>_<algo>_rl_s<seed>.json.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3 import PPO, SAC, HerReplayBuffer
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import DummyVecEnv

from antmaze_hirl.atomic_io import atomic_write_json, atomic_write_with
from antmaze_hirl.envs.state_layout import STATE_LAYOUT
from antmaze_hirl.envs.suite_specs import SUITE_SPECS
from antmaze_hirl.sb3_ext.shipped import make_maze_env, make_maze_vector_env
from antmaze_hirl.sb3_ext.vec_env import GymnasiumVecEnv

RESULTS = Path(__file__).resolve().parents[1] / "results" / "leaderboard"
SUITES = {
    body: next(spec.name for spec in SUITE_SPECS.values() if spec.body == body and spec.source == "random")
    for body in ("point", "ant")
}
"""Each body's suite: its random family, whose ``train`` part the baselines train on (``point5``, ``ant4``)."""
FLAT_STEPS = SUITE_SPECS["point5"].max_low_level_steps
assert all(SUITE_SPECS[suite].max_low_level_steps == FLAT_STEPS for suite in SUITES.values())  # one budget: 500
SETTINGS: dict[str, dict[str, Any]] = {
    # Rollouts of 256 high-level steps per maze, so every update sees whole episodes of 8 mazes.
    "ppo": {"n_steps": 256, "batch_size": 64, "n_epochs": 4},
    # One gradient step per transition (SAC's usual ratio), over the vector env's N transitions per step.
    "sac": {"buffer_size": 50_000, "learning_starts": 200, "batch_size": 64, "gradient_steps": -1},
    # HER as SB3's docs set it up; learning starts after two whole (500-step) episodes.
    "flat-sac-her": {
        "buffer_size": 300_000,
        "learning_starts": 2 * FLAT_STEPS,
        "batch_size": 256,
        "replay_buffer_class": "HerReplayBuffer",
        "replay_buffer_kwargs": {"n_sampled_goal": 4, "goal_selection_strategy": "future"},
    },
}


class WallClockCap(BaseCallback):
    """Stops ``learn`` once ``seconds`` of wall time have passed (checked after every env step)."""

    def __init__(self, seconds: float) -> None:
        super().__init__()
        self.seconds = seconds
        self.started = time.perf_counter()
        self.capped = False

    def _on_step(self) -> bool:
        self.capped = time.perf_counter() - self.started >= self.seconds
        return not self.capped


UNRECORDED_RUN = "not recorded: this checkpoint was written before checkpoints recorded their run's command"
"""``command_note`` of a report on a checkpoint that predates per-checkpoint commands."""


class StaleCheckpoints(RuntimeError):
    """A fresh run's checkpoint folder already holds another run's checkpoints."""


class Checkpoints(BaseCallback):
    """Writes the model every ``every`` steps as ``<folder>/<steps>.zip`` with ``<steps>.json``, its record.

    A checkpoint is taken when a rollout starts (SB3's ``on_rollout_start``), once ``every`` steps have passed
    since the last: there the model has had every update due for the steps counted (none before
    ``learning_starts``) and an off-policy buffer holds every transition counted (the last ``buffer_size`` once
    it is full), so ``<steps>`` is the steps trained on, for PPO (whose rollouts are
    ``n_steps`` x mazes long, so its checkpoints fall on whole rollouts) and SAC alike. :attr:`trained_steps` is
    the count at the last rollout start, what a run cut mid-rollout has trained on.

    The record holds the steps and the training seconds so far (``seconds_before`` plus this run's) and
    ``run``, the command and wall-time cap of the run that wrote it (a checkpoint scored by a later run is
    reported with the run that trained it, :func:`score_checkpoints`); an
    off-policy model's replay buffer is written first, as ``<folder>/replay_buffer_<steps>.pkl``, and
    ``latest.json`` names the model and its buffer last, so a run killed at any point resumes from a model
    and the buffer saved with it.
    """

    def __init__(
        self, folder: Path, every: int, seconds_before: float, resumed_at: list[int], run: dict[str, Any]
    ) -> None:
        super().__init__()
        self.folder = folder
        self.run = run
        self.every = every
        self.seconds_before = seconds_before
        self.resumed_at = resumed_at
        self.started = time.perf_counter()
        self.next_steps = every
        self.trained_steps = 0

    def _on_training_start(self) -> None:
        self.next_steps = (self.model.num_timesteps // self.every + 1) * self.every
        self.trained_steps = int(self.model.num_timesteps)

    def _on_rollout_start(self) -> None:
        self.trained_steps = int(self.model.num_timesteps)
        if self.trained_steps >= self.next_steps:
            self.save()
            self.next_steps = (self.trained_steps // self.every + 1) * self.every

    def _on_step(self) -> bool:
        return True

    def seconds(self) -> float:
        """Training seconds so far, over every run of this model."""
        return self.seconds_before + time.perf_counter() - self.started

    def save(self) -> dict[str, Any]:
        """Writes one checkpoint now and returns its record."""
        steps = int(self.model.num_timesteps)
        latest: dict[str, Any] = {"model": f"{steps}.zip"}
        if getattr(self.model, "replay_buffer", None) is not None:
            # One buffer per checkpoint, named in latest.json: a kill between the writes never pairs a model
            # with a newer buffer. The older buffers (about 1 GB each for SAC) go once latest.json names this one.
            latest["replay_buffer"] = f"replay_buffer_{steps}.pkl"
            atomic_write_with(self.folder / latest["replay_buffer"], self.model.save_replay_buffer)
        atomic_write_with(self.folder / f"{steps}.zip", self.model.save)
        record = {
            "steps": steps,
            "training_seconds": round(self.seconds(), 1),
            "resumed_at": self.resumed_at,
            **self.run,
        }
        atomic_write_json(self.folder / f"{steps}.json", record)
        atomic_write_json(self.folder / "latest.json", {**record, **latest})
        for old in self.folder.glob("replay_buffer*.pkl"):
            if old.name != latest.get("replay_buffer"):
                old.unlink()
        return record


def checkpoint_folder(model_path: Path) -> Path:
    """Where a model's checkpoints live: beside it, ``<model stem>_checkpoints/``."""
    return model_path.with_name(f"{model_path.stem}_checkpoints")


def family_size(body: str) -> int:
    """Free cells per side of the body's suite family (5 for the point, 4 for the ant): the training mazes' size."""
    return SUITE_SPECS[SUITES[body]].maze_size


def _no_low_level(observation: dict[str, np.ndarray]) -> np.ndarray:
    raise RuntimeError("FlatMazeEnv drives the body itself; its high-level env never walks")


class FlatMazeEnv(gym.Env):
    """The body in a random ``train``-part maze of its family, goal-conditioned on the final goal (a GoalEnv).

    Each reset draws a task as the high-level training env does (start corner, goal >= 3 grid steps away,
    +-0.25 cell of noise) and the body then acts every step for up to 500 steps; the episode ends at the goal
    (within the body's reach radius) or when the ant flips, or is truncated. Observation and reward are
    :class:`~antmaze_hirl.envs.reach.ReachEnv`'s.
    """

    def __init__(self, body: str = "point") -> None:
        self.high = make_maze_env(
            body,
            low_level=_no_low_level,
            split="train",
            horizon=FLAT_STEPS,
            maze_size=family_size(body),
            terminate_on_flip=True,  # step() ends the episode on the reach env's flip termination
        )
        self.reach = self.high.reach
        self.observation_space = self.reach.observation_space
        self.action_space = self.reach.action_space

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[dict, dict]:
        """A new task, drawn with ``np_random``."""
        super().reset(seed=seed)
        self.high.reset(seed=int(self.np_random.integers(2**31)))
        return self.reach._get_obs(), {"is_success": False}

    def step(self, action: np.ndarray) -> tuple[dict, float, bool, bool, dict]:
        """One body step; terminated at the goal or when the ant flips (a failure), truncated after 500 steps."""
        # The reach env terminates on a flip (the high-level env's terminate_on_flip, on by default): a flipped
        # ant ends its episode as it does in the hierarchy, not after 500 steps on its back.
        obs, reward, flipped, truncated, info = self.reach.step(action)
        return obs, reward, bool(info["is_success"]) or bool(flipped), truncated, info

    def compute_reward(self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any) -> np.ndarray:
        """The reach env's sparse reward (HER relabels with it)."""
        return self.reach.compute_reward(achieved_goal, desired_goal, info)

    def close(self) -> None:
        """Frees the simulator."""
        self.high.close()


class FinalGoalPolicy:
    """A high-level policy whose subgoal is always the final goal (the flat baseline's scoring policy)."""

    __name__ = "final goal as the only subgoal"

    def __call__(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """The goal xy of the high-level state."""
        return STATE_LAYOUT.goal_xy(np.asarray(observation["state"]))


def high_level_vec_env(num_envs: int, body: str = "point") -> GymnasiumVecEnv:
    """``num_envs`` ``train``-part mazes in lockstep behind the body's shipped low level, as an SB3 VecEnv."""
    venv = make_maze_vector_env(
        num_envs, body, split="train", autoreset_mode="SameStep", clip_subgoals=True, maze_size=family_size(body)
    )
    return GymnasiumVecEnv(venv)


def training_env(algo: str, num_envs: int, body: str = "point") -> Any:
    """The SB3 VecEnv ``algo`` trains on."""
    if algo == "flat-sac-her":
        return DummyVecEnv([lambda: FlatMazeEnv(body)])
    return high_level_vec_env(num_envs, body)


def make_model(algo: str, num_envs: int, seed: int, tensorboard_log: str | None = None, body: str = "point") -> Any:
    """The untrained SB3 model of ``algo`` on its training env (logging to TensorBoard under ``tensorboard_log``)."""
    settings = dict(SETTINGS[algo])
    if algo == "flat-sac-her":
        settings["replay_buffer_class"] = HerReplayBuffer
    algorithm = PPO if algo == "ppo" else SAC
    env = training_env(algo, num_envs, body)
    return algorithm("MultiInputPolicy", env, seed=seed, device="cpu", tensorboard_log=tensorboard_log, **settings)


def resume_model(args: argparse.Namespace, folder: Path) -> tuple[Any, dict[str, Any]]:
    """The model of the last checkpoint in ``folder`` (with its replay buffer) on a fresh env, and its record."""
    latest = json.loads((folder / "latest.json").read_text())
    algorithm = PPO if args.algo == "ppo" else SAC
    env = training_env(args.algo, args.num_envs, args.body)
    # The seed is offset by the steps so far: the resumed envs draw other mazes than the first run's start.
    model = algorithm.load(
        folder / latest["model"],
        env=env,
        device="cpu",
        seed=args.seed + latest["steps"],
        tensorboard_log=getattr(args, "tensorboard", None),
    )
    if args.algo != "ppo":
        # Checkpoints from before per-checkpoint buffers name none: theirs is replay_buffer.pkl. A HER buffer's
        # unfinished episode is truncated on load (SB3's default, with a warning): the resumed env starts anew.
        model.load_replay_buffer(folder / latest.get("replay_buffer", "replay_buffer.pkl"))
    return model, latest


def refuse_stale_checkpoints(folder: Path, resume: bool) -> None:
    """Raises :class:`StaleCheckpoints` if a fresh run would write into ``folder`` over another run's files.

    A fresh run (no ``--resume``, or ``--resume`` with no ``latest.json`` to resume from) must start from an
    empty folder: otherwise ``--score-checkpoints`` would score the old run's checkpoints as this run's, and a
    later ``--resume`` after a kill before this run's first checkpoint would continue the old run.
    """
    if resume and (folder / "latest.json").is_file():
        return
    leftovers = sorted(path.name for path in folder.glob("*")) if folder.is_dir() else []
    if leftovers:
        raise StaleCheckpoints(
            f"{folder} holds another run's checkpoints ({', '.join(leftovers[:3])}{', ...' * (len(leftovers) > 3)}): "
            f"pass --resume to continue it{' (it has no latest.json)' * resume}, or remove the folder"
        )


def train(args: argparse.Namespace, model_path: Path, record_path: Path) -> dict[str, Any]:
    """Trains (or resumes with ``args.resume``), saves the model, and writes (and returns) the training record.

    With ``args.resume`` on a run whose last checkpoint is at or past ``args.steps`` and whose record exists,
    nothing is trained or written: the stored record is returned as it is (its command, cap and stop reason
    are the run's, not this call's). On a run killed after its last checkpoint but before its record, nothing
    is trained either: the model and record are written now, naming the killed run's command and cap.

    Raises:
        StaleCheckpoints: If a fresh run's checkpoint folder holds files (:func:`refuse_stale_checkpoints`).
    """
    folder = checkpoint_folder(model_path)
    refuse_stale_checkpoints(folder, getattr(args, "resume", False))
    resume = getattr(args, "resume", False) and (folder / "latest.json").is_file()
    if resume and record_path.is_file() and model_path.is_file():
        steps = json.loads((folder / "latest.json").read_text())["steps"]
        if steps >= args.steps:
            print(f"already trained to {steps} steps, at or past --steps {args.steps}: not training")
            return json.loads(record_path.read_text())
    if resume:
        model, latest = resume_model(args, folder)
        seconds_before, resumed_at = latest["training_seconds"], list(latest["resumed_at"])
    else:
        model = make_model(args.algo, args.num_envs, args.seed, getattr(args, "tensorboard", None), args.body)
        seconds_before, resumed_at = 0.0, []
    remaining = args.steps - model.num_timesteps
    if resume and remaining > 0:
        print(f"resuming at {latest['steps']} steps ({latest['training_seconds']} s of training so far)")
        resumed_at.append(latest["steps"])
    elif resume:  # killed after its last checkpoint, before its record: the record is written now
        print(f"trained to {latest['steps']} steps, at or past --steps {args.steps}; writing its record")
    cap = WallClockCap(60 * args.max_minutes)
    run = {"max_minutes": args.max_minutes, "command": args.command}
    if resume and remaining <= 0 and "command" in latest:
        # Nothing is trained now: the model is the killed run's, so its record names that run, not this call.
        run = {"max_minutes": latest["max_minutes"], "command": latest["command"]}
    checkpoints = Checkpoints(folder, getattr(args, "checkpoint_every", 25_000), seconds_before, resumed_at, run)
    dropped = 0
    if remaining > 0:  # --steps 0: the untrained model, where a learning curve starts
        # reset_num_timesteps=False: SB3 then counts `remaining` on from the checkpoint's steps.
        model.learn(
            total_timesteps=remaining, callback=[cap, checkpoints], progress_bar=False, reset_num_timesteps=not resume
        )
        if cap.capped:
            # The cap cut a rollout: its steps were neither trained on (PPO) nor stored (SAC's last vector
            # step), so they are not counted. A resume collects them again.
            dropped = int(model.num_timesteps) - checkpoints.trained_steps
            model.num_timesteps = checkpoints.trained_steps
        # Where a --resume continues, even when the cap stopped it between checkpoints; its seconds are the
        # record's, so a later resume and this record agree.
        seconds = checkpoints.save()["training_seconds"]
    else:
        seconds = seconds_before
    model_path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_with(model_path, model.save)
    model.get_env().close()
    step_kind = "low-level steps (body actions)" if args.algo == "flat-sac-her" else "high-level steps (subgoals)"
    record = {
        "algorithm": args.algo,
        "settings": SETTINGS[args.algo],
        "steps_asked": args.steps,
        "steps_reached": int(model.num_timesteps),
        "steps_dropped": dropped,
        "step_kind": step_kind,
        "stopped_by": "wall-time cap" if cap.capped else "step budget" if args.steps else "untrained (--steps 0)",
        "num_envs": 1 if args.algo == "flat-sac-her" else args.num_envs,
        "body": args.body,
        "training_split": "train",
        "training_seconds": round(seconds, 1),
        "resumed_at": resumed_at,
        "seed": args.seed,
        **run,
    }
    atomic_write_json(record_path, record)
    return record


def report_name(body: str, algo: str, seed: int, steps: int, suffix: str = "") -> str:
    """A report's file name: ``<suite>_<algo>_rl_s<seed>[_untrained]<suffix>.json`` (``-`` in ``algo`` as ``_``)."""
    untrained = "_untrained" if steps == 0 else ""
    return f"{SUITES[body]}_{algo.replace('-', '_')}_rl_s{seed}{untrained}{suffix}.json"


def score(args: argparse.Namespace, model_path: Path, record: dict[str, Any], *, suffix: str = "") -> dict[str, Any]:
    """Scores the saved model on the body's suite and writes the leaderboard's results file (name ending ``suffix``)."""
    # Imported here, after training: the scorer is read as it stands when scoring starts.
    from antmaze_hirl.experiments.benchmark import score_policy

    scoring: dict[str, Any] = {"num_envs": args.score_num_envs}
    if args.algo == "flat-sac-her":
        low_level = SAC.load(
            model_path,
            device="cpu",
            custom_objects={"replay_buffer_class": None, "replay_buffer_kwargs": {}, "buffer_size": 1},
        )
        report = score_policy(SUITES[args.body], FinalGoalPolicy(), low_level=low_level, **scoring)
        what = f"flat SAC+HER (no hierarchy), {record['steps_reached']:,} body steps"
    else:
        report = score_policy(SUITES[args.body], str(model_path), **scoring)
        what = f"SB3 {args.algo.upper()} on the high level, {record['steps_reached']:,} high-level steps"
    report["policy"] = f"{what}, seed {args.seed}"
    report["training"] = record
    out = RESULTS / report_name(args.body, args.algo, args.seed, record["steps_reached"], suffix)
    atomic_write_json(out, report)
    low, high = report["wilson_95"]
    print(f"{report['policy']}: {report['successes']}/{report['episodes']} [{low:.1%}, {high:.1%}] -> {out}")
    return report


def score_checkpoints(args: argparse.Namespace, model_path: Path, record: dict[str, Any]) -> None:
    """Scores each checkpoint short of the final model (``record``'s steps) as ``..._rl_s<seed>_at_<steps>.json``.

    A checkpoint's report carries the command and cap of the run that wrote the checkpoint, which may be an
    earlier run than ``record``'s. A checkpoint written before checkpoints recorded them takes ``record``'s
    where that run wrote it (past the step it resumed at), and otherwise says it is not recorded
    (``"command": null`` with ``command_note``) rather than borrow another run's.
    """
    folder = checkpoint_folder(model_path)
    steps = sorted(int(path.stem) for path in folder.glob("*.zip") if path.stem.isdigit())
    final_run_from = max(record["resumed_at"], default=0)  # the step the final model's run started at
    for step in (step for step in steps if step < record["steps_reached"]):
        checkpoint = json.loads((folder / f"{step}.json").read_text())
        if "command" not in checkpoint and step <= final_run_from:
            checkpoint |= {"command": None, "max_minutes": None, "command_note": UNRECORDED_RUN}
        # A checkpoint falls on a rollout start, so no rollout was cut from its count, whatever the final run's.
        at = {**record, **checkpoint, "steps_reached": step, "steps_dropped": 0}
        at["stopped_by"] = f"checkpoint of {model_path.name}"
        del at["steps"]
        score(args, folder / f"{step}.zip", at, suffix=f"_at_{step}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--algo", choices=sorted(SETTINGS), required=True)
    parser.add_argument(
        "--body", choices=sorted(SUITES), default="point", help="the body; its family's suite is scored"
    )
    parser.add_argument(
        "--steps", type=int, default=200_000, help="step budget (high-level steps, or body steps); 0: untrained"
    )
    parser.add_argument("--max-minutes", type=float, default=20.0, help="wall-time cap on training")
    parser.add_argument("--num-envs", type=int, default=8, help="lockstep mazes for ppo/sac training")
    parser.add_argument("--score-num-envs", type=int, default=8, help="lockstep mazes for scoring")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path("runs/rl_baselines"), help="folder for models")
    parser.add_argument("--score-only", action="store_true", help="score the saved model again; no training")
    parser.add_argument("--checkpoint-every", type=int, default=25_000, help="steps between checkpoints")
    parser.add_argument("--tensorboard", help="folder for TensorBoard logs (SB3's tensorboard_log); none by default")
    parser.add_argument("--resume", action="store_true", help="continue from the last checkpoint, if there is one")
    parser.add_argument(
        "--score-checkpoints", action="store_true", help="also score every checkpoint short of the final model"
    )
    args = parser.parse_args(argv)
    # The record names the call that trained: main's argv when given, so a caller's run is not named sys.argv.
    args.command = shlex.join(["python", "scripts/rl_baselines.py", *(sys.argv[1:] if argv is None else argv)])
    if args.steps < 0 or args.num_envs < 1 or args.score_num_envs < 1 or not args.max_minutes > 0:
        parser.error(f"--steps must be >= 0, --num-envs and --score-num-envs >= 1 and --max-minutes > 0, got {args}")
    if args.checkpoint_every < 1:
        parser.error(f"--checkpoint-every must be >= 1, got {args.checkpoint_every}")
    torch.set_num_threads(1)
    model_path = (
        args.out / f"{SUITES[args.body]}_{args.algo}_seed{args.seed}{'_untrained' if args.steps == 0 else ''}.zip"
    )
    record_path = model_path.with_suffix(".training.json")
    if args.score_only:
        record = json.loads(record_path.read_text())
    else:
        try:
            record = train(args, model_path, record_path)
        except StaleCheckpoints as error:
            parser.error(str(error))
        print(f"trained {record['steps_reached']} steps in {record['training_seconds']} s ({record['stopped_by']})")
    score(args, model_path, record)
    if args.score_checkpoints:
        score_checkpoints(args, model_path, record)
    return 0


if __name__ == "__main__":
    sys.exit(main())
