"""Records an env's constructor arguments for ``EzPickle`` from the constructor's own parameters.

The maze envs are rebuilt from what they record: a pickle, and :func:`~antmaze_hirl.envs.vector.copies_of`
(the lockstep copies) call ``type(env)(*env._ezpickle_args, **env._ezpickle_kwargs)``. Listing the parameters a
second time by hand lets a new one be left out of the copies; reading them from ``locals()`` lists them once.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Mapping, Sequence
from functools import cache
from typing import Any

from gymnasium.utils.ezpickle import EzPickle

_NOT_ARGUMENTS = frozenset({"self", "__class__"})


def record_constructor_arguments(
    env: EzPickle,
    parameters: Mapping[str, Any],
    constructor: Callable[..., Any],
    positional: Sequence[str] = ("body", "maze_map"),
) -> None:
    """Calls ``EzPickle.__init__`` on ``env`` with every constructor parameter in ``parameters``.

    ``parameters`` must be the constructor's ``locals()`` read before it binds any other name, so that it holds
    exactly the parameters (and ``self``, which is left out). ``constructor`` is the class whose ``__init__``
    makes the call, named explicitly: a subclass's ``type(env)`` has another signature. The names in
    ``positional`` are recorded as positional arguments, in that order (``env._ezpickle_args``); all others by
    keyword (``env._ezpickle_kwargs``), in the signature's order.

    Raises:
        ValueError: If the names in ``parameters`` are not ``constructor``'s parameters (a call made after the
            constructor bound another name, or with another class), naming the difference.
        KeyError: If a name in ``positional`` is not among ``parameters``.
    """
    keywords = {name: value for name, value in parameters.items() if name not in _NOT_ARGUMENTS}
    expected = _parameter_names(constructor)
    if set(keywords) != expected:
        extra, missing = sorted(set(keywords) - expected), sorted(expected - set(keywords))
        raise ValueError(
            f"record_constructor_arguments for {constructor.__name__}: not its parameters: extra {extra}, "
            f"missing {missing} (call it first in __init__, with locals())"
        )
    arguments = tuple(keywords.pop(name) for name in positional)
    EzPickle.__init__(env, *arguments, **keywords)


@cache
def _parameter_names(constructor: Callable[..., Any]) -> frozenset[str]:
    return frozenset(inspect.signature(constructor).parameters)
