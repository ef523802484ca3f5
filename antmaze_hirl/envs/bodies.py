"""The bodies (ant, point) and their fixed facts: plain data, importable without MuJoCo (the CLI's choices).

The values live in :mod:`antmaze_hirl.envs.profiles`, the package's one home for fixed facts; this module
names the body-level part of them for the many modules that import it.
"""

from __future__ import annotations

from antmaze_hirl.envs.profiles import BODY_SPECS, Body, BodySpec, body_spec

__all__ = ["BODY_SPECS", "Body", "BodySpec", "body_spec"]
