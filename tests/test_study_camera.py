"""The ant's camera view on the study page: a MuJoCo render where OpenGL works, a clear 404 where it does not."""

import textwrap

import pytest
from egl_helpers import run_under_egl
from study_helpers import make_tiny_study

from antmaze_hirl.study.camera import AntCamera, CameraUnavailable
from antmaze_hirl.study.plan import make_plan, save_plan
from antmaze_hirl.study.settings import StudySettings, save_settings


def test_without_an_opengl_backend_the_camera_says_how_to_get_one(monkeypatch):
    monkeypatch.delenv("MUJOCO_GL", raising=False)
    with pytest.raises(CameraUnavailable, match="MUJOCO_GL=egl"):
        AntCamera()


def test_the_point_has_no_camera_view(tmp_path):
    from antmaze_hirl.study.store import Study

    study = Study(make_tiny_study(tmp_path / "study"))
    with pytest.raises(CameraUnavailable, match="for the ant"):
        study.session("P01").camera_frame()


@pytest.mark.slow
def test_an_ant_trial_serves_a_png_camera_frame_with_egl(tmp_path):
    # In a fresh interpreter: MuJoCo picks its OpenGL backend from MUJOCO_GL when it is first imported.
    folder = tmp_path / "study"
    save_plan(make_plan("ant", ["dagger"], 1, episodes=1, practice=0, seed=0), folder)
    save_settings(StudySettings.for_body("ant", eval_every=1, eval_episodes=1, final_eval_episodes=1), folder)
    script = textwrap.dedent(
        f"""
        from antmaze_hirl.study.camera import CameraUnavailable
        from antmaze_hirl.study.store import Study
        session = Study({str(folder)!r}).session("P01")
        session.start_trial()
        assert session.state()["camera"]
        try:
            png = session.camera_frame()
        except CameraUnavailable as error:
            print("UNAVAILABLE", error)
        else:
            assert png[:8] == b"\\x89PNG\\r\\n\\x1a\\n" and len(png) > 5000, len(png)
            print("FRAME", len(png))
        session.close()
        """
    )
    assert "FRAME" in run_under_egl(script)
