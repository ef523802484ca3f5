"""A trial's checkpoint on disk, in a format whose loading cannot run code.

The file (:data:`CHECKPOINT_FILE`) is :data:`MAGIC`, the SHA-256 hex digest of the rest and a newline, then
a ``torch.save`` archive. It is read with ``torch.load(weights_only=True)``: torch's restricted unpickler,
which builds tensors, numpy arrays and plain containers and calls nothing but the globals on an
allow-list (:func:`allowed_global`): the learner's, dataset's and strategies' own classes (from
``antmaze_hirl.dagger`` and ``antmaze_hirl.envs``), torch's layers and optimisers, and numpy's array,
dtype and random-generator constructors. A pickle from an untrusted place can run any code when loaded
(``pickle.loads``); this loader refuses every other global instead, so a replaced checkpoint is a
:class:`CheckpointError`, never a payload that runs.

Checkpoints written before this format (``checkpoint.pkl``: a bare pickle, or one after a hash line)
are refused with a message that says so: they are pickles, which this version does not load.
"""

from __future__ import annotations

import hashlib
import importlib
import io
from collections import defaultdict
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from antmaze_hirl.atomic_io import atomic_write_bytes

CHECKPOINT_FILE = "checkpoint.pt"
"""A trial's checkpoint, in its trial folder."""

LEGACY_CHECKPOINT_FILE = "checkpoint.pkl"
"""The pickled checkpoint of versions before :data:`CHECKPOINT_FILE` (refused: a pickle can run code)."""

MAGIC = b"antmaze_hirl trial checkpoint v3 (torch, weights_only)\n"
"""First line of a checkpoint; the SHA-256 hex digest of the archive follows on the second."""

_LEGACY_MAGIC = b"antmaze_hirl trial checkpoint v2\n"

_PACKAGES = ("antmaze_hirl.dagger.", "antmaze_hirl.envs.")
"""Packages whose classes a checkpoint may hold (the trainer's parts; never the study kit's server or files)."""

_NUMPY_GLOBALS = frozenset(
    {
        "numpy._core.multiarray._reconstruct",
        "numpy._core.multiarray.scalar",
        "numpy.core.multiarray._reconstruct",
        "numpy.core.multiarray.scalar",
        "numpy.ndarray",
        "numpy.dtype",
        "numpy.random._pickle.__generator_ctor",
        "numpy.random._pickle.__bit_generator_ctor",
        "numpy.random._pcg64.PCG64",
        "numpy.random.bit_generator.SeedSequence",
        "numpy.random.bit_generator.__pyx_unpickle_SeedSequence",
        "collections.deque",
        "collections.OrderedDict",
        "collections.defaultdict",
        "builtins.dict",
        "builtins.set",
        "builtins.frozenset",
    }
)
"""Globals outside the packages that a checkpoint needs: numpy's array and generator state, containers."""


class CheckpointError(ValueError):
    """A checkpoint that is damaged, in the old pickle format, or holds something not on the allow-list."""


def allowed_global(name: str, value: Any) -> bool:
    """Whether a checkpoint may name the global ``name`` (``module.qualname``), which resolves to ``value``.

    Classes of :data:`_PACKAGES` (never their functions), ``torch.nn`` modules and ``torch.optim``
    optimisers, numpy dtypes, and :data:`_NUMPY_GLOBALS`.
    """
    import numpy as np
    import torch

    if name in _NUMPY_GLOBALS:
        return True
    if not isinstance(value, type):
        return False
    if name.startswith(_PACKAGES):
        return True
    if name.startswith("torch.nn.modules.") and issubclass(value, torch.nn.Module):
        return True
    if name.startswith("torch.optim.") and issubclass(value, torch.optim.Optimizer):
        return True
    return name.startswith("numpy.dtypes.") and issubclass(value, np.dtype)


def save_checkpoint(content: Any, path: str | Path) -> Path:
    """Writes ``content`` (anything made of allow-listed classes) to ``path`` atomically, with its hash."""
    import torch

    buffer = io.BytesIO()
    optimizers = _optimizers(content)
    for optimizer in optimizers:  # torch's restricted loader fills plain dicts only, not a defaultdict
        optimizer.state = dict(optimizer.state)
    try:
        torch.save(content, buffer)
    finally:
        for optimizer in optimizers:
            optimizer.state = defaultdict(dict, optimizer.state)
    archive = buffer.getvalue()
    return atomic_write_bytes(path, MAGIC + hashlib.sha256(archive).hexdigest().encode() + b"\n" + archive)


def load_checkpoint(path: str | Path, extra_classes: Iterable[type] = ()) -> Any:
    """What :func:`save_checkpoint` wrote at ``path``, loaded with ``weights_only=True`` and the allow-list.

    Args:
        path: The checkpoint.
        extra_classes: Further classes it may hold (the study session's own records).

    Raises:
        CheckpointError: If the file fails its hash, is an old pickled checkpoint or a bare pickle, or names a
            global that is not allowed (the message names the file and the global); nothing in it has run.
    """
    import torch

    path = Path(path)
    data = path.read_bytes()
    if not data.startswith(MAGIC):
        if data.startswith(_LEGACY_MAGIC) or data[:1] == b"\x80":
            raise CheckpointError(
                f"{path} is a pickled checkpoint (of an earlier antmaze_hirl), which can run code when loaded: not "
                "loaded. Finish that participant with the version that wrote it, or remove the trial's folder"
            )
        raise CheckpointError(f"{path} is not a trial checkpoint (no {MAGIC[:-1].decode()!r} header)")
    digest, _, archive = data[len(MAGIC) :].partition(b"\n")
    if hashlib.sha256(archive).hexdigest().encode() != digest:
        raise CheckpointError(f"{path} is damaged: its content does not match its SHA-256 (restore a backup)")
    import numpy as np

    extra = {f"{cls.__module__}.{cls.__qualname__}": cls for cls in extra_classes}
    # numpy's dtype classes are met only while building arrays, so the scan below does not list them.
    allowed: list[Any] = [
        kind for kind in vars(np.dtypes).values() if isinstance(kind, type) and issubclass(kind, np.dtype)
    ]
    try:
        names = torch.serialization.get_unsafe_globals_in_checkpoint(io.BytesIO(archive))
    except Exception as error:  # a damaged archive raises nearly anything
        raise CheckpointError(f"{path} is not a readable trial checkpoint: {type(error).__name__}: {error}") from None
    for name in names:
        value = extra.get(name)
        if value is None:
            value = _resolve(name)
            if value is None or not allowed_global(name, value):
                raise CheckpointError(f"{path} names {name!r}, which a trial checkpoint may not hold: not loaded")
        allowed.append(value)
    try:
        with torch.serialization.safe_globals(allowed):
            content = torch.load(io.BytesIO(archive), weights_only=True)
    except Exception as error:
        raise CheckpointError(f"{path} is not a readable trial checkpoint: {type(error).__name__}: {error}") from None
    for optimizer in _optimizers(content):
        optimizer.state = defaultdict(dict, optimizer.state)
    return content


def _optimizers(root: Any) -> list[Any]:
    """The torch optimisers reachable from ``root`` through the attributes of this package's objects."""
    import torch

    found, pending, seen = [], [root], set()
    while pending:
        item = pending.pop()
        if id(item) in seen:
            continue
        seen.add(id(item))
        if isinstance(item, torch.optim.Optimizer):
            found.append(item)
        elif isinstance(item, list | tuple):
            pending.extend(item)
        elif isinstance(item, dict):
            pending.extend(item.values())
        elif type(item).__module__.startswith("antmaze_hirl.") and hasattr(item, "__dict__"):
            pending.extend(vars(item).values())
    return found


def _resolve(name: str) -> Any:
    """The object ``module.qualname`` names, importing only modules of allowed packages; ``None`` if none."""
    for split in range(len(name.split(".")) - 1, 0, -1):  # nested classes: the module is a prefix of the name
        module_name, qualname = ".".join(name.split(".")[:split]), ".".join(name.split(".")[split:])
        allowed_module = module_name.startswith(("antmaze_hirl.", "numpy", "torch", "collections", "builtins"))
        if not allowed_module:
            return None
        try:
            value: Any = importlib.import_module(module_name)
        except ImportError:
            continue
        try:
            for part in qualname.split("."):
                value = getattr(value, part)
        except AttributeError:
            return None
        return value
    return None
