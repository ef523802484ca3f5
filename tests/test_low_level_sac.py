"""SAC (and, with sb3-contrib installed, TQC) as the low level: training, resume, loading, configuration errors."""

import json

import gymnasium as gym
import numpy as np
import pytest
import torch as th
from stable_baselines3 import SAC

from antmaze_hirl.cli import main
from antmaze_hirl.envs.reach import ReachEnv
from antmaze_hirl.experiments.runner import low_level_identity
from antmaze_hirl.sb3_ext import load_config, make_model, train_low_level
from antmaze_hirl.sb3_ext.checkpoint import latest_checkpoint
from antmaze_hirl.sb3_ext.loading import load_low_level, policy_fingerprint
from antmaze_hirl.sb3_ext.training import algo_class

# End to end (see pyproject.toml's markers): left out of the default unit tier, run by .ci/run.
pytestmark = pytest.mark.integration

TINY = {"eval_freq": 10**9, "eval_episodes": 3, "progress_bar": False}


def tiny_config(algo="sac", **changes):
    return load_config("point", algo=algo).replace(learning_starts=100, buffer_size=5_000, batch_size=64, **changes)


def test_point_sac_trains_checkpoints_and_resumes_with_its_entropy_state(tmp_path):
    config = tiny_config()
    model = train_low_level("point", "sac", 300, tmp_path, config=config, checkpoint_freq=150, **TINY)
    assert isinstance(model, SAC) and model.num_timesteps == 300 and model.action_noise is None
    _, state = latest_checkpoint(tmp_path / "checkpoints", expected={"algo": "sac", "config": config.to_dict()})
    assert state["num_timesteps"] == 300 and state["config"]["ent_coef"] == "auto"
    # The temperature is learnt ("auto"): it moved, and the resumed run starts from the saved one.
    log_alpha = model.log_ent_coef.detach().clone()
    assert float(log_alpha) != 0.0
    resumed = train_low_level("point", "sac", 300, tmp_path, config=config, resume=True, checkpoint_freq=150, **TINY)
    assert policy_fingerprint(resumed) == policy_fingerprint(model)
    assert th.equal(resumed.log_ent_coef.detach(), log_alpha)
    assert resumed.replay_buffer.size() == 300
    resumed = train_low_level("point", "sac", 400, tmp_path, config=config, resume=True, checkpoint_freq=150, **TINY)
    assert resumed.num_timesteps == 400
    with pytest.raises(Exception, match="made with algo='sac', this run has 'td3'"):
        train_low_level("point", "td3", 500, tmp_path, config=tiny_config("td3"), resume=True, **TINY)


def test_a_saved_sac_low_level_loads_like_td3s_acts_deterministically_and_drives_the_maze(tmp_path):
    model = make_model("point", "sac", tiny_config(), seed=0)
    model.learn(200)
    model.save(tmp_path / "sac.zip")
    loaded = load_low_level("point", tmp_path / "sac.zip")
    assert isinstance(loaded, SAC) and policy_fingerprint(loaded) == policy_fingerprint(model)
    assert low_level_identity("point", loaded) == f"sha256:{policy_fingerprint(model)}"
    obs, _ = ReachEnv("point").reset(seed=0)
    actions = [loaded.predict(obs, deterministic=True)[0] for _ in range(3)]
    assert all(np.array_equal(actions[0], action) for action in actions)  # the Gaussian's mean, not a sample
    env = gym.make("antmaze_hirl/PointMaze-v0", maze_size=3, low_level=loaded)
    obs, _ = env.reset(seed=0)
    _, _, _, _, info = env.step(obs["state"][:2] + np.array([0.5, 0.0], dtype=np.float32))
    assert info["low_level_steps"] >= 1 and len(info["agent_path"]) == info["low_level_steps"] + 1
    env.close()


def test_td3_config_keys_and_checkpoints_stay_as_before_sac():
    # A TD3 checkpoint stores config.to_dict(); new SAC keys in it would fail every older run's --resume.
    td3 = load_config("ant").to_dict()
    assert "algo" not in td3 and {"action_l2", "action_noise_std"} <= set(td3)
    assert not {"ent_coef", "target_entropy", "target_update_interval", "n_quantiles"} & set(td3)
    sac = load_config("ant", algo="sac")
    assert sac.action_l2 == 0.0 and "action_l2" not in sac.to_dict()  # the shipped TD3 penalty is left out


def test_bad_sac_hyperparameters_give_one_line_errors(tmp_path, capsys):
    overrides = tmp_path / "mine.yml"
    overrides.write_text("point:\n  action_noise_std: 0.3\n")
    message = "sets action_noise_std, a td3/ddpg key that --algo sac does not use"
    with pytest.raises(ValueError, match=message):
        load_config("point", overrides, algo="sac")
    with pytest.raises(SystemExit):
        main(f"train-low --body point --algo sac --timesteps 10 --out {tmp_path} --hyperparams {overrides}".split())
    error = capsys.readouterr().err
    assert message in error and error.count("\n") == 1
    overrides.write_text("point:\n  ent_coef: 0.1\n")
    with pytest.raises(ValueError, match="sets ent_coef, a sac/tqc key that --algo td3 does not use"):
        load_config("point", overrides)
    overrides.write_text("point:\n  algo: sac\n")
    with pytest.raises(ValueError, match=r"unknown keys \['algo'\]"):
        load_config("point", overrides, algo="sac")
    with pytest.raises(ValueError, match="ent_coef must be 'auto', 'auto_<initial value>' or a float > 0, got 'atuo'"):
        tiny_config(ent_coef="atuo")
    with pytest.raises(ValueError, match="target_entropy must be 'auto' or a float, got 'low'"):
        tiny_config(target_entropy="low")
    with pytest.raises(ValueError, match="action_l2 is a td3/ddpg key; sac does not use it"):
        tiny_config(action_l2=1.0)  # TD3's critic carries the penalty; SAC's actor loss never calls q1_forward
    with pytest.raises(ValueError, match=r"the config is for td3, not sac: load it with load_config\(body, ..."):
        make_model("point", "sac", load_config("point"), seed=0)
    assert tiny_config(ent_coef="auto_0.1", target_entropy=-1.0).ent_coef == "auto_0.1"


def test_sac_refuses_a_td3_warm_start(tmp_path):
    make_model("point", "td3", tiny_config("td3"), seed=0).save(tmp_path / "td3.zip")
    with pytest.raises(ValueError, match="holds a TD3 policy; --algo sac cannot start from it"):
        train_low_level("point", "sac", 10, tmp_path / "run", config=tiny_config(), init_from=tmp_path / "td3.zip")


def test_tqc_trains_and_loads_when_sb3_contrib_is_installed(tmp_path):
    try:
        import sb3_contrib
    except ImportError:
        with pytest.raises(ValueError, match=r"--algo tqc needs sb3-contrib: pip install 'antmaze_hirl\[tqc\]'"):
            algo_class("tqc")
        pytest.skip("sb3-contrib is not installed: its error is checked")
    config = tiny_config("tqc", n_quantiles=5, top_quantiles_to_drop_per_net=1)
    model = train_low_level("point", "tqc", 200, tmp_path, config=config, checkpoint_freq=10**9, **TINY)
    assert isinstance(model, sb3_contrib.TQC) and model.critic.n_quantiles == 5
    assert json.loads((tmp_path / "checkpoints" / "ckpt-200" / "state.json").read_text())["algo"] == "tqc"
    assert isinstance(load_low_level("point", tmp_path / "policy.zip"), sb3_contrib.TQC)
