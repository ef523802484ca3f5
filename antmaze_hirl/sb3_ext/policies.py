"""Saving and loading low-level policies: the ones shipped inside the package, or any TD3/DDPG ``.zip``."""

from __future__ import annotations

import functools
import hashlib
import zipfile
from importlib import resources
from pathlib import Path

import torch as th
from stable_baselines3 import TD3
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm

from antmaze_hirl.atomic_io import atomic_write_with
from antmaze_hirl.envs.reach import ReachEnv
from antmaze_hirl.envs.simulator import body_spec

_ACTING_ONLY = {"replay_buffer_class": None, "replay_buffer_kwargs": {}, "buffer_size": 1}


def shipped_policy_path(body: str) -> Path:
    """Path of the policy shipped for ``body`` (``antmaze_hirl/policies/<body>_td3.zip``)."""
    body_spec(body)
    return Path(str(resources.files("antmaze_hirl").joinpath("policies", f"{body}_td3.zip")))


@functools.cache
def load_shipped_policy(body: str) -> OffPolicyAlgorithm:
    """The shipped policy for ``body``, loaded once per process and shared (acting only reads it)."""
    return load_low_level(body)


def load_low_level(body: str, path: str | Path | None = None, *, device: str = "cpu") -> OffPolicyAlgorithm:
    """Loads a low-level reach policy for ``body``.

    Args:
        body: ``"ant"`` or ``"point"``.
        path: A TD3/DDPG ``.zip`` saved by SB3 (``train-low`` writes ``policy.zip``). Default: the
            policy shipped in the package.
        device: Torch device for the networks.

    Returns:
        The SB3 model (DDPG is a TD3 subclass in SB3, so both load here); act with ``predict``.

    Raises:
        FileNotFoundError: If there is no file at ``path``.
        ValueError: If the file is not an SB3 policy zip, or was trained for another body.
    """
    path = Path(path) if path is not None else shipped_policy_path(body)
    if not path.is_file():
        raise FileNotFoundError(f"no low-level policy at {path}; train one with `antmaze-hirl train-low --body {body}`")
    try:
        # Loading for acting only: no HER buffer (it would need an env and allocate buffer_size rows).
        model = TD3.load(path, device=device, custom_objects=_ACTING_ONLY)
    except (zipfile.BadZipFile, KeyError, ValueError, EOFError) as error:
        raise ValueError(f"{path} is not an SB3 TD3/DDPG policy zip: {error}") from error
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
