"""Low-level training hyperparameters, read from ``hyperparams.yml`` beside this module.

The keys every algorithm shares (learning rate, buffer, HER, networks, env) sit beside keys only some
algorithms read: TD3/DDPG's exploration noise and action penalty, SAC/TQC's entropy settings, TQC's
quantiles. A key for another algorithm is an error, never silently ignored: a SAC run whose YAML sets
``action_noise_std`` would otherwise train with settings its author did not get.
"""

from __future__ import annotations

import dataclasses
import numbers
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import yaml

ALGOS = ("td3", "ddpg", "sac", "tqc")
_TD3_FAMILY = ("td3", "ddpg")  # SB3's DDPG is TD3 without the delay and target noise: one policy class
_SAC_FAMILY = ("sac", "tqc")  # sb3-contrib's TQC is SAC with a distributional critic


WARMUP_ACTIONS = ("uniform", "policy")
"""``warmup_actions`` values: SB3's uniformly random actions, or the model's own policy with its exploration."""


def check_warm_start_options(warmup_actions: Any, actor_frozen_steps: Any) -> None:
    """One-line ``ValueError`` for an unknown ``warmup_actions`` or an ``actor_frozen_steps`` that is < 0 or no int."""
    if warmup_actions not in WARMUP_ACTIONS:
        raise ValueError(f"warmup_actions must be one of {list(WARMUP_ACTIONS)}, got {warmup_actions!r}")
    if not isinstance(actor_frozen_steps, numbers.Integral) or isinstance(actor_frozen_steps, bool):
        raise ValueError(f"actor_frozen_steps must be an int, got {actor_frozen_steps!r}")
    if actor_frozen_steps < 0:
        raise ValueError(f"actor_frozen_steps must be >= 0, got {actor_frozen_steps}")


def _only(*algos: str) -> dict[str, tuple[str, ...]]:
    """Field metadata: the algorithms that read this key (the others must leave it at its default)."""
    return {"algos": algos}


# Field metadata of keys added after runs were checkpointed: at their default they stay out of to_dict, so a
# checkpoint written before the key existed still matches its config on --resume.
_LATER = {"omit_at_default": True}


# Checked at construction: a YAML typo (``3e-4`` is a string in YAML 1.1) would otherwise fail deep inside SB3.
_SCALAR_TYPES: dict[str, tuple[type, ...]] = {"float": (numbers.Real,), "int": (numbers.Integral,), "bool": (bool,)}


@dataclass(frozen=True)
class LowLevelConfig:
    """Hyperparameters of an SB3 off-policy + HER run on a reach env (SB3 constructor keywords).

    ``algo`` names the algorithm the config is for (``"td3"`` and ``"ddpg"`` share theirs). Besides SB3's
    keywords: ``net_arch``, ``n_sampled_goal`` (HER), ``relative_goal``/``quaternion_index``
    (:class:`RelativeGoalExtractor`) and ``env_kwargs`` for :class:`~antmaze_hirl.envs.reach.ReachEnv`.
    TD3/DDPG only: ``action_noise_std`` (Gaussian exploration noise) and ``action_l2`` (HER's actor action
    penalty, :class:`ActionPenaltyPolicy`; 0 = SB3's own policy). SAC/TQC only: ``ent_coef`` (``"auto"``,
    ``"auto_<initial>"`` or a fixed float), ``target_entropy`` (``"auto"`` = minus the action size, or a
    float) and ``target_update_interval``. TQC only: ``n_quantiles`` and ``top_quantiles_to_drop_per_net``.
    Fine-tuning a warm start (:mod:`antmaze_hirl.sb3_ext.warm_start`): ``warmup_actions`` (``"uniform"``,
    SB3's random actions before ``learning_starts``, or ``"policy"``, the warm-started policy's own with its
    usual exploration) and, TD3/DDPG only, ``actor_frozen_steps`` (the first gradient steps update the critics
    only; 0 = none). Both need ``train_low_level``'s ``init_from``.

    Raises:
        ValueError: If a number or flag has the wrong type, ``action_l2`` or ``actor_frozen_steps`` is negative,
            an entropy setting is malformed, ``warmup_actions`` is unknown, or a key of another algorithm is set
            (one line, naming the key).
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
    action_noise_std: float = field(default=0.2, metadata=_only(*_TD3_FAMILY))
    n_sampled_goal: int = 4
    relative_goal: bool = True
    quaternion_index: int | None = None
    action_l2: float = field(default=0.0, metadata=_only(*_TD3_FAMILY))
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    algo: str = "td3"
    ent_coef: str | float = field(default="auto", metadata=_only(*_SAC_FAMILY))
    target_entropy: str | float = field(default="auto", metadata=_only(*_SAC_FAMILY))
    target_update_interval: int = field(default=1, metadata=_only(*_SAC_FAMILY))
    n_quantiles: int = field(default=25, metadata=_only("tqc"))
    top_quantiles_to_drop_per_net: int = field(default=2, metadata=_only("tqc"))
    warmup_actions: str = field(default="uniform", metadata=_LATER)
    actor_frozen_steps: int = field(default=0, metadata={**_only(*_TD3_FAMILY), **_LATER})

    def __post_init__(self) -> None:
        for spec in dataclasses.fields(self):
            value, accepted = getattr(self, spec.name), _SCALAR_TYPES.get(str(spec.type))
            if accepted is None:
                continue
            if not isinstance(value, accepted) or isinstance(value, bool) != (bool in accepted):
                raise ValueError(f"{spec.name} must be {spec.type}, got {value!r}{_yaml_hint(value)}")
        if self.algo not in ALGOS:
            raise ValueError(f"algo must be one of {list(ALGOS)}, got {self.algo!r}")
        for spec in dataclasses.fields(self):
            if not applies(spec, self.algo) and getattr(self, spec.name) != spec.default:
                raise ValueError(
                    f"{spec.name} is a {'/'.join(spec.metadata['algos'])} key; {self.algo} does not use it"
                )
        if self.action_l2 < 0:
            raise ValueError(f"action_l2 must be >= 0, got {self.action_l2}")
        _check_entropy(self.ent_coef, self.target_entropy)
        check_warm_start_options(self.warmup_actions, self.actor_frozen_steps)

    def replace(self, **changes: Any) -> LowLevelConfig:
        """A copy with ``changes`` applied (unknown keys raise ``TypeError``)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON form of the keys ``algo`` reads, stored in checkpoints to detect a mismatched resume.

        Neither ``algo`` (the checkpoint records it apart) nor other algorithms' keys are in it, so a TD3
        checkpoint written before SAC was added still matches its config on ``--resume``; for the same reason
        ``warmup_actions`` and ``actor_frozen_steps`` are in it only when they differ from their defaults.
        """
        data = {
            spec.name: getattr(self, spec.name)
            for spec in dataclasses.fields(self)
            if applies(spec, self.algo)
            and not (spec.metadata.get("omit_at_default") and getattr(self, spec.name) == spec.default)
        }
        data["net_arch"] = list(self.net_arch)
        del data["algo"]
        return data


def applies(spec: dataclasses.Field[Any], algo: str) -> bool:
    """Whether ``algo`` reads the :class:`LowLevelConfig` field ``spec`` (shared keys apply to all)."""
    return algo in spec.metadata.get("algos", ALGOS)


def _check_entropy(ent_coef: str | float, target_entropy: str | float) -> None:
    """SB3 parses these only when the model is built, where a typo ("atuo") fails with a bare float error."""
    initial = ent_coef.removeprefix("auto_") if isinstance(ent_coef, str) and ent_coef != "auto" else ent_coef
    if not (ent_coef == "auto" or (_real(initial) and float(initial) > 0)):
        raise ValueError(f"ent_coef must be 'auto', 'auto_<initial value>' or a float > 0, got {ent_coef!r}")
    if not (target_entropy == "auto" or _real(target_entropy)):
        raise ValueError(f"target_entropy must be 'auto' or a float, got {target_entropy!r}")


def _real(value: Any) -> bool:
    """A number (not a flag), or a string of one as ``auto_0.1`` holds after its prefix."""
    if isinstance(value, str):
        try:
            float(value)
        except ValueError:
            return False
        return True
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _yaml_hint(value: Any) -> str:
    try:
        float(value)
    except (TypeError, ValueError):
        return ""
    return " (YAML 1.1 reads 3e-4 as a string: write 3.0e-4)" if isinstance(value, str) else ""


def load_config(body: str, overrides: str | Path | None = None, *, algo: str = "td3") -> LowLevelConfig:
    """The shipped hyperparameters for ``body`` (``"ant"`` or ``"point"``) and ``algo``, optionally overridden.

    The shipped sections hold the shared keys and TD3/DDPG's; for SAC and TQC their TD3/DDPG keys are left
    out and the entropy keys keep :class:`LowLevelConfig`'s defaults (SB3's own).

    Args:
        body: Section to read.
        overrides: A YAML file in the same format (a section per body); the keys its ``body`` section
            sets replace the shipped ones, whole values (``env_kwargs`` too), the rest stay.
        algo: One of :data:`ALGOS`; ``overrides`` may set only the keys it reads.

    Raises:
        ValueError: If a file has no section for ``body``, a section has an unknown key, or ``overrides``
            sets a key ``algo`` does not read (one line, naming the key).

    """
    if algo not in ALGOS:
        raise ValueError(f"unknown algo {algo!r}; choose one of {list(ALGOS)}")
    fields = {spec.name: spec for spec in dataclasses.fields(LowLevelConfig)}
    shipped = _section(
        resources.files("antmaze_hirl.sb3_ext").joinpath("hyperparams.yml").read_text(), body, "hyperparams.yml"
    )
    values = {key: value for key, value in shipped.items() if applies(fields[key], algo)}
    if overrides is not None:
        mine = _section(Path(overrides).read_text(), body, str(overrides))
        for key in mine:
            if not applies(fields[key], algo):
                algos = "/".join(fields[key].metadata["algos"])
                raise ValueError(
                    f"{overrides} section {body!r} sets {key}, a {algos} key that --algo {algo} does not use"
                )
        values.update(mine)
    values["net_arch"] = tuple(values.get("net_arch", LowLevelConfig.net_arch))
    return LowLevelConfig(**values, algo=algo)


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
    # algo comes from --algo: a file naming one could disagree with the command line.
    unknown = sorted(set(values) - {f.name for f in dataclasses.fields(LowLevelConfig)} | ({"algo"} & set(values)))
    if unknown:
        raise ValueError(f"{source} section {body!r} has unknown keys {unknown}")
    return values
