"""Fine-tuning hooks (antmaze_hirl.sb3_ext.warm_start): policy-driven warm-up, a critic-only start, resume."""

import csv
import pickle

import gymnasium as gym
import numpy as np
import pytest
import torch as th
from stable_baselines3 import DDPG, SAC, TD3
from stable_baselines3.common.logger import configure
from stable_baselines3.common.noise import ActionNoise

from antmaze_hirl.sb3_ext import CheckpointError, load_config, make_model, save_policy, train_low_level, warm_start
from antmaze_hirl.sb3_ext.warm_start import WarmStartMixin, with_warm_start

STARTS = 64  # learning_starts of the Pendulum models: warm-up steps, all in Pendulum's first 200-step episode


class BoundedNoise(ActionNoise):
    """Uniform noise in [-bound, bound]: unlike a Gaussian it has bounds an action can be checked against."""

    def __init__(self, bound, size, seed):
        super().__init__()
        self.bound, self.size, self.rng = bound, size, np.random.default_rng(seed)

    def __call__(self):
        return self.rng.uniform(-self.bound, self.bound, self.size)


def pendulum_td3(algorithm=TD3, **kwargs):
    options = {"learning_starts": STARTS, "batch_size": 32, "policy_kwargs": {"net_arch": [16, 16]}, "seed": 0}
    return with_warm_start(algorithm)("MlpPolicy", gym.make("Pendulum-v1"), verbose=0, **{**options, **kwargs})


def warmup_gaps(model):
    """|stored action - the policy's own deterministic action| at each warm-up step's observation (scaled units)."""
    model.learn(STARTS)
    assert model._n_updates == 0  # no gradient step yet: the policy that acted is the one queried here
    observations = model.replay_buffer.observations[:STARTS, 0]
    actions = model.replay_buffer.actions[:STARTS, 0]
    # One observation at a time, as the model acted: a batched forward pass may round differently.
    own = [model.policy.scale_action(model.predict(obs, deterministic=True)[0]) for obs in observations]
    return np.abs(actions - np.array(own))


def actor_tensors(model):
    return [t.clone() for t in (*model.actor.state_dict().values(), *model.actor_target.state_dict().values())]


def critic_tensors(model):
    return [t.clone() for t in (*model.critic.state_dict().values(), *model.critic_target.state_dict().values())]


def all_equal(these, those):
    return all(th.equal(a, b) for a, b in zip(these, those, strict=True))


def none_equal(these, those):
    return not any(th.equal(a, b) for a, b in zip(these, those, strict=True))


def test_policy_warmup_acts_with_the_policys_own_action_and_uniform_warmup_does_not():
    assert warmup_gaps(pendulum_td3(warmup_actions="policy", action_noise=None)).max() == 0
    noisy = warmup_gaps(pendulum_td3(warmup_actions="policy", action_noise=BoundedNoise(0.1, 1, seed=1)))
    assert noisy.max() <= 0.1 + 1e-6 and noisy.max() > 0
    # Uniform actions on [-1, 1] land within 0.1 of a given action one time in ten or less.
    assert np.mean(warmup_gaps(pendulum_td3(warmup_actions="uniform", action_noise=None)) <= 0.1) < 0.5


def test_sac_warms_up_with_its_own_sampled_actions():
    options = {"learning_starts": STARTS, "policy_kwargs": {"net_arch": [16, 16]}, "seed": 0}
    model = with_warm_start(SAC)("MlpPolicy", gym.make("Pendulum-v1"), warmup_actions="policy", **options)
    model.policy.actor.log_std.weight.data.zero_()  # a near-deterministic policy: its samples stay near its mean
    model.policy.actor.log_std.bias.data.fill_(-20.0)
    assert warmup_gaps(model).max() < 1e-4


def test_frozen_steps_train_the_critics_only_and_the_actor_afterwards():
    model = pendulum_td3(actor_frozen_steps=15)
    model.learn(STARTS)  # fills the buffer; no gradient step yet
    actor, critic = actor_tensors(model), critic_tensors(model)
    model.train(gradient_steps=15, batch_size=32)
    assert all_equal(actor_tensors(model), actor) and not model.actor.optimizer.state  # no Adam step either
    assert none_equal(critic_tensors(model), critic)  # both critics and their targets moved
    model.train(gradient_steps=6, batch_size=32)  # the boundary inside one call: steps 16-21 train the actor
    assert model._n_updates == 21 and none_equal(actor_tensors(model), actor)


@pytest.mark.parametrize(("algorithm", "frozen"), [(TD3, 15), (TD3, 16), (DDPG, 15)])
def test_the_first_actor_update_after_the_frozen_steps_moves_the_actor(algorithm, frozen):
    # The boundary exactly: train(frozen) leaves the actor as it was (an off-by-one early would move it where that
    # step is an actor update: DDPG's every step, TD3's even ones), and the next step that is an actor update
    # (TD3 updates its actor every policy_delay = 2 steps) moves it (an off-by-one late would not).
    model = pendulum_td3(algorithm, actor_frozen_steps=frozen)
    model.learn(STARTS)
    actor = actor_tensors(model)
    model.train(gradient_steps=frozen, batch_size=32)
    assert model._n_updates == frozen and all_equal(actor_tensors(model), actor) and not model.actor.optimizer.state
    next_actor_update = (frozen // model.policy_delay + 1) * model.policy_delay
    model.train(gradient_steps=next_actor_update - frozen, batch_size=32)
    assert none_equal(actor_tensors(model), actor)


def test_the_frozen_share_of_each_train_call_is_logged(tmp_path):
    model = pendulum_td3(actor_frozen_steps=20)
    model.set_logger(configure(str(tmp_path), ["csv"]))
    model.learn(STARTS)
    for step, gradient_steps in enumerate([15, 10, 4]):  # all frozen, half (steps 16-20 of 16-25), none
        model.train(gradient_steps=gradient_steps, batch_size=32)
        model.logger.dump(step)
    rows = list(csv.DictReader((tmp_path / "progress.csv").open()))
    assert [float(row["train/actor_frozen"]) for row in rows] == [1.0, 0.5, 0.0]


class OwnTD3(TD3):
    """A user's subclass of an algorithm."""


def test_warm_start_classes_pickle_by_reference():
    # pickle (and so multiprocessing, Ray) finds a class by module and name: each class lives in the module it names.
    classes = [with_warm_start(algorithm) for algorithm in (TD3, DDPG, SAC, OwnTD3)]
    assert [cls.__name__ for cls in classes] == ["WarmStartTD3", "WarmStartDDPG", "WarmStartSAC", "WarmStartOwnTD3"]
    assert classes[:3] == [warm_start.WarmStartTD3, warm_start.WarmStartDDPG, warm_start.WarmStartSAC]
    same_name = type("TD3", (TD3,), {"__module__": __name__})  # another algorithm named TD3: a name of its own
    classes.append(with_warm_start(same_name))
    assert classes[-1] is not classes[0] and issubclass(classes[-1], same_name)
    for cls in classes:
        assert pickle.loads(pickle.dumps(cls)) is cls and with_warm_start(cls.__bases__[1]) is cls


def test_options_are_checked_with_one_line_errors():
    for options, message in [
        ({"warmup_actions": "random"}, "warmup_actions must be one of"),
        ({"actor_frozen_steps": -1}, "actor_frozen_steps must be >= 0"),
        ({"actor_frozen_steps": 2.5}, "actor_frozen_steps must be (an )?int"),
    ]:
        with pytest.raises(ValueError, match=message):
            pendulum_td3(**options)
        with pytest.raises(ValueError, match=message):
            load_config("point").replace(**options)
    with pytest.raises(ValueError, match="actor_frozen_steps is for TD3/DDPG"):
        with_warm_start(SAC)("MlpPolicy", gym.make("Pendulum-v1"), actor_frozen_steps=1)
    with pytest.raises(ValueError, match="actor_frozen_steps is a td3/ddpg key"):
        load_config("point", algo="sac").replace(actor_frozen_steps=1)


def test_configs_without_the_options_keep_their_checkpoint_identity_and_sb3s_class():
    plain = load_config("point")
    assert "warmup_actions" not in plain.to_dict() and "actor_frozen_steps" not in plain.to_dict()
    assert type(make_model("point", "td3", plain, seed=0)) is TD3
    warm = plain.replace(warmup_actions="policy", actor_frozen_steps=3)
    assert warm.to_dict()["warmup_actions"] == "policy" and warm.to_dict()["actor_frozen_steps"] == 3
    model = make_model("point", "td3", warm, seed=0)
    assert isinstance(model, WarmStartMixin) and (model.warmup_actions, model.actor_frozen_steps) == ("policy", 3)


def test_a_fine_tune_resumes_with_its_options_and_a_fresh_run_refuses_them(tmp_path):
    config = load_config("point").replace(
        learning_starts=50, buffer_size=2_000, warmup_actions="policy", actor_frozen_steps=100
    )
    tiny = {"eval_freq": 10**9, "eval_episodes": 1, "progress_bar": False, "checkpoint_freq": 25}
    with pytest.raises(ValueError, match="give init_from"):
        train_low_level("point", "td3", 10, tmp_path / "fresh", config=config, **tiny)
    warm = make_model("point", "td3", load_config("point"), seed=3)
    source = save_policy(warm, tmp_path / "source.zip")
    run = tmp_path / "run"
    first = train_low_level("point", "td3", 100, run, config=config, init_from=source, **tiny)
    actor = actor_tensors(first)
    assert first._n_updates == 50 and all_equal(actor, actor_tensors(warm))
    resumed = train_low_level("point", "td3", 150, run, config=config, resume=True, **tiny)
    assert isinstance(resumed, WarmStartMixin) and (resumed.warmup_actions, resumed.actor_frozen_steps) == (
        "policy",
        100,
    )
    assert resumed._n_updates == 100 and all_equal(actor_tensors(resumed), actor)  # still frozen: 100 updates
    later = train_low_level("point", "td3", 160, run, config=config, resume=True, **tiny)
    assert none_equal(actor_tensors(later), actor)
    with pytest.raises(CheckpointError, match="config"):
        train_low_level("point", "td3", 200, run, config=config.replace(actor_frozen_steps=0), resume=True, **tiny)
