"""Deprecated: split into :mod:`antmaze_hirl.sb3_ext.loading` and :mod:`antmaze_hirl.sb3_ext.shipped`.

"Policy" meant three things (the shipped weights in ``antmaze_hirl/policies/``, this loader, and the
high-level policy in ``dagger``); the loader now has a name of its own. This module will be removed.
"""

from __future__ import annotations

import warnings

from antmaze_hirl.sb3_ext.loading import load_low_level, policy_fingerprint, save_policy
from antmaze_hirl.sb3_ext.shipped import load_shipped_policy, shipped_policy_path

warnings.warn(
    "antmaze_hirl.sb3_ext.policies is deprecated: import from antmaze_hirl.sb3_ext.loading (load_low_level, "
    "save_policy, policy_fingerprint) or antmaze_hirl.sb3_ext.shipped (shipped_policy_path, load_shipped_policy)",
    DeprecationWarning,
    stacklevel=2,
)

__all__ = ["load_low_level", "load_shipped_policy", "policy_fingerprint", "save_policy", "shipped_policy_path"]
