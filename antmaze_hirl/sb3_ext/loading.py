"""Loading and saving low-level policies: any SB3 off-policy ``.zip`` (TD3, DDPG, SAC; TQC with sb3-contrib)."""

from __future__ import annotations

import hashlib
import json
import pickle
import warnings
import zipfile
from pathlib import Path

import torch as th
from stable_baselines3 import SAC, TD3
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm
from stable_baselines3.common.save_util import json_to_data

from antmaze_hirl.atomic_io import atomic_write_with
from antmaze_hirl.envs.reach import ReachEnv
from antmaze_hirl.sb3_ext.shipped import shipped_policy_path

_ACTING_ONLY = {"replay_buffer_class": None, "replay_buffer_kwargs": {}, "buffer_size": 1}
LOAD_ERRORS = (zipfile.BadZipFile, KeyError, ValueError, EOFError, pickle.UnpicklingError, RuntimeError)
"""What loading a damaged SB3 zip raises: a broken archive, a missing or garbled member, a truncated tensor file
(torch's ``RuntimeError``), a pickle that torch's weights-only loader refuses."""
LOW_LEVEL_NAMES: dict[str, dict[str, str]] = {
    "ant": {"shipped": "ant_td3.zip", "ensemble": "ant_td3.zip"},
    "point": {"shipped": "point_td3.zip"},
}
"""Low levels loadable by name, per body: the file each names in ``antmaze_hirl/policies/``. ``shipped`` is the
body's default; the ant's ``ensemble`` is the seven-head stage-6 action ensemble, whatever ships by default, so
that every result made with it replays by name."""


def low_level_path(body: str, name_or_path: str | Path | None) -> Path:
    """The zip that a low-level name (:data:`LOW_LEVEL_NAMES`) or path stands for; ``None``: the shipped one.

    A value is a name when it is one of the body's names; anything else is a path, and a value that looks like
    neither (no ``.zip`` suffix, no folder, no such file) is reported as an unknown name.

    Raises:
        ValueError: For an unknown body, or a value that is neither a known name nor a zip path.
    """
    names = LOW_LEVEL_NAMES.get(body)
    if names is None:
        raise ValueError(f"unknown body {body!r}; choose one of {sorted(LOW_LEVEL_NAMES)}")
    if name_or_path is None:
        return shipped_policy_path(body)
    text = str(name_or_path)
    if text in names:
        return shipped_policy_path(body).with_name(names[text])
    path = Path(name_or_path)
    if path.suffix != ".zip" and len(path.parts) == 1 and not path.exists():
        raise ValueError(
            f"unknown low level {text!r} for the {body}: give a zip path or one of {', '.join(sorted(names))}"
        )
    return path


def off_policy_algorithms() -> tuple[type[OffPolicyAlgorithm], ...]:
    """The algorithms :func:`load_low_level` reads: TD3 (DDPG too: SB3's DDPG is TD3 with TD3's policy), SAC, TQC.

    TQC is included when ``sb3_contrib`` is installed.
    """
    try:
        from sb3_contrib import TQC
    except ImportError:  # sb3-contrib is optional
        return (TD3, SAC)
    return (TD3, SAC, TQC)


def policy_class_of(path: str | Path) -> type:
    """The policy class an SB3 zip names (read from its ``data``, without loading the weights).

    Raises:
        ValueError: If ``path`` is not an SB3 zip, or its policy class cannot be imported here.
    """
    try:
        with zipfile.ZipFile(path) as archive:
            entry = json.loads(archive.read("data"))["policy_class"]
        module = entry["__module__"]
    except (zipfile.BadZipFile, KeyError, ValueError, TypeError) as error:
        raise ValueError(f"{path} is not an SB3 policy zip: {error!r}") from error
    try:
        with warnings.catch_warnings():  # SB3 warns and skips what it cannot unpickle: that is the error below
            warnings.simplefilter("ignore")
            policy_class = json_to_data(json.dumps({"policy_class": entry})).get("policy_class")
    except ImportError as error:
        hint = "; pip install sb3-contrib to load its TQC" if str(module).startswith("sb3_contrib") else ""
        raise ValueError(f"{path} holds a policy from {module}, which this Python cannot import{hint}") from error
    if not isinstance(policy_class, type):
        raise ValueError(f"{path} holds a policy class from {module} that cannot be unpickled here")
    return policy_class


def algorithm_of(path: str | Path) -> type[OffPolicyAlgorithm]:
    """The SB3 algorithm class that saved ``path``, read from the policy class the zip names.

    An SB3 zip does not name its algorithm, but its ``data`` names the policy class, and each algorithm's
    ``"MlpPolicy"`` alias is the base class of all its policies (``TD3Policy``, ``SACPolicy``, ...), so a
    subclass such as :class:`~antmaze_hirl.sb3_ext.action_penalty.ActionPenaltyPolicy` is found too.
    Loading with the wrong class can succeed and fail only when acting, so the class is checked first.

    Raises:
        ValueError: If ``path`` is not an SB3 zip, or its policy belongs to none of
            :func:`off_policy_algorithms` (an on-policy PPO, ...), naming the policy class.
    """
    policy_class = policy_class_of(path)
    algorithms = off_policy_algorithms()
    for algorithm in algorithms:
        if issubclass(policy_class, algorithm.policy_aliases["MlpPolicy"]):
            return algorithm
    names = ", ".join(algorithm.__name__ for algorithm in algorithms)
    raise ValueError(
        f"{path} holds a {policy_class.__module__}.{policy_class.__qualname__}, not a policy of an off-policy "
        f"algorithm this loader reads ({names}; DDPG loads as TD3)"
    )


def load_low_level(body: str, path: str | Path | None = None, *, device: str = "cpu") -> OffPolicyAlgorithm:
    """Loads a low-level reach policy for ``body``, with the algorithm class that saved it.

    Args:
        body: ``"ant"`` or ``"point"``.
        path: An SB3 off-policy ``.zip`` (TD3, DDPG, SAC, or TQC with sb3-contrib installed; ``train-low``
            writes ``policy.zip``), or a name of :data:`LOW_LEVEL_NAMES` (``"shipped"``, the ant's
            ``"ensemble"``). Default: the policy shipped in the package.
        device: Torch device for the networks.

    Returns:
        The SB3 model (a DDPG zip loads as TD3, its SB3 base class); act with ``predict``.

    Raises:
        FileNotFoundError: If there is no file at ``path``.
        ValueError: If the file is not an SB3 zip (or is damaged), holds a policy of an unsupported algorithm,
            was trained for another body, or ``path`` is an unknown name.
    """
    path = low_level_path(body, path)
    if not path.is_file():
        raise FileNotFoundError(f"no low-level policy at {path}; train one with `antmaze-hirl train-low --body {body}`")
    algorithm = algorithm_of(path)
    try:
        # Loading for acting only: no HER buffer (it would need an env and allocate buffer_size rows).
        model = algorithm.load(path, device=device, custom_objects=_ACTING_ONLY)
    except LOAD_ERRORS as error:
        reason = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise ValueError(f"{path} is not a loadable SB3 {algorithm.__name__} zip (damaged?): {reason}") from error
    probe = ReachEnv(body)  # the body's observation space; the simulator is released right away
    expected = probe.observation_space
    probe.close()
    if model.observation_space != expected:
        raise ValueError(
            f"policy {path} was trained on observations {model.observation_space}, but body {body!r} "
            f"gives {expected}: wrong checkpoint for this body?"
        )
    return model


def save_policy(model: OffPolicyAlgorithm, path: str | Path) -> Path:
    """Saves the model without replay buffer or env, atomically (temp file beside ``path``, fsync, rename)."""
    return atomic_write_with(path, lambda tmp: model.save(tmp, exclude=["replay_buffer", "env"]))


def policy_fingerprint(model: OffPolicyAlgorithm | th.nn.Module) -> str:
    """A short SHA-256 of the policy's weights (of an SB3 model or a torch module): same weights, same fingerprint.

    Results folders record it, so that results made with one low-level policy are never resumed
    with another (a new shipped policy changes every ant figure).
    """
    digest = hashlib.sha256()
    module = model if isinstance(model, th.nn.Module) else model.policy
    for name, tensor in sorted(module.state_dict().items()):
        digest.update(name.encode())
        digest.update(tensor.detach().cpu().contiguous().reshape(-1).view(th.uint8).numpy().tobytes())
    return digest.hexdigest()[:16]
