"""Rendering high-level episodes: the unchanged schematic, one frame per low-level step, the trail, MuJoCo's camera."""

import itertools
import sys
import textwrap

import gymnasium as gym
import numpy as np
import pytest
from egl_helpers import run_under_egl

from antmaze_hirl.envs.rendering import SUBGOAL_RGB, TRAIL_RGB, RenderUnavailable
from antmaze_hirl.experts import PathOracle

SUITE_ID = "antmaze_hirl/PointMaze-5x5-v0"


def play_oracle_episode(env, *, collect=True):
    """Plays task 0 with the oracle; returns the frames render() gave after the reset and every step, and the info.

    With ``collect=False`` nobody calls render() here (a recording wrapper does), and the frames are ``None``.
    """
    oracle = PathOracle.for_env(env)
    obs, _ = env.reset(seed=0, options={"task_id": 0})
    frames = list(env.render()) if collect else None
    done = False
    while not done:
        obs, _, terminated, truncated, info = env.step(oracle(obs))
        if collect:
            frames += env.render()
        done = terminated or truncated
    return frames, info


def test_the_default_picture_is_the_schematic_it_always_was():
    env = gym.make(SUITE_ID, render_mode="rgb_array")
    env.reset(seed=0, options={"task_id": 3})
    inner = env.unwrapped
    expected = inner.renderer.rgb(inner.layout.walls, inner.agent_xy, inner.goal_xy)
    np.testing.assert_array_equal(env.render(), expected)
    env.close()


@pytest.fixture(scope="module")
def trail_episode():
    """Task 0 played once by the oracle with the trail view: the frames (read only) and the last info."""
    env = gym.make(SUITE_ID, render_mode="rgb_array_list", render_view="trail")
    frames, info = play_oracle_episode(env)
    env.close()
    for frame in frames:
        frame.flags.writeable = False  # shared by the tests below
    return frames, info


def test_a_rendered_high_level_episode_has_one_frame_per_low_level_step(trail_episode):
    frames, info = trail_episode
    assert info["is_success"] and info["attempts"] > 1
    assert len(frames) == info["total_low_level_steps"] + 1  # the reset's frame, then one per low-level step
    assert all(frame.dtype == np.uint8 and frame.shape == frames[0].shape and frame.shape[2] == 3 for frame in frames)
    moved = sum(not np.array_equal(before, after) for before, after in itertools.pairwise(frames))
    assert moved > len(frames) // 2  # the body walks between frames


def test_the_trail_view_draws_the_path_and_the_current_subgoal(trail_episode):
    frames, _ = trail_episode

    def count(frame, colour):
        return int(np.all(frame == colour, axis=-1).sum())

    assert count(frames[0], TRAIL_RGB) == 0 and count(frames[0], SUBGOAL_RGB) == 0  # nothing walked, no subgoal yet
    assert count(frames[-1], TRAIL_RGB) > count(frames[len(frames) // 4], TRAIL_RGB) > 0  # the path grows
    assert count(frames[-1], SUBGOAL_RGB) > 0


def test_list_mode_hands_each_frame_out_once_and_a_reset_starts_afresh():
    env = gym.make(SUITE_ID, render_mode="rgb_array_list")
    env.reset(seed=1, options={"task_id": 1})
    assert len(env.render()) == 1 and env.render() == []
    _, _, _, _, info = env.step(env.unwrapped.goal_xy)
    assert len(env.render()) == info["low_level_steps"]
    env.reset(seed=2, options={"task_id": 2})
    assert len(env.render()) == 1
    env.close()


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"render_view": "3d"}, r"render_view must be one of \['schematic', 'trail', 'mujoco'\], got '3d'"),
        ({"render_mode": "human"}, r"render_mode must be None, 'rgb_array' or 'rgb_array_list', got 'human'"),
    ],
)
def test_an_unknown_view_or_mode_is_refused_naming_it(kwargs, message):
    with pytest.raises(ValueError, match=message):
        gym.make(SUITE_ID, **kwargs)


def test_the_mujoco_view_without_an_opengl_backend_says_how_to_get_one(monkeypatch):
    monkeypatch.delenv("MUJOCO_GL", raising=False)
    monkeypatch.delenv("DISPLAY", raising=False)
    with pytest.raises(RenderUnavailable, match="MUJOCO_GL=egl"):
        gym.make(SUITE_ID, render_mode="rgb_array", render_view="mujoco")


def test_record_low_level_video_keeps_every_frame(monkeypatch, tmp_path):
    # A stand-in for MoviePy's writer (not installed everywhere): it receives what RecordVideo would encode.
    import types

    written = []

    class ImageSequenceClip:
        def __init__(self, frames, fps):
            written.append((len(frames), fps))

        def write_videofile(self, path, **kwargs):
            open(path, "wb").close()

    clip_module = types.ModuleType("moviepy.video.io.ImageSequenceClip")
    clip_module.ImageSequenceClip = ImageSequenceClip
    for name in ("moviepy", "moviepy.video", "moviepy.video.io"):
        monkeypatch.setitem(sys.modules, name, types.ModuleType(name))
    monkeypatch.setitem(sys.modules, "moviepy.video.io.ImageSequenceClip", clip_module)
    from antmaze_hirl.envs.video import RecordLowLevelVideo

    env = gym.make(SUITE_ID, render_mode="rgb_array_list", render_view="trail")
    env = RecordLowLevelVideo(env, str(tmp_path), episode_trigger=lambda episode: True, fps=30)
    _, info = play_oracle_episode(env, collect=False)
    env.close()
    assert written == [(info["total_low_level_steps"] + 1, 30)]


def test_record_low_level_video_writes_an_mp4_of_every_low_level_step(tmp_path):
    # The real writer: MoviePy comes with the `video` extra, which CI installs; elsewhere the reason is shown.
    pytest.importorskip("moviepy", reason="writing a video needs the video extra: pip install 'antmaze_hirl[video]'")
    import imageio.v3 as iio

    from antmaze_hirl.envs.video import RecordLowLevelVideo

    env = gym.make(SUITE_ID, render_mode="rgb_array_list", render_view="trail")
    env = RecordLowLevelVideo(env, str(tmp_path), episode_trigger=lambda episode: True, fps=30, disable_logger=True)
    _, info = play_oracle_episode(env, collect=False)
    env.close()
    (video,) = tmp_path.glob("*.mp4")
    frames = list(iio.imiter(video))
    # One frame at the reset and one per low-level step, as the writer was handed them (checked above).
    assert len(frames) == info["total_low_level_steps"] + 1
    assert frames[0].shape[-1] == 3 and not np.array_equal(frames[0], frames[-1])


@pytest.mark.slow  # a fresh interpreter per body (MuJoCo reads MUJOCO_GL at import): CI's slow tier runs it
@pytest.mark.parametrize("suite_id", [SUITE_ID, "antmaze_hirl/AntMaze-4x4-v0"])
def test_the_mujoco_view_is_an_rgb_array_where_egl_works(suite_id):
    # In a fresh interpreter: MuJoCo picks its OpenGL backend from MUJOCO_GL when it is first imported.
    script = textwrap.dedent(
        f"""
        import gymnasium as gym
        import numpy as np
        import antmaze_hirl
        from antmaze_hirl.envs.rendering import MUJOCO_FRAME_PX, RenderUnavailable
        env = gym.make({suite_id!r}, render_mode="rgb_array_list", render_view="mujoco")
        try:
            env.reset(seed=0, options={{"task_id": 0}})
            env.step(env.unwrapped.goal_xy)
            frames = env.render()
        except RenderUnavailable as error:
            print("UNAVAILABLE", error)
        else:
            assert len(frames) > 2, len(frames)
            for frame in frames:
                assert frame.dtype == np.uint8 and frame.shape == (*MUJOCO_FRAME_PX, 3), (frame.dtype, frame.shape)
            assert frames[0].std() > 10  # a picture, not a blank
            assert not np.array_equal(frames[0], frames[-1])  # the body moved
            print("FRAMES", len(frames))
        env.close()
        """
    )
    assert "FRAMES" in run_under_egl(script)


def test_the_subgoal_marker_is_small_and_faint_enough_not_to_hide_the_ant():
    import mujoco

    from antmaze_hirl.envs.simulator import MazeSimulator

    sim = MazeSimulator("ant", np.array([[1, 1, 1], [1, 0, 1], [1, 1, 1]], dtype=bool))
    model = sim._mujoco_env.model
    site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "target")
    torso = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "torso_geom")
    assert model.site_size[site, 0] < model.geom_size[torso, 0]  # gymnasium-robotics': 0.8 m, the torso 0.25 m
    assert model.site_rgba[site, 3] <= 0.5
