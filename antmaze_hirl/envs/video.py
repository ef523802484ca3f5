"""Videos of high-level episodes that show every low-level step: :class:`RecordLowLevelVideo`.

A high-level env made with ``render_mode="rgb_array_list"`` draws one frame at the reset and one after every
low-level step (:mod:`antmaze_hirl.envs.rendering`). Gymnasium's ``RecordVideo`` asks for frames once per
``step`` and, when ``render()`` returns a list, keeps only its last frame in the video (gymnasium 1.x's
``_capture_frame``): one frame per subgoal. :class:`RecordLowLevelVideo` keeps the whole list, so the video
shows the walk::

    import gymnasium as gym
    from antmaze_hirl.envs.video import RecordLowLevelVideo

    env = gym.make("antmaze_hirl/PointMaze-5x5-v0", render_mode="rgb_array_list", render_view="trail")
    env = RecordLowLevelVideo(env, "videos", episode_trigger=lambda episode: True)

Writing the file needs MoviePy (``pip install "antmaze_hirl[video]"``), as for ``RecordVideo``.
"""

from __future__ import annotations

from gymnasium.wrappers import RecordVideo


class RecordLowLevelVideo(RecordVideo):
    """``gymnasium.wrappers.RecordVideo`` that records every frame a list-rendering env drew since its last step.

    Same arguments as ``RecordVideo``; ``video_length`` counts frames (low-level steps), and ``fps`` defaults to
    the env's ``render_fps``, so pass e.g. ``fps=30`` for a walk at a watchable speed.
    """

    def _capture_frame(self) -> None:
        frames = self.env.render()
        if isinstance(frames, list):
            self.recorded_frames.extend(frames)  # all of them: RecordVideo keeps only frames[-1]
            return
        self.recorded_frames.append(frames)
