"""What comes before a flip, step by step: per-step records of the oracle's walks, and their summary.

``record`` lets the scripted oracle (2 m subgoals) drive an ant low level through ``--episodes`` mazes of a
family (default ``select6``: 6x6 layouts of the ``selection`` part of the layout partition, step limits scaled to
the path, via ``antmaze_lab.in_maze_protocol.family_env``), ``--num-envs`` at once in lockstep, the low level
through its numpy path (optionally inside :class:`~antmaze_hirl.envs.controllers.TiltDampedController`,
``--tilt-damping U,L,K``). Every low-level step is one row of an ``.npz``: episode seed, step, subgoal count and
steps since the subgoal was set, subgoal offset, uprightness, torso height, linear and angular velocity, the
8 actions (clipped to [-1, 1]), leg-wall contacts (MuJoCo's contact list), torso-to-wall distance (the wall
grid's boxes), torso quaternion and the walk's flip flag; with each episode's outcome.

``summarise`` reads such records and writes, per run, the flips and their *onset* (the last step with
uprightness >= 0.9 before the flip): onset to flip, onsets within 20 steps after a leg-wall contact, the onset
hazard after a contact and otherwise, by torso-to-wall distance, and the actions, speed and heading in the
20 steps before the onset against non-flip windows; and paired comparisons of runs on the same mazes (exact
conditional test of equal flip rates, McNemar on successes), ``--compare NAME:BASE`` and pooled
``--pool LABEL=A+B:C+D``.

Usage: python -m antmaze_lab.flip_precursors record --out RUN.npz [--low-level ZIP|ensemble] [--episodes 600]
           [--seed 3000000] [--num-envs 25] [--family select6] [--clearance-m M] [--tilt-damping U,L,K]
       python -m antmaze_lab.flip_precursors summarise NAME=RUN.npz... --out FILE.json [--describe NAME=TEXT]
           [--compare NAME:BASE] [--pool LABEL=A+B:C+D]
Records are large (~160 bytes a step, 34 MB for 600 select6 mazes): keep them out of the repository.
``results/steady_ant/flip_precursors_select6.json`` (session 29) was summarised from five such records.
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

import mujoco
import numpy as np
import torch
from scipy.stats import binomtest

from antmaze_hirl.atomic_io import atomic_write_json, atomic_write_with
from antmaze_hirl.envs.controllers import TiltDampedController
from antmaze_hirl.experiments.config import BODY_DEFAULTS
from antmaze_hirl.experts import PathOracle
from antmaze_hirl.sb3_ext.numpy_actor import NumpyActor
from antmaze_lab.commands import recorded_command
from antmaze_lab.flip_warning import flip_lead
from antmaze_lab.in_maze_protocol import MazeEpisodeRecorder, family_env, play_episodes_lockstep, worker_low_level
from antmaze_lab.tables import lab_parser, refuse_below_one

COLUMNS = (
    "ep t nsub since offx offy up z vx vy vz wx wy wz a0 a1 a2 a3 a4 a5 a6 a7 wallc walld qw qx qy qz fell".split()
)
"""The columns of a record's ``rows``, one row per low-level step (see the module docstring)."""

ONSET_UPRIGHTNESS = 0.9
"""A flip's onset is its last step at or above this uprightness."""
CONTACT_WINDOW_STEPS = 20
"""A step counts as *after a wall contact* if a leg touched a wall in the this many steps before it."""
CONTROL_STRIDE_STEPS = 10
"""Non-flip episodes give a 20-step control window every this many steps."""
WALL_BINS_M = ((0, 1.0), (1.0, 1.25), (1.25, 1.5), (1.5, 99))
"""Torso-to-wall distance bins of the onset hazard."""
DIP_THRESHOLDS = (0.8, 0.7, 0.6)
"""Uprightness levels whose down-crossings are counted in non-flip episodes."""
PROBE_SETTINGS = {"family": "select6", "num_envs": 25, "oracle_subgoal_reach_m": 2.0}
"""What a record without ``settings`` (written by session 29's probe script before this module) was made with."""


def wall_boxes(env: Any) -> np.ndarray:
    """The maze's wall cells as axis-aligned boxes ``(x_lo, y_lo, x_hi, y_hi)`` in metres, one row each."""
    geometry = env.geometry
    boxes = []
    for row, column in zip(*np.nonzero(env.layout.walls), strict=True):
        centre = geometry.cell_to_xy((row, column))
        boxes.append(np.r_[centre - geometry.scale / 2, centre + geometry.scale / 2])
    return np.array(boxes)


def wall_distance_m(xy: np.ndarray, boxes: np.ndarray) -> float:
    """Distance from the point ``xy`` to the nearest box of :func:`wall_boxes` (0 inside one)."""
    gap = np.maximum(np.maximum(boxes[:, :2] - xy, xy - boxes[:, 2:]), 0.0)
    return float(np.sqrt((gap**2).sum(1)).min())


def wall_contacts(sim: Any, floor: int) -> int:
    """Contacts between a wall (a world-body geom other than the ``floor`` geom) and a non-wall geom."""
    data, model = sim.data, sim._mujoco_env.model
    count = data.ncon
    if count == 0:
        return 0
    first, second = data.contact.geom1[:count], data.contact.geom2[:count]
    wall_first = (model.geom_bodyid[first] == 0) & (first != floor)
    wall_second = (model.geom_bodyid[second] == 0) & (second != floor)
    return int(np.sum(wall_first ^ wall_second))


class StepRecorder:
    """Records every low-level step of episodes played on recorder-wrapped envs (one row of :data:`COLUMNS` each).

    It hooks each env's ``begin_episode`` (the lockstep player calls it after every reset, in the order of the
    seeds: the k-th call starts the k-th seed's episode) and its unwrapped env's ``advance_subgoal``.

    Args:
        recorders: The envs, as :func:`~antmaze_lab.in_maze_protocol.play_episodes_lockstep` gets them.
        seeds: The episodes' seeds, in the order they are played.
    """

    def __init__(self, recorders: Sequence[MazeEpisodeRecorder], seeds: Sequence[int]) -> None:
        self.rows: list[tuple[float, ...]] = []
        self._seeds = iter(seeds)
        self._episodes: dict[int, dict[str, Any]] = {}
        self._floor: int | None = None
        for index, recorder in enumerate(recorders):
            self._hook(index, recorder)

    def _hook(self, index: int, recorder: MazeEpisodeRecorder) -> None:
        env = recorder.unwrapped
        begin, advance = recorder.begin_episode, env.advance_subgoal

        def begin_episode() -> None:
            begin()
            if self._floor is None:
                model = env.reach.sim._mujoco_env.model
                self._floor = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "floor")
            self._episodes[index] = {"seed": next(self._seeds), "t": 0, "subgoals": 0, "since": 0, "walk": None}
            self._episodes[index]["boxes"] = wall_boxes(env)

        def advance_subgoal(walk: Any, action: Any) -> Any:
            result = advance(walk, action)
            self._step(index, env.reach.sim, walk, action)
            return result

        recorder.begin_episode = begin_episode  # type: ignore[method-assign]
        env.advance_subgoal = advance_subgoal

    def _step(self, index: int, sim: Any, walk: Any, action: Any) -> None:
        episode = self._episodes[index]
        position, velocity = sim.data.qpos, sim.data.qvel
        subgoal = np.asarray(walk.subgoal, float)
        if episode["walk"] is not walk:  # a new subgoal's walk
            episode.update(walk=walk, since=0, subgoals=episode["subgoals"] + 1)
        episode["since"] += 1
        offset = subgoal - position[:2]
        self.rows.append(
            (
                episode["seed"], episode["t"], episode["subgoals"], episode["since"], offset[0], offset[1],
                sim.uprightness, position[2], *velocity[:6], *np.clip(np.asarray(action, float), -1, 1),
                wall_contacts(sim, self._floor), wall_distance_m(position[:2], episode["boxes"]),
                *position[3:7], float(walk.fell),
            )
        )  # fmt: skip
        episode["t"] += 1


def parse_tilt_damping(text: str) -> tuple[float, float, float]:
    """``U,L,K`` as ``(upper_uprightness, lower_uprightness, min_scale)`` of a ``TiltDampedController``.

    Raises:
        ValueError: Naming ``text`` if it is not three comma-separated numbers (the controller checks their range).
    """
    try:
        upper, lower, scale = (float(value) for value in text.split(","))
    except ValueError:
        raise ValueError(f"--tilt-damping {text!r} is not U,L,K (three numbers, e.g. 0.8,0.6,0.3)") from None
    return upper, lower, scale


def record(
    low_level: str | None,
    seeds: range,
    *,
    num_envs: int,
    family: str,
    clearance_m: float | None,
    tilt_damping: tuple[float, float, float] | None,
) -> tuple[np.ndarray, list[str], float]:
    """Plays one episode per seed with the oracle and ``low_level``, ``num_envs`` at once; every step recorded.

    Returns:
        The rows (float64, one per low-level step, :data:`COLUMNS`), the outcomes in seed order, and the
        seconds it took.
    """
    torch.set_num_threads(1)
    controller: Any = NumpyActor.from_model(worker_low_level(low_level))
    if tilt_damping is not None:
        upper, lower, scale = tilt_damping
        controller = TiltDampedController(controller, upper_uprightness=upper, lower_uprightness=lower, min_scale=scale)
    recorders = [family_env(family, controller) for _ in range(num_envs)]
    oracle = PathOracle.for_env(
        recorders[0], subgoal_reach_m=BODY_DEFAULTS["ant"]["subgoal_reach_m"], clearance_m=clearance_m
    )
    steps = StepRecorder(recorders, seeds)
    started = time.perf_counter()
    raw = play_episodes_lockstep(recorders, oracle, seeds)
    return np.array(steps.rows, dtype=np.float64), raw["outcomes"], time.perf_counter() - started


def load_run(path: Path) -> dict[str, Any]:
    """A record's rows, column index, seeds, outcomes and settings (``PROBE_SETTINGS`` where none are stored).

    Raises:
        ValueError: One line naming ``path`` if it is missing, not an ``.npz`` or lacks a record's arrays.
    """
    if not path.is_file():
        raise ValueError(f"no record at {path}")
    try:
        with np.load(path, allow_pickle=False) as data:
            run = {key: data[key] for key in ("rows", "cols", "seeds", "outcomes")}
            settings = json.loads(str(data["settings"])) if "settings" in data else dict(PROBE_SETTINGS)
    except (OSError, ValueError, KeyError) as error:
        reason = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise ValueError(
            f"{path} is not a flip_precursors record (.npz of rows, cols, seeds, outcomes): {reason}"
        ) from None
    run["columns"] = {str(name): index for index, name in enumerate(run.pop("cols"))}
    run["settings"] = settings
    return run


def step_features(rows: np.ndarray, columns: dict[str, int]) -> dict[str, np.ndarray]:
    """Per-step features of one episode's rows.

    Uprightness, steps since the subgoal was set, wall contacts and torso-to-wall distance, mean |action|, speed
    (m/s) and the angle (degrees) between the velocity and the subgoal's direction.
    """
    column = {name: rows[:, index] for name, index in columns.items()}
    actions = rows[:, [columns[f"a{k}"] for k in range(8)]]
    subgoal_angle = np.arctan2(column["offy"], column["offx"])
    turn = subgoal_angle - np.arctan2(column["vy"], column["vx"])
    return {
        "up": column["up"],
        "since": column["since"],
        "wallc": column["wallc"],
        "walld": column["walld"],
        "amag": np.abs(actions).mean(1),
        "speed": np.hypot(column["vx"], column["vy"]),
        "vrel": np.abs(np.degrees(np.arctan2(np.sin(turn), np.cos(turn)))),
    }


def episodes_by_seed(rows: np.ndarray, columns: dict[str, int]) -> dict[int, np.ndarray]:
    """The rows of each episode (lockstep interleaves them), in step order, by the episode's seed."""
    rows = rows[np.lexsort((rows[:, columns["t"]], rows[:, columns["ep"]]))]
    bounds = np.r_[0, np.nonzero(np.diff(rows[:, columns["ep"]]))[0] + 1, len(rows)]
    return {int(rows[start, columns["ep"]]): rows[start:end] for start, end in itertools.pairwise(bounds)}


def after_wall_contact(contacts: np.ndarray) -> np.ndarray:
    """Per step: whether a leg touched a wall in the :data:`CONTACT_WINDOW_STEPS` steps before it."""
    touched = np.convolve((contacts > 0).astype(float), np.ones(CONTACT_WINDOW_STEPS))[: len(contacts)] > 0
    return np.r_[False, touched[:-1]]


def onset_step(up: np.ndarray, seed: int) -> int:
    """A flipped episode's onset: its last step with uprightness >= :data:`ONSET_UPRIGHTNESS`.

    Raises:
        ValueError: Naming the seed if the episode never stood that upright.
    """
    onset = len(up) - 1 - flip_lead(up, ONSET_UPRIGHTNESS)
    if onset < 0:
        raise ValueError(f"episode {seed} flipped without a step at uprightness >= {ONSET_UPRIGHTNESS}")
    return onset


def _average(statistic: Any, values: Sequence[float], digits: int) -> float | None:
    # Flip-onset figures of a run without flips (or dips) are None, not NaN.
    return round(float(statistic(values)), digits) if len(values) else None


def _per_10k(events: float, steps: float) -> float | None:
    return round(events / steps * 1e4, 2) if steps else None


def run_figures(run: dict[str, Any]) -> dict[str, Any]:
    """One record's flip figures (the ``runs`` entries of ``summarise``'s file, without ``low_level``)."""
    episodes = episodes_by_seed(run["rows"], run["columns"])
    seeds, outcomes = run["seeds"], run["outcomes"]
    flips = int((outcomes == "flip").sum())
    lead, since, contact_led, onset_wall, action, speed, heading = [], [], [], [], [], [], []
    steps_after, steps_other, onsets_after, onsets_other = 0, 0, 0, 0
    bin_steps, bin_onsets = np.zeros(len(WALL_BINS_M)), np.zeros(len(WALL_BINS_M))
    control: dict[str, list[float]] = {"amag": [], "speed": [], "vrel": [], "walld": []}
    after_dip: dict[str, list[float]] = {"flip": [], "recover": []}
    for seed, result in zip(seeds, outcomes, strict=True):
        feature = step_features(episodes[int(seed)], run["columns"])
        steps = len(feature["up"])
        contact = after_wall_contact(feature["wallc"])
        end, onset = steps, None
        if result == "flip":
            onset = onset_step(feature["up"], int(seed))
            end = onset + 1
            lead.append(steps - 1 - onset)
            since.append(int(feature["since"][onset]))
            contact_led.append(bool(contact[onset]))
            onset_wall.append(float(feature["walld"][onset]))
            window = slice(max(0, onset - 20), onset)
            action.append(float(feature["amag"][window].mean()))
            speed.append(float(feature["speed"][window].mean()))
            heading.append(float(np.nanmean(feature["vrel"][window])))
        else:
            for stop in range(20, steps, CONTROL_STRIDE_STEPS):
                window = slice(stop - 20, stop)
                for name in ("amag", "speed", "vrel"):
                    control[name].append(np.nanmean(feature[name][window]))
                control["walld"].append(feature["walld"][stop])
        steps_after += int(contact[:end].sum())
        steps_other += int((~contact[:end]).sum())
        for index, (low, high) in enumerate(WALL_BINS_M):
            bin_steps[index] += ((feature["walld"][:end] >= low) & (feature["walld"][:end] < high)).sum()
            if onset is not None and low <= feature["walld"][onset] < high:
                bin_onsets[index] += 1
        if onset is not None:
            onsets_after += int(contact[onset])
            onsets_other += int(not contact[onset])
        below = feature["up"] < 0.8
        for crossing in np.nonzero(np.diff(below.astype(int)) == 1)[0] + 1:
            kind = "recover" if (feature["up"][crossing:] >= ONSET_UPRIGHTNESS).any() else None
            kind = kind or ("flip" if result == "flip" else None)
            if kind:
                after_dip[kind].append(float(feature["amag"][crossing : crossing + 8].mean()))
    calm = [
        episodes[int(seed)][:, run["columns"]["up"]]
        for seed, result in zip(seeds, outcomes, strict=True)
        if result != "flip"
    ]
    dips = {
        str(level): int(sum(np.sum(np.diff((up < level).astype(int)) == 1) for up in calm)) for level in DIP_THRESHOLDS
    }
    steps_total = len(run["rows"])
    return {
        "episodes": len(seeds),
        "outcomes": {name: int((outcomes == name).sum()) for name in sorted(set(outcomes.tolist()))},
        "low_level_steps": steps_total,
        "flips": flips,
        "flips_per_10k_steps": round(flips / steps_total * 1e4, 3),
        "onset_to_flip_steps": {
            "median": _average(np.median, lead, 1),
            "min": min(lead, default=None),
            "max": max(lead, default=None),
        },
        "wall_contact_in_20_steps_before_onset": f"{sum(contact_led)} of {flips}",
        "onset_hazard_per_10k_steps_after_a_wall_contact": _per_10k(onsets_after, steps_after),
        "onset_hazard_per_10k_steps_otherwise": _per_10k(onsets_other, steps_other),
        "steps_after_a_wall_contact": steps_after,
        "onset_hazard_per_10k_by_torso_to_wall_m": {
            f"{low}-{high}": f"{onsets:.0f} / {steps:.0f} = {_per_10k(onsets, steps) or 0:.2f}"
            for (low, high), onsets, steps in zip(WALL_BINS_M, bin_onsets, bin_steps, strict=True)
        },
        "torso_to_wall_m_at_onset_median": _average(np.median, onset_wall, 2),
        "torso_to_wall_m_non_flip_median": _average(np.median, control["walld"], 2),
        "steps_since_subgoal_at_onset": sorted(since),
        "mean_abs_action_20_steps_before_onset_median": _average(np.median, action, 3),
        "mean_abs_action_non_flip_20_step_windows_median": _average(np.median, control["amag"], 3),
        "speed_m_s_20_steps_before_onset_median": _average(np.median, speed, 2),
        "speed_m_s_non_flip_median": _average(np.median, control["speed"], 2),
        "velocity_to_subgoal_deg_before_onset_median": _average(np.median, heading, 1),
        "velocity_to_subgoal_deg_non_flip_median": _average(np.median, control["vrel"], 1),
        "mean_abs_action_8_steps_after_crossing_0.8": {
            "flipping": _average(np.mean, after_dip["flip"], 3),
            "recovering": _average(np.mean, after_dip["recover"], 3),
            "recovering_crossings": len(after_dip["recover"]),
        },
        "non_flip_dips_below_uprightness": dips,
    }


def equal_rate_p(flips: int, steps: int, base_flips: int, base_steps: int) -> float:
    """Exact conditional test of equal flip rates per step: binomial on ``flips`` of all flips (3 decimals)."""
    return _binomial_p(flips, base_flips + flips, steps / (base_steps + steps))


def _binomial_p(successes: int, trials: int, share: float) -> float:
    # No trials (no flips, no discordant pairs) is no evidence of a difference: p = 1.
    return round(binomtest(successes, trials, share).pvalue, 3) if trials else 1.0


def paired(name: str, base: str, runs: dict[str, dict[str, Any]], figures: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """Run ``name`` against run ``base`` on the same mazes: flips, their rate test, McNemar on successes.

    Raises:
        ValueError: If the two runs did not play the same seeds.
    """
    if runs[name]["seeds"].tolist() != runs[base]["seeds"].tolist():
        raise ValueError(f"--compare {name}:{base}: the two runs played different maze seeds")
    ours = dict(zip(runs[name]["seeds"].tolist(), runs[name]["outcomes"].tolist(), strict=True))
    theirs = dict(zip(runs[base]["seeds"].tolist(), runs[base]["outcomes"].tolist(), strict=True))
    only_base = sum(theirs[s] == "success" and ours[s] != "success" for s in theirs)
    only_ours = sum(ours[s] == "success" and theirs[s] != "success" for s in theirs)
    flips, base_flips = figures[name]["flips"], figures[base]["flips"]
    return {
        "flips": f"{flips} vs {base_flips}",
        "equal_flip_rate_exact_conditional_p": equal_rate_p(
            flips, figures[name]["low_level_steps"], base_flips, figures[base]["low_level_steps"]
        ),
        f"success_only_{base}": only_base,
        f"success_only_{name}": only_ours,
        "mcnemar_p": _binomial_p(only_ours, only_base + only_ours, 0.5),
        "flipping_mazes_shared": sum(ours[s] == "flip" and theirs[s] == "flip" for s in theirs),
    }


def pooled(names: Sequence[str], bases: Sequence[str], figures: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """Runs ``names`` pooled against runs ``bases`` pooled: flips per step and their rate test."""
    flips, steps = (sum(figures[name][key] for name in names) for key in ("flips", "low_level_steps"))
    base_flips, base_steps = (sum(figures[name][key] for name in bases) for key in ("flips", "low_level_steps"))
    return {
        "flips": f"{flips} / {steps} vs {base_flips} / {base_steps}",
        "per_10k": f"{flips / steps * 1e4:.2f} vs {base_flips / base_steps * 1e4:.2f}",
        "equal_flip_rate_exact_conditional_p": equal_rate_p(flips, steps, base_flips, base_steps),
    }


def split_pair(text: str, separator: str, option: str) -> tuple[str, str]:
    """``LEFT<separator>RIGHT`` as its two non-empty parts.

    Raises:
        ValueError: Naming ``option`` and ``text`` if it is not of that form.
    """
    left, found, right = text.partition(separator)
    if not (found and left and right):
        raise ValueError(f"{option} {text!r} is not LEFT{separator}RIGHT")
    return left, right


def summarise(
    runs: dict[str, Path],
    *,
    describe: dict[str, str],
    compare: Sequence[tuple[str, str]],
    pool: Sequence[tuple[str, list[str], list[str]]],
) -> dict[str, Any]:
    """The summary of the records ``runs`` (by name): run figures, then the comparisons asked for.

    Raises:
        ValueError: One line for an unreadable record, a name not among the runs, runs of different
            settings, or compared runs on different seeds.
    """
    named = [*describe, *(name for pair in compare for name in pair)]
    named += [name for _, names, bases in pool for name in (*names, *bases)]
    unknown = sorted(set(named) - set(runs))
    if unknown:
        raise ValueError(f"not a run given as NAME=RUN.npz: {', '.join(unknown)}")
    loaded = {name: load_run(path) for name, path in runs.items()}
    settings = {json.dumps({key: run["settings"][key] for key in PROBE_SETTINGS}) for run in loaded.values()}
    if len(settings) > 1:
        raise ValueError(f"the runs differ in family, num_envs or subgoal reach: {sorted(settings)}")
    seeds = np.concatenate([run["seeds"] for run in loaded.values()])
    first = next(iter(loaded.values()))["settings"]
    out: dict[str, Any] = {
        "family": first["family"],
        "maze_seeds": [int(seeds.min()), int(seeds.max())],
        "oracle_subgoal_reach_m": first["oracle_subgoal_reach_m"],
        "num_envs": first["num_envs"],
        "onset": f"the last step with uprightness >= {ONSET_UPRIGHTNESS} before a flip",
        "runs": {},
    }
    for name, run in loaded.items():
        text = describe.get(name, run["settings"].get("description"))
        out["runs"][name] = {**({"low_level": text} if text else {}), **run_figures(run)}
    figures = out["runs"]
    out["paired"] = {f"{name} vs {base}": paired(name, base, loaded, figures) for name, base in compare}
    out["paired"].update({label: pooled(names, bases, figures) for label, names, bases in pool})
    return out


def build_parser() -> argparse.ArgumentParser:
    """The command line's parser (``scripts/results_index.py --check`` parses recorded options with it)."""
    parser = lab_parser("antmaze_lab.flip_precursors", __doc__)
    commands = parser.add_subparsers(dest="command", required=True)
    rec = commands.add_parser("record", help="play the mazes and write every low-level step to an .npz")
    rec.add_argument("--out", type=Path, required=True, help="the .npz to write (required)")
    rec.add_argument("--low-level", default=None, help="policy .zip or 'ensemble' (default: the shipped ant)")
    rec.add_argument("--episodes", type=int, default=600, help="mazes, one episode each (default: 600)")
    rec.add_argument("--seed", type=int, default=3_000_000, help="maze seed of episode 0 (default: 3000000)")
    rec.add_argument("--num-envs", type=int, default=25, help="mazes played in lockstep (default: 25)")
    rec.add_argument("--family", default="select6", help="maze family (default: select6)")
    rec.add_argument("--clearance-m", type=float, default=None, help="oracle wall clearance (default: the oracle's)")
    rec.add_argument("--tilt-damping", default=None, help="U,L,K of a TiltDampedController (default: none)")
    summ = commands.add_parser("summarise", help="summarise records into a JSON file")
    summ.add_argument("runs", nargs="+", metavar="NAME=RUN.npz", help="named records (required)")
    summ.add_argument("--out", type=Path, required=True, help="the JSON file to write (required)")
    summ.add_argument(
        "--describe", action="append", default=[], help="NAME=TEXT: a run's low_level text (default: its record's)"
    )
    summ.add_argument(
        "--compare", action="append", default=[], help="NAME:BASE, paired on the same mazes (default: none)"
    )
    summ.add_argument("--pool", action="append", default=[], help="LABEL=A+B:C+D, runs pooled (default: none)")
    return parser


def _fail(message: str) -> NoReturn:
    # Bad input is one line on stderr and status 2 (argparse's own errors add the usage above theirs).
    print(f"error: {message}", file=sys.stderr)
    sys.exit(2)


def _record(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    refuse_below_one(parser, args, ["episodes", "num_envs"])
    if not args.out.parent.is_dir():
        _fail(f"--out {args.out}: no folder {args.out.parent}")  # before the run, not after it
    try:
        damping = parse_tilt_damping(args.tilt_damping) if args.tilt_damping is not None else None
        rows, outcomes, seconds = record(
            args.low_level,
            range(args.seed, args.seed + args.episodes),
            num_envs=args.num_envs,
            family=args.family,
            clearance_m=args.clearance_m,
            tilt_damping=damping,
        )
    except (ValueError, FileNotFoundError) as error:
        _fail(str(error))
    clearance = "defaults" if args.clearance_m is None else f"clearance_m={args.clearance_m:g}"
    damped = ""
    if damping is not None:
        damped = " in TiltDampedController(upper_uprightness={}, lower_uprightness={}, min_scale={})".format(*damping)
    low_level = args.low_level or "the shipped ant"
    settings = {
        "family": args.family,
        "num_envs": args.num_envs,
        "oracle_subgoal_reach_m": BODY_DEFAULTS["ant"]["subgoal_reach_m"],
        "description": f"{low_level} (numpy path){damped}, oracle {clearance}",
        "command": recorded_command("antmaze_lab.flip_precursors", sys.argv[1:]),
    }
    seeds = np.arange(args.seed, args.seed + args.episodes)

    def write(path: Path) -> None:
        with path.open("wb") as handle:  # np.savez would append .npz to a temporary name
            np.savez_compressed(
                handle, rows=rows, cols=np.array(COLUMNS), seeds=seeds, outcomes=np.array(outcomes),
                settings=np.array(json.dumps(settings)),
            )  # fmt: skip

    atomic_write_with(args.out, write)
    counts = {name: outcomes.count(name) for name in sorted(set(outcomes))}
    print(f"{len(rows)} steps in {seconds:.1f}s = {len(rows) / seconds:.0f} steps/s; outcomes {counts}")


def _summarise(args: argparse.Namespace) -> None:
    try:
        runs = dict(split_pair(text, "=", "run") for text in args.runs)
        describe = dict(split_pair(text, "=", "--describe") for text in args.describe)
        compare = [split_pair(text, ":", "--compare") for text in args.compare]
        pool = []
        for text in args.pool:
            label, sides = split_pair(text, "=", "--pool")
            names, bases = split_pair(sides, ":", "--pool")
            pool.append((label, names.split("+"), bases.split("+")))
        out = summarise(
            {name: Path(path) for name, path in runs.items()}, describe=describe, compare=compare, pool=pool
        )
    except ValueError as error:
        _fail(str(error))
    out["command"] = recorded_command("antmaze_lab.flip_precursors", sys.argv[1:])
    atomic_write_json(args.out, out)
    print(json.dumps(out, indent=1))


def main() -> None:
    """The command line: ``record`` one run's steps, or ``summarise`` records into a JSON file."""
    parser = build_parser()
    args = parser.parse_args()
    if args.command == "record":
        _record(parser, args)
    else:
        _summarise(args)


if __name__ == "__main__":
    main()
