"""Keeps gymnasium-robotics' unrelated AdroitHand notice off every antmaze_hirl command's output.

gymnasium-robotics 1.4.2 prints (``print`` to stderr, not ``warnings.warn``, so no warning filter can
catch it) a notice about its AdroitHand envs' rewards when it is first imported. We use none of those
envs, and the notice on every command reads like an error of ours. It comes from the
``farama_notifications`` table, so the AdroitHand entries are dropped from that table before any module
of ``antmaze_hirl.envs`` imports gymnasium-robotics; other notices still print.
"""

from __future__ import annotations


def drop_adroit_notice() -> None:
    """Removes gymnasium-robotics' AdroitHand entries from ``farama_notifications`` (no-op without it)."""
    try:
        from farama_notifications import notifications
    except ImportError:  # an optional dependency of gymnasium: then there is no notice to drop
        return
    robotics = notifications.get("gymnasium_robotics", {})
    for version in [version for version, message in robotics.items() if "AdroitHand" in str(message)]:
        del robotics[version]


drop_adroit_notice()
