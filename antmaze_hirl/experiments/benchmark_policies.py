"""The policies ``antmaze-hirl benchmark`` scores, by name or file: :func:`resolve_policy`.

``oracle`` (the scripted :class:`~antmaze_hirl.experts.PathOracle`), ``random``
(:class:`RandomSubgoalPolicy`), ``planner`` (the planning learner shipped for the suite's body), or the path
of an SB3 zip of a high-level model or a saved DAgger learner, each checked against the suite's body and maze
before any episode is played.
"""

from __future__ import annotations

import os
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from antmaze_hirl.envs.suite_specs import SuiteSpec

POLICY_KEYWORDS = ("oracle", "random")


PLANNER = "planner"
"""``--policy planner``: the planning learner shipped for the suite's body (:mod:`antmaze_hirl.dagger.shipped`)."""


class RandomSubgoalPolicy:
    """Subgoals drawn uniformly over the action space (the maze's inner bounds), from a seeded generator.

    Args:
        low: Lowest subgoal, metres.
        high: Highest subgoal, metres.
        seed: Seed of the draws.
    """

    def __init__(self, low: np.ndarray, high: np.ndarray, seed: int) -> None:
        self.low, self.high = np.asarray(low, dtype=np.float64), np.asarray(high, dtype=np.float64)
        self.rng = np.random.default_rng(seed)

    def __call__(self, observation: dict[str, np.ndarray]) -> np.ndarray:
        """A uniform subgoal (the observation is ignored)."""
        return self.rng.uniform(self.low, self.high)


def check_oracle_settings(other_policy: str | None, settings: dict[str, Any]) -> None:
    """Refuses an oracle setting given for another policy, or one that is not a finite number of metres > 0.

    The one check of ``score_policy``'s ``subgoal_reach_m`` / ``clearance_m`` and the command's
    ``--subgoal-reach-m`` / ``--clearance-m``; each caller names the settings and the policy its own way.

    Args:
        other_policy: How to name the policy when it is not the oracle (``"policy 'random'"``,
            ``"--policy random"``); ``None`` for the oracle.
        settings: Each setting's name and value (``None``: not given).

    Raises:
        ValueError: Naming the first setting refused and its value (or the policy that takes none).
    """
    for name, metres in settings.items():
        if metres is None:
            continue
        if other_policy is not None:
            raise ValueError(f"{name} is the oracle's setting; {other_policy} takes none")
        number = isinstance(metres, int | float) and not isinstance(metres, bool)
        if not (number and np.isfinite(metres) and metres > 0):
            raise ValueError(f"{name} must be a finite number of metres > 0, got {metres!r}")


def resolve_policy(
    spec: SuiteSpec,
    policy: str | os.PathLike[str],
    env: Any,
    *,
    seed: int,
    subgoal_reach_m: float | None = None,
    clearance_m: float | None = None,
) -> tuple[Any, str]:
    """The policy named by ``policy`` for suite ``spec`` (on ``env``, one of its envs) and its description.

    ``"oracle"``: the scripted oracle, its subgoals at most ``subgoal_reach_m`` metres away (default the
    body's experiment setting: one cell for the point, 2 m for the ant) and its straight walks ``clearance_m``
    from walls (default :class:`~antmaze_hirl.experts.PathOracle`'s, 0.2 cell); ``"random"``:
    :class:`RandomSubgoalPolicy` seeded with ``seed``; ``"planner"``: the planning learner shipped for the suite's
    body (:mod:`antmaze_hirl.dagger.shipped`), zero-shot on a map it was not trained on; else a path to an SB3
    zip of a high-level model (PPO, A2C, SAC, TD3/DDPG) or to a saved DAgger learner
    (:meth:`~antmaze_hirl.dagger.high_level_policy.HighLevelPolicy.save`, e.g. a study's ``learner.zip``).

    Raises:
        FileNotFoundError: If a path names no file.
        ValueError: If the file is neither kind, its policy is for another body or maze shape, or
            ``subgoal_reach_m`` or ``clearance_m`` is given for a policy other than the oracle or is not a
            finite number > 0.
    """
    check_oracle_settings(
        f"policy {str(policy)!r}" if policy != "oracle" else None,
        {"subgoal_reach_m": subgoal_reach_m, "clearance_m": clearance_m},
    )
    if policy == "oracle":
        from antmaze_hirl.experiments.config import BODY_DEFAULTS
        from antmaze_hirl.experts import PathOracle

        reach = BODY_DEFAULTS[spec.body]["subgoal_reach_m"] if subgoal_reach_m is None else subgoal_reach_m
        return PathOracle.for_env(env, subgoal_reach_m=reach, clearance_m=clearance_m), "oracle"
    if policy == "random":
        space = env.action_space
        return RandomSubgoalPolicy(space.low, space.high, seed), "random"
    if policy == PLANNER:
        from antmaze_hirl.dagger.shipped import shipped_learner_path, shipped_learner_record

        record = shipped_learner_record(spec.body)
        path = shipped_learner_path(spec.body)
        learner, description = _learner_and_description(spec, path, env)
        return learner, (
            f"shipped {spec.body} planning learner sha256:{record['sha256'][:16]} ({record['labels']} labels)"
            + description.removeprefix(f"dagger learner {path}")
        )
    path = Path(policy)
    if not path.is_file():
        raise FileNotFoundError(
            f"no policy file at {path}; --policy takes oracle, random, or the path of an SB3 zip or a saved DAgger "
            "learner"
        )
    try:
        with zipfile.ZipFile(path) as archive:
            names = set(archive.namelist())
    except zipfile.BadZipFile:
        raise ValueError(f"{path} is not a zip (an SB3 model or a saved DAgger learner)") from None
    if "meta.json" in names:
        return _learner_and_description(spec, path, env)
    if "data" in names:
        return _load_sb3(spec, path, env), f"sb3 {path}"
    raise ValueError(f"{path} is neither an SB3 model zip (no 'data') nor a saved DAgger learner (no 'meta.json')")


def _learner_and_description(spec: SuiteSpec, path: Path, env: Any) -> tuple[Any, str]:
    """A saved DAgger learner for ``spec``'s maps and its description, which says when it plays zero-shot."""
    from antmaze_hirl.dagger.high_level_policy import HighLevelPolicy, read_policy_file
    from antmaze_hirl.envs.bodies import BODY_SPECS
    from antmaze_hirl.envs.state_layout import STATE_LAYOUT

    config, _ = read_policy_file(path)
    rows, cols, scale = config["geometry"]
    inner = env.unwrapped
    bodies = [body for body, body_facts in BODY_SPECS.items() if body_facts.scale == scale]
    if scale != inner.geometry.scale:
        raise ValueError(
            f"policy {path} is a learner for the {bodies[0] if bodies else '?'} body ({scale:g} m cells); suite "
            f"{spec.name!r} is {spec.body}"
        )
    body_dim = STATE_LAYOUT.body_dim(inner.observation_space["state"].shape[0])
    if config.get("body_dim", body_dim) != body_dim:
        raise ValueError(
            f"policy {path} reads {config['body_dim']} body values per state; suite {spec.name!r} ({spec.body}) "
            f"gives {body_dim}: a learner for another body"
        )
    learner = HighLevelPolicy.load(path)
    description = f"dagger learner {path}"
    if (rows, cols) == (inner.geometry.n_rows, inner.geometry.n_cols):
        return learner, description
    if not learner.runs_on_any_map:
        raise ValueError(
            f"policy {path} is a CNN learner for {rows}x{cols} maps; suite {spec.name!r} has "
            f"{inner.geometry.n_rows}x{inner.geometry.n_cols} maps (only a planning learner runs on any map)"
        )
    # Zero-shot: the same weights, planning rounds for this map.
    moved = learner.on_map(inner.geometry, pixels_per_cell=inner.pixels_per_cell)
    return moved, f"{description} (zero-shot: trained on {rows}x{cols} maps)"


def _sb3_algorithm(path: Path) -> Any:
    from stable_baselines3 import PPO, SAC, TD3

    from antmaze_hirl.sb3_ext.loading import policy_class_of

    policy_class = policy_class_of(path)
    for algorithm in (PPO, SAC, TD3):  # A2C's policies are PPO's; DDPG's are TD3's
        if issubclass(policy_class, algorithm.policy_aliases["MlpPolicy"]):
            return algorithm
    raise ValueError(
        f"{path} holds a {policy_class.__module__}.{policy_class.__qualname__}, not a policy of PPO, A2C, SAC, "
        "TD3 or DDPG"
    )


def _load_sb3(spec: SuiteSpec, path: Path, env: Any) -> Any:
    from antmaze_hirl.sb3_ext.loading import LOAD_ERRORS

    algorithm = _sb3_algorithm(path)
    try:
        model = algorithm.load(path, device="cpu", custom_objects={"replay_buffer_class": None, "buffer_size": 1})
    except LOAD_ERRORS as error:
        reason = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise ValueError(f"{path} is not a loadable SB3 {algorithm.__name__} zip (damaged?): {reason}") from error
    if model.observation_space != env.observation_space or model.action_space.shape != env.action_space.shape:
        raise ValueError(
            f"policy {path} observes {_space_text(model.observation_space)}, but suite {spec.name!r} ({spec.body}) "
            f"gives {_space_text(env.observation_space)}: a policy of another body or maze size"
        )
    return lambda observation: model.predict(observation, deterministic=True)[0]


def _space_text(space: Any) -> str:
    if hasattr(space, "spaces"):
        return ", ".join(f"{key} {tuple(sub.shape)}" for key, sub in space.spaces.items())
    return str(getattr(space, "shape", space))
