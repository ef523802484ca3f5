"""The trained planning learners shipped in ``antmaze_hirl/learners/``, one per body.

Each is the ``next_cell_plan`` learner (:data:`~antmaze_hirl.experiments.config.LEARNERS`, ``any_map``)
trained by plain DAgger with the scripted oracle on its body's random family's ``train`` part until about 300
labels, by ``scripts/train_shipped_learner.py``, whose command, label count and fingerprint sit beside the
weights in ``antmaze_hirl/learners/<body>_plan.json``. Its weights act on any map
(:meth:`~antmaze_hirl.dagger.high_level_policy.HighLevelPolicy.on_map`), so it scores on every suite of its body,
zero-shot where the suite's map was never trained on::

    from antmaze_hirl.dagger import load_shipped_learner
    learner = load_shipped_learner("ant")  # then learner.predict(observation) -> xy subgoal, metres

or ``antmaze-hirl benchmark large --policy planner``.
"""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from antmaze_hirl.dagger.high_level_policy import HighLevelPolicy
from antmaze_hirl.envs.profiles import body_spec


def shipped_learner_path(body: str) -> Path:
    """Path of the planning learner shipped for ``body`` (``antmaze_hirl/learners/<body>_plan.zip``).

    Raises:
        ValueError: If ``body`` is not a known body.
    """
    body_spec(body)
    return Path(str(resources.files("antmaze_hirl").joinpath("learners", f"{body}_plan.zip")))


def shipped_learner_record(body: str) -> dict[str, Any]:
    """How the shipped learner of ``body`` was made: command, labels, episodes, seconds, fingerprint.

    Raises:
        ValueError: If ``body`` is unknown or no learner ships for it.
    """
    record = shipped_learner_path(body).with_suffix(".json")
    if not record.is_file():
        raise ValueError(f"no planning learner ships for the {body} body ({record} is missing)")
    return json.loads(record.read_text())


def load_shipped_learner(body: str, *, rng: np.random.Generator | None = None) -> HighLevelPolicy:
    """The planning learner shipped for ``body``, on the maps of its training family (move it with ``on_map``).

    Raises:
        ValueError: If ``body`` is unknown or no learner ships for it.
    """
    path = shipped_learner_path(body)
    if not path.is_file():
        raise ValueError(f"no planning learner ships for the {body} body ({path} is missing)")
    return HighLevelPolicy.load(path, rng=rng)
