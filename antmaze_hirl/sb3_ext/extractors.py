"""Features extractors for goal-conditioned SB3 policies on the reach envs."""

from __future__ import annotations

import torch as th
from gymnasium import spaces
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor


def yaw_from_quaternion(quaternion: th.Tensor) -> th.Tensor:
    """Heading angle about z of unit quaternions ``(w, x, y, z)`` (MuJoCo order), shape ``(..., 4)``."""
    w, x, y, z = quaternion.unbind(-1)
    return th.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


class RelativeGoalExtractor(BaseFeaturesExtractor):
    """Features ``[observation, desired_goal - achieved_goal]``, optionally in the body's heading frame.

    SB3's default ``CombinedExtractor`` feeds absolute positions to the networks, which then have to
    learn the same gait anew at every place in the maze. The goal offset makes the policy translation
    invariant; rotating it by the body's yaw (``quaternion_index`` names where the torso quaternion sits
    in ``observation``) also makes it invariant to heading. Both are pure functions of the observation,
    so HER's relabelling stays exact.

    Args:
        observation_space: The reach env's ``Dict`` space.
        quaternion_index: Start of the ``(w, x, y, z)`` torso quaternion in ``observation`` (the ant: 1),
            or ``None`` to keep the offset in the world frame.
    """

    def __init__(self, observation_space: spaces.Dict, quaternion_index: int | None = None) -> None:
        observation_dim = observation_space["observation"].shape[0]
        super().__init__(observation_space, features_dim=observation_dim + 2)
        if quaternion_index is not None and not 0 <= quaternion_index <= observation_dim - 4:
            raise ValueError(f"quaternion_index {quaternion_index} does not fit an observation of {observation_dim}")
        self.quaternion_index = quaternion_index

    def forward(self, observations: dict[str, th.Tensor]) -> th.Tensor:
        """Returns the features for a batch of observations."""
        body = observations["observation"]
        offset = observations["desired_goal"] - observations["achieved_goal"]
        if self.quaternion_index is not None:
            yaw = yaw_from_quaternion(body[:, self.quaternion_index : self.quaternion_index + 4])
            cos, sin = th.cos(yaw), th.sin(yaw)
            offset = th.stack(
                [cos * offset[:, 0] + sin * offset[:, 1], -sin * offset[:, 0] + cos * offset[:, 1]], dim=1
            )
        return th.cat([body, offset], dim=1)
