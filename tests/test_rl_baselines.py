"""scripts/rl_baselines.py: the flat goal env, the final-goal scoring policy, and the wall-time cap's record."""

import argparse
import json

import numpy as np
import pytest
import torch
from gymnasium.utils.env_checker import check_env
from script_helpers import load_script

from antmaze_hirl.envs.state_layout import STATE_LAYOUT

pytestmark = pytest.mark.integration  # a lab check (scripts/rl_baselines.py): the integration tier

rl_baselines = load_script("scripts/rl_baselines.py")


def test_the_flat_env_is_a_goal_env_whose_goal_is_the_final_goal():
    env = rl_baselines.FlatMazeEnv()
    check_env(env, skip_render_check=True)
    obs, _ = env.reset(seed=0)
    np.testing.assert_array_equal(obs["desired_goal"], env.high.goal_xy)  # the task's goal, not a nearby subgoal
    assert env.high.layout.walls.shape == (7, 7)  # a 5x5 maze of the train part
    reward = env.compute_reward(obs["desired_goal"][None], obs["desired_goal"][None], [{}])
    assert reward.tolist() == [1.0]
    steps = 0
    truncated = terminated = False
    while not (terminated or truncated):
        obs, _, terminated, truncated, _ = env.step(np.zeros(2))
        steps += 1
    assert truncated and steps == rl_baselines.FLAT_STEPS  # a still body never reaches a goal >= 3 cells away
    env.close()


def test_the_final_goal_policy_proposes_the_goal():
    state = np.zeros(6, dtype=np.float32)
    state[STATE_LAYOUT.goal_slice] = (1.5, -2.0)
    assert rl_baselines.FinalGoalPolicy()({"state": state}).tolist() == [1.5, -2.0]


def test_the_wall_time_cap_stops_training_and_the_record_gives_the_steps_reached(tmp_path):
    args = argparse.Namespace(
        algo="ppo", body="point", steps=10_000, max_minutes=1e-9, num_envs=2, seed=0, command="python scripts/x"
    )
    record = rl_baselines.train(args, tmp_path / "m.zip", tmp_path / "m.training.json")
    assert record["stopped_by"] == "wall-time cap"
    # The cap cut the first rollout after one vector step of 2 mazes: never trained on, so not counted.
    assert record["steps_reached"] == 0 and record["steps_dropped"] == 2
    assert json.loads((tmp_path / "m.training.json").read_text()) == record
    assert (tmp_path / "m.zip").is_file()


def _args(algo, steps, **overrides):
    """The script's arguments for a short test run; ``overrides`` replace or add keys."""
    defaults = {
        "algo": algo,
        "body": "point",
        "steps": steps,
        "max_minutes": 60.0,
        "num_envs": 2,
        "seed": 0,
        "checkpoint_every": 4,
        "resume": True,
        "command": "python scripts/rl_baselines.py",
    }
    return argparse.Namespace(**{**defaults, **overrides})


@pytest.fixture
def small_settings(monkeypatch):
    """PPO rollouts of 2 steps per maze (4 of 2 mazes) and SAC learning from its first step: seconds of training."""
    monkeypatch.setitem(rl_baselines.SETTINGS, "ppo", {"n_steps": 2, "batch_size": 4, "n_epochs": 1})
    monkeypatch.setitem(rl_baselines.SETTINGS, "sac", {"buffer_size": 100, "learning_starts": 0, "batch_size": 8})


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_a_run_checkpoints_and_a_resumed_run_continues_from_the_last_checkpoint(tmp_path, algo, small_settings):
    model_path = tmp_path / "m.zip"
    first = rl_baselines.train(_args(algo, 8), model_path, tmp_path / "m.training.json")
    folder = rl_baselines.checkpoint_folder(model_path)
    assert first["steps_reached"] == 8 and first["resumed_at"] == []
    assert sorted(path.name for path in folder.glob("*.zip")) == ["4.zip", "8.zip"]  # every 4 steps of 2 mazes
    assert json.loads((folder / "latest.json").read_text())["model"] == "8.zip"
    buffers = sorted(path.name for path in folder.glob("replay_buffer*.pkl"))
    assert buffers == (["replay_buffer_8.pkl"] if algo == "sac" else [])  # the latest one only, the 4-step one gone
    assert json.loads((folder / "latest.json").read_text()).get("replay_buffer") == (buffers or [None])[0]
    saved = (rl_baselines.PPO if algo == "ppo" else rl_baselines.SAC).load(folder / "8.zip", device="cpu")
    restored, _ = rl_baselines.resume_model(_args(algo, 16), folder)
    for name, tensor in saved.policy.state_dict().items():  # the resumed model is the checkpoint's, not a new one
        assert torch.equal(tensor, restored.policy.state_dict()[name]), name
    if algo == "sac":  # the buffer holds every one of the 8 steps counted (4 vector steps of 2 mazes), no fewer
        assert restored.replay_buffer.size() * restored.n_envs == 8
    restored.get_env().close()
    second = rl_baselines.train(_args(algo, 16), model_path, tmp_path / "m.training.json")
    assert second["steps_reached"] == 16 and second["resumed_at"] == [8]  # 8 more steps, not 16 from scratch
    assert second["training_seconds"] > first["training_seconds"]  # seconds add up over the runs
    model = (rl_baselines.PPO if algo == "ppo" else rl_baselines.SAC).load(model_path, device="cpu")
    assert model.num_timesteps == 16


@pytest.mark.parametrize(("algo", "expected"), [("ppo", [4, 8]), ("sac", [4, 6, 8])])
def test_checkpoints_are_taken_at_rollout_starts(tmp_path, algo, expected, small_settings, monkeypatch):
    # Every 3 steps: PPO's rollouts are 4 steps (2 per maze), so at rollout starts it can checkpoint only at 4
    # and at the end (8), never mid-rollout at 6; SAC's are one vector step (2), so 4, 6 and the end.
    seen = []
    save = rl_baselines.Checkpoints.save

    def spy(checkpoints):
        model = checkpoints.model
        buffer = getattr(model, "replay_buffer", None)
        seen.append((model.num_timesteps, None if buffer is None else buffer.size() * model.n_envs))
        return save(checkpoints)

    monkeypatch.setattr(rl_baselines.Checkpoints, "save", spy)
    args = _args(algo, 8, checkpoint_every=3)
    rl_baselines.train(args, tmp_path / "m.zip", tmp_path / "r.json")
    folder = rl_baselines.checkpoint_folder(tmp_path / "m.zip")
    assert sorted(int(path.stem) for path in folder.glob("*.zip")) == expected
    # SAC's buffer holds every transition its checkpoint counts (on a step, it would lack the step's own).
    assert all(stored in (None, steps) for steps, stored in seen), seen


def test_resuming_a_finished_run_trains_nothing_and_keeps_its_record(tmp_path, small_settings):
    model_path = tmp_path / "m.zip"
    first = rl_baselines.train(_args("ppo", 8), model_path, tmp_path / "r.json")
    stamp = (tmp_path / "r.json").stat().st_mtime_ns, model_path.stat().st_mtime_ns
    other_cap = _args("ppo", 8, max_minutes=5.0)
    again = rl_baselines.train(other_cap, model_path, tmp_path / "r.json")
    assert again == first  # the run's own record, not one rebuilt from this call's arguments
    assert ((tmp_path / "r.json").stat().st_mtime_ns, model_path.stat().st_mtime_ns) == stamp  # nothing rewritten
    latest = json.loads((rl_baselines.checkpoint_folder(model_path) / "latest.json").read_text())
    assert latest["training_seconds"] == first["training_seconds"]  # the record and its checkpoint agree


def test_a_fresh_run_refuses_a_folder_holding_another_runs_checkpoints(tmp_path, small_settings, capsys):
    model_path = tmp_path / "m.zip"
    rl_baselines.train(_args("ppo", 8), model_path, tmp_path / "r.json")
    fresh = _args("ppo", 4, resume=False)
    with pytest.raises(rl_baselines.StaleCheckpoints, match="m_checkpoints holds another run's checkpoints"):
        rl_baselines.train(fresh, model_path, tmp_path / "r.json")
    leftovers = rl_baselines.checkpoint_folder(tmp_path / "out" / "point5_ppo_seed0.zip")
    leftovers.mkdir(parents=True)
    (leftovers / "4.zip").write_bytes(b"")  # a kill before latest.json: --resume has nothing to resume either
    for extra in ([], ["--resume"]):
        with pytest.raises(SystemExit) as stop:
            rl_baselines.main(["--algo", "ppo", "--out", str(tmp_path / "out"), *extra])
        assert stop.value.code == 2
        error = capsys.readouterr().err.strip().splitlines()[-1]
        assert "point5_ppo_seed0_checkpoints holds another run's checkpoints (4.zip)" in error


def test_report_names_carry_the_seed():
    assert rl_baselines.report_name("point", "flat-sac-her", 3, 4_514) == "point5_flat_sac_her_rl_s3.json"
    assert rl_baselines.report_name("ant", "ppo", 0, 0) == "ant4_ppo_rl_s0_untrained.json"
    assert rl_baselines.report_name("point", "sac", 1, 50, "_at_25000") == "point5_sac_rl_s1_at_25000.json"


def test_every_checkpoint_short_of_the_final_model_is_scored_at_its_own_steps(tmp_path, small_settings, monkeypatch):
    model_path = tmp_path / "m.zip"
    record = rl_baselines.train(_args("ppo", 12), model_path, tmp_path / "r.json")
    scored = []
    monkeypatch.setattr(rl_baselines, "score", lambda args, path, at, suffix: scored.append((path.name, at, suffix)))
    capped = {**record, "steps_dropped": 2}  # as if the cap had cut the final run's last rollout
    rl_baselines.score_checkpoints(_args("ppo", 12), model_path, capped)
    assert [(name, suffix) for name, _, suffix in scored] == [("4.zip", "_at_4"), ("8.zip", "_at_8")]
    assert [at["steps_reached"] for _, at, _ in scored] == [4, 8] and all("steps" not in at for _, at, _ in scored)
    assert [at["steps_dropped"] for _, at, _ in scored] == [0, 0]  # the final run's cut is not a checkpoint's


def test_a_checkpoint_is_reported_with_the_run_that_trained_it(tmp_path, small_settings, monkeypatch):
    model_path = tmp_path / "m.zip"
    first_run = "python scripts/rl_baselines.py --max-minutes 60"
    rl_baselines.train(_args("ppo", 8, command=first_run), model_path, tmp_path / "r.json")
    resumed = _args("ppo", 16, max_minutes=30.0, command=f"{first_run[:-2]}30 --resume")
    record = rl_baselines.train(resumed, model_path, tmp_path / "r.json")
    folder = rl_baselines.checkpoint_folder(model_path)
    for step in (4, 12):  # as checkpoints were written before they recorded their run
        old = json.loads((folder / f"{step}.json").read_text())
        del old["command"], old["max_minutes"]
        (folder / f"{step}.json").write_text(json.dumps(old))
    scored = {}
    monkeypatch.setattr(rl_baselines, "score", lambda args, path, at, suffix: scored.update({path.stem: at}))
    rl_baselines.score_checkpoints(_args("ppo", 16, max_minutes=5.0), model_path, record)
    assert sorted(scored, key=int) == ["4", "8", "12"]
    assert (scored["8"]["command"], scored["8"]["max_minutes"]) == (first_run, 60.0)  # not the resume's 30
    assert (scored["12"]["command"], scored["12"]["max_minutes"]) == (f"{first_run[:-2]}30 --resume", 30.0)
    # Unrecorded: 4 is the first run's, so unknown; 12 is past the resume at 8, so the final run's.
    assert scored["4"]["command"] is None and scored["4"]["command_note"] == rl_baselines.UNRECORDED_RUN
    assert scored["12"]["command"] == record["command"] and "command_note" not in scored["12"]
    assert record["command"].endswith("--max-minutes 30 --resume")  # the final model's run


def test_a_record_written_after_a_kill_names_the_run_that_trained_the_model(tmp_path, small_settings, monkeypatch):
    model_path, record_path = tmp_path / "m.zip", tmp_path / "r.json"
    first_run = "python scripts/rl_baselines.py --max-minutes 60"
    trained = rl_baselines.train(_args("ppo", 8, command=first_run), model_path, record_path)
    record_path.unlink(), model_path.unlink()  # killed after its last checkpoint, before its model and record
    resumed = _args("ppo", 8, max_minutes=5.0, command="python scripts/rl_baselines.py --max-minutes 5 --resume")
    record = rl_baselines.train(resumed, model_path, record_path)
    assert (record["command"], record["max_minutes"]) == ("python scripts/rl_baselines.py --max-minutes 60", 60.0)
    assert record == trained and json.loads(record_path.read_text()) == trained  # as the killed run would have
    assert model_path.is_file()


def test_the_record_names_mains_argv_not_the_processs(tmp_path, small_settings, monkeypatch):
    monkeypatch.setattr(rl_baselines.sys, "argv", ["pytest", "-q"])
    monkeypatch.setattr(rl_baselines, "score", lambda args, path, record: None)
    argv = ["--algo", "ppo", "--steps", "0", "--num-envs", "2", "--out", str(tmp_path)]
    assert rl_baselines.main(argv) == 0
    record = json.loads((tmp_path / "point5_ppo_seed0_untrained.training.json").read_text())
    assert record["command"] == "python scripts/rl_baselines.py " + " ".join(argv)


def test_flat_sac_her_resumes_with_its_her_buffer(tmp_path, monkeypatch):
    # Collection only (learning would start after a whole 500-step episode): the HER buffer is what resumes.
    settings = {**rl_baselines.SETTINGS["flat-sac-her"], "buffer_size": 1_000, "learning_starts": 10_000}
    monkeypatch.setitem(rl_baselines.SETTINGS, "flat-sac-her", settings)
    model_path = tmp_path / "flat.zip"
    rl_baselines.train(_args("flat-sac-her", 8), model_path, tmp_path / "r.json")
    folder = rl_baselines.checkpoint_folder(model_path)
    restored, latest = rl_baselines.resume_model(_args("flat-sac-her", 16), folder)
    assert latest["replay_buffer"] == "replay_buffer_8.pkl"
    assert isinstance(restored.replay_buffer, rl_baselines.HerReplayBuffer) and restored.replay_buffer.size() == 8
    restored.get_env().close()
    second = rl_baselines.train(_args("flat-sac-her", 16), model_path, tmp_path / "r.json")
    assert second["steps_reached"] == 16 and second["resumed_at"] == [8]


def test_tensorboard_logs_the_training_run(tmp_path, small_settings):
    args = _args("ppo", 8, tensorboard=str(tmp_path / "tb"))
    rl_baselines.train(args, tmp_path / "m.zip", tmp_path / "r.json")
    assert list((tmp_path / "tb").rglob("events.out.tfevents.*"))


def test_the_ant_baselines_train_on_the_ant_family_and_score_on_its_suite():
    assert rl_baselines.SUITES == {"point": "point5", "ant": "ant4"}
    env = rl_baselines.FlatMazeEnv("ant")
    env.reset(seed=0)
    assert env.high.layout.walls.shape == (6, 6)  # a 4x4 maze of the ant family's train part
    assert env.action_space.shape == (8,)  # the ant's eight joints, driven directly
    env.close()


def test_a_flipped_ant_ends_its_flat_episode_as_a_failure():
    env = rl_baselines.FlatMazeEnv("ant")
    env.reset(seed=0)
    data = env.reach.sim.data
    data.qpos[2], data.qpos[3:7] = 0.6, (0.0, 1.0, 0.0, 0.0)  # the torso turned half over about x: on its back
    data.qvel[:] = 0.0
    _, _, terminated, truncated, info = env.step(np.zeros(8))
    assert info["flipped"] and terminated and not truncated and not info["is_success"]
    env.close()
