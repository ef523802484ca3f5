"""The bodies (ant, point) and their fixed facts: plain data, importable without MuJoCo (the CLI's choices).

The values live in :mod:`antmaze_hirl.envs.profiles`, the package's one home for fixed facts; this module
names the body-level part of them for the many modules that import it.
"""

from __future__ import annotations

import numpy as np

from antmaze_hirl.envs.profiles import BODY_SPECS, Body, BodySpec, body_spec

__all__ = ["BODY_SPECS", "Body", "BodySpec", "body_spec", "uprightness"]


def uprightness(quaternion: np.ndarray) -> float | np.ndarray:
    """World z component of a body's up axis, ``1 - 2 (qx^2 + qy^2)``, for unit quaternions ``(qw, qx, qy, qz)``.

    One quaternion (shape ``(4,)``) gives a float; a batch (``(..., 4)``) an array of its leading shape.
    1 upright, 0 on its side, -1 on its back.
    """
    q = np.asarray(quaternion, dtype=np.float64)
    value = 1 - 2 * (q[..., 1] * q[..., 1] + q[..., 2] * q[..., 2])
    return float(value) if value.ndim == 0 else value
