"""Low-level training hyperparameters, read from ``hyperparams.yml`` beside this module."""

from __future__ import annotations

import dataclasses
import numbers
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import yaml

ALGOS = ("td3", "ddpg")
# Checked at construction: a YAML typo (``3e-4`` is a string in YAML 1.1) would otherwise fail deep inside SB3.
_SCALAR_TYPES: dict[str, tuple[type, ...]] = {"float": (numbers.Real,), "int": (numbers.Integral,), "bool": (bool,)}


@dataclass(frozen=True)
class LowLevelConfig:
    """Hyperparameters of an SB3 TD3/DDPG + HER run on a reach env (SB3 constructor keywords).

    Besides SB3's keywords: ``net_arch`` and ``action_noise_std`` (Gaussian exploration noise),
    ``n_sampled_goal`` (HER), ``relative_goal``/``quaternion_index`` (:class:`RelativeGoalExtractor`),
    ``action_l2`` (HER's actor action penalty, :class:`ActionPenaltyPolicy`; 0 = SB3's own policy)
    and ``env_kwargs`` for :class:`~antmaze_hirl.envs.reach.ReachEnv`.

    Raises:
        ValueError: If a number or flag has the wrong type, or ``action_l2`` is negative.
    """

    learning_rate: float = 1e-3
    buffer_size: int = 1_000_000
    batch_size: int = 256
    gamma: float = 0.95
    tau: float = 0.005
    learning_starts: int = 1000
    train_freq: int = 1
    gradient_steps: int = 1
    net_arch: tuple[int, ...] = (256, 256)
    action_noise_std: float = 0.2
    n_sampled_goal: int = 4
    relative_goal: bool = True
    quaternion_index: int | None = None
    action_l2: float = 0.0
    env_kwargs: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for spec in dataclasses.fields(self):
            value, accepted = getattr(self, spec.name), _SCALAR_TYPES.get(str(spec.type))
            if accepted is None:
                continue
            if not isinstance(value, accepted) or isinstance(value, bool) != (bool in accepted):
                raise ValueError(f"{spec.name} must be {spec.type}, got {value!r}{_yaml_hint(value)}")
        if self.action_l2 < 0:
            raise ValueError(f"action_l2 must be >= 0, got {self.action_l2}")

    def replace(self, **changes: Any) -> LowLevelConfig:
        """A copy with ``changes`` applied (unknown keys raise ``TypeError``)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON form, stored in checkpoints to detect a mismatched resume."""
        data = dataclasses.asdict(self)
        data["net_arch"] = list(self.net_arch)
        return data


def _yaml_hint(value: Any) -> str:
    try:
        float(value)
    except (TypeError, ValueError):
        return ""
    return " (YAML 1.1 reads 3e-4 as a string: write 3.0e-4)" if isinstance(value, str) else ""


def load_config(body: str, overrides: str | Path | None = None) -> LowLevelConfig:
    """The shipped hyperparameters for ``body`` (``"ant"`` or ``"point"``), optionally overridden.

    Args:
        body: Section to read.
        overrides: A YAML file in the same format (a section per body); the keys its ``body`` section
            sets replace the shipped ones, whole values (``env_kwargs`` too), the rest stay.

    Raises:
        ValueError: If a file has no section for ``body`` or a section has an unknown key.

    """
    values = _section(
        resources.files("antmaze_hirl.sb3_ext").joinpath("hyperparams.yml").read_text(), body, "hyperparams.yml"
    )
    if overrides is not None:
        values.update(_section(Path(overrides).read_text(), body, str(overrides)))
    values["net_arch"] = tuple(values.get("net_arch", LowLevelConfig.net_arch))
    return LowLevelConfig(**values)


def _section(text: str, body: str, source: str) -> dict[str, Any]:
    try:
        sections = yaml.safe_load(text) or {}
    except yaml.YAMLError as error:
        raise ValueError(f"{source} is not valid YAML: {error}") from error
    if not isinstance(sections, dict) or body not in sections:
        found = sorted(sections) if isinstance(sections, dict) else type(sections).__name__
        raise ValueError(f"{source} has no section for body {body!r}; it has {found}")
    if not isinstance(sections[body], dict):
        raise ValueError(f"{source} section {body!r} must map keys to values, got {sections[body]!r}")
    values = dict(sections[body])
    unknown = sorted(set(values) - {f.name for f in dataclasses.fields(LowLevelConfig)})
    if unknown:
        raise ValueError(f"{source} section {body!r} has unknown keys {unknown}")
    return values
