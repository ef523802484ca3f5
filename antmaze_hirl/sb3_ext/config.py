"""Low-level training hyperparameters, read from ``hyperparams.yml`` beside this module."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from importlib import resources
from typing import Any

import yaml

ALGOS = ("td3", "ddpg")


@dataclass(frozen=True)
class LowLevelConfig:
    """Hyperparameters of an SB3 TD3/DDPG + HER run on a reach env (SB3 constructor keywords).

    Besides SB3's keywords: ``net_arch`` and ``action_noise_std`` (Gaussian exploration noise),
    ``n_sampled_goal`` (HER), ``relative_goal``/``quaternion_index`` (:class:`RelativeGoalExtractor`),
    ``action_l2`` (HER's actor action penalty, :class:`ActionPenaltyPolicy`; 0 = SB3's own policy)
    and ``env_kwargs`` for :class:`~antmaze_hirl.envs.reach.ReachEnv`.

    Raises:
        ValueError: If ``action_l2`` is negative.
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


def load_config(body: str) -> LowLevelConfig:
    """The shipped hyperparameters for ``body`` (``"ant"`` or ``"point"``).

    Raises:
        ValueError: If the file has no section for ``body`` or a section has an unknown key.

    """
    text = resources.files("antmaze_hirl.sb3_ext").joinpath("hyperparams.yml").read_text()
    sections = yaml.safe_load(text)
    if body not in sections:
        raise ValueError(f"hyperparams.yml has no section for body {body!r}; it has {sorted(sections)}")
    values = dict(sections[body])
    known = {f.name for f in dataclasses.fields(LowLevelConfig)}
    unknown = sorted(set(values) - known)
    if unknown:
        raise ValueError(f"hyperparams.yml section {body!r} has unknown keys {unknown}")
    values["net_arch"] = tuple(values.get("net_arch", LowLevelConfig.net_arch))
    return LowLevelConfig(**values)
