"""Records an env's constructor arguments for ``EzPickle`` from the constructor's own parameters.

The maze envs are rebuilt from what they record: a pickle, and :func:`~antmaze_hirl.envs.vector.copies_of`
(the lockstep copies) call ``type(env)(*env._ezpickle_args, **env._ezpickle_kwargs)``. Listing the parameters a
second time by hand lets a new one be left out of the copies; reading them from ``locals()`` lists them once.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from gymnasium.utils.ezpickle import EzPickle

_NOT_ARGUMENTS = frozenset({"self", "__class__"})


def record_constructor_arguments(
    env: EzPickle, parameters: Mapping[str, Any], positional: Sequence[str] = ("body", "maze_map")
) -> None:
    """Calls ``EzPickle.__init__`` on ``env`` with every constructor parameter in ``parameters``.

    ``parameters`` must be the constructor's ``locals()`` read before it binds any other name, so that it holds
    exactly the parameters (and ``self``, which is left out). The names in ``positional`` are recorded as
    positional arguments, in that order (``env._ezpickle_args``); all others by keyword (``env._ezpickle_kwargs``),
    in the signature's order.

    Raises:
        KeyError: If a name in ``positional`` is not among ``parameters``.
    """
    keywords = {name: value for name, value in parameters.items() if name not in _NOT_ARGUMENTS}
    arguments = tuple(keywords.pop(name) for name in positional)
    EzPickle.__init__(env, *arguments, **keywords)
