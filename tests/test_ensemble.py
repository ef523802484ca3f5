"""Action ensembles of TD3 low-level policies: the mean action, one SB3 zip, loading, the CLI, bad members."""

import json

import numpy as np
import pytest
import torch as th
from stable_baselines3 import TD3
from stable_baselines3.td3.policies import Actor

from antmaze_hirl.cli import main
from antmaze_hirl.envs.reach import ReachEnv
from antmaze_hirl.experiments.runner import low_level_identity
from antmaze_hirl.sb3_ext import load_config, make_model
from antmaze_hirl.sb3_ext.ensemble import (
    BatchedMeanOfHeads,
    EnsemblePolicy,
    MeanOfHeads,
    build_ensemble,
    save_ensemble,
)
from antmaze_hirl.sb3_ext.loading import algorithm_of, load_low_level, policy_fingerprint, save_policy


def member(tmp_path, name, *, seed, algo="td3", **changes):
    """An untrained point policy saved as a zip (members differ by their initial weights)."""
    config = load_config("point", algo=algo).replace(learning_starts=100, buffer_size=1_000, **changes)
    path = tmp_path / f"{name}.zip"
    make_model("point", algo, config, seed=seed).save(path)
    return path


@pytest.fixture(scope="module")
def members(tmp_path_factory):
    """Three member zips, saved once per module (the tests only read them)."""
    folder = tmp_path_factory.mktemp("members")
    return [member(folder, f"m{seed}", seed=seed) for seed in range(3)]


def observations(count):
    env = ReachEnv("point")
    obs, _ = env.reset(seed=0)
    seen = []
    rng = np.random.default_rng(0)
    for _ in range(count):
        seen.append(obs)
        obs, *_ = env.step(rng.uniform(-1, 1, size=env.action_space.shape))
    env.close()
    return seen


@pytest.mark.parametrize("batched", [True, False])
def test_the_saved_ensemble_acts_with_the_members_mean_action_and_loads_as_td3(tmp_path, members, batched):
    path = save_ensemble(members, tmp_path / "ensemble.zip", body="point", batched_heads=batched)
    assert algorithm_of(path) is TD3
    ensemble = load_low_level("point", path)
    assert isinstance(ensemble.policy, EnsemblePolicy) and ensemble.policy.n_members == 3
    # The head layout is saved with the zip, so the loaded ensemble computes its mean as it was built.
    assert isinstance(ensemble.policy.actor.mu, BatchedMeanOfHeads if batched else MeanOfHeads)
    models = [load_low_level("point", path) for path in members]
    spread = 0.0
    for obs in observations(15):
        actions = np.array([model.predict(obs, deterministic=True)[0] for model in models])
        spread = max(spread, float(np.ptp(actions, axis=0).max()))
        np.testing.assert_allclose(ensemble.predict(obs, deterministic=True)[0], actions.mean(axis=0), atol=1e-5)
    assert spread > 0.05  # the members disagree, so the mean is not any one of them
    fingerprints = {policy_fingerprint(model) for model in models}
    assert policy_fingerprint(ensemble) not in fingerprints
    assert low_level_identity("point", ensemble) == f"sha256:{policy_fingerprint(ensemble)}"
    # The critic kept (acting never uses it) is the first member's.
    for kept, first in zip(ensemble.policy.critic.parameters(), models[0].policy.critic.parameters(), strict=True):
        assert kept.detach().equal(first.detach())


def test_member_order_changes_nothing_but_the_fingerprint_is_stable_across_saves(tmp_path, members):
    first = build_ensemble(members, body="point")
    again = load_low_level("point", save_ensemble(members, tmp_path / "again.zip", body="point"))
    assert policy_fingerprint(first) == policy_fingerprint(again)
    swapped = build_ensemble([members[1], members[0], members[2]], body="point")
    # The same mean action, but other weights per head (and critic): the order is part of the fingerprint.
    assert policy_fingerprint(swapped) != policy_fingerprint(first)
    obs = observations(1)[0]
    np.testing.assert_allclose(
        first.predict(obs, deterministic=True)[0], swapped.predict(obs, deterministic=True)[0], atol=1e-5
    )


@pytest.mark.parametrize("nested_batched", [True, False])
def test_an_ensemble_member_contributes_its_heads_in_order(tmp_path, members, nested_batched):
    nested = save_ensemble(members[:2], tmp_path / "nested.zip", body="point", batched_heads=nested_batched)
    grown = build_ensemble([members[2], nested], body="point")
    assert grown.policy.n_members == 3 and grown.policy_kwargs["n_members"] == 3
    flat = build_ensemble([members[2], members[0], members[1]], body="point")
    # Heads m2, m0, m1 in that order: the same weights as listing the three members, so the same fingerprint.
    assert policy_fingerprint(grown) == policy_fingerprint(flat)
    reloaded = load_low_level("point", save_policy(grown, tmp_path / "grown.zip"))
    single = load_low_level("point", members[2])
    for obs in observations(5):
        np.testing.assert_allclose(
            reloaded.predict(obs, deterministic=True)[0], flat.predict(obs, deterministic=True)[0], atol=1e-6
        )
    assert not np.allclose(reloaded.predict(obs, deterministic=True)[0], single.predict(obs, deterministic=True)[0])
    # A nested ensemble with differently shaped networks is still refused, naming it.
    wide = [member(tmp_path, f"w{seed}", seed=seed, net_arch=(32, 32)) for seed in range(2)]
    wide_ensemble = save_ensemble(wide, tmp_path / "wide_ensemble.zip", body="point")
    with pytest.raises(ValueError, match=f"member {wide_ensemble} has policy settings"):
        build_ensemble([members[0], wide_ensemble], body="point")


def test_batched_and_sequential_heads_hold_the_same_weights_and_act_alike(tmp_path, members):
    batched = build_ensemble(members, body="point")
    sequential = build_ensemble(members, body="point", batched_heads=False)
    for mine, theirs in zip(
        batched.policy.actor.mu.head_states(), sequential.policy.actor.mu.head_states(), strict=True
    ):
        assert mine.keys() == theirs.keys()
        assert all(mine[key].equal(theirs[key]) for key in mine)
    # Another layout of the weights: another fingerprint, and the same action up to rounding.
    assert policy_fingerprint(batched) != policy_fingerprint(sequential)
    for obs in observations(10):
        np.testing.assert_allclose(
            batched.predict(obs, deterministic=True)[0], sequential.predict(obs, deterministic=True)[0], atol=1e-5
        )
    # One ensemble alone is rebuilt with the other layout: the same heads, in the same order.
    relaid = build_ensemble([save_ensemble(members, tmp_path / "seq.zip", body="point", batched_heads=False)], "point")
    assert policy_fingerprint(relaid) == policy_fingerprint(batched)
    with pytest.raises(ValueError, match="cannot load 2 head states"):
        batched.policy.actor.mu.load_head_states(sequential.policy.actor.mu.head_states()[:2])
    wrong = [{key: tensor[:1] for key, tensor in state.items()} for state in sequential.policy.actor.mu.head_states()]
    with pytest.raises(ValueError, match="head 0 has layers"):
        batched.policy.actor.mu.load_head_states(wrong)


def test_the_shipped_ant_is_stage_6_with_batched_heads():
    # The shipped zip records its layout: stage 6 loads as seven batched heads, with the fingerprint every
    # committed ant figure since it shipped names (stage 5 was five sequential heads, sha256:6ec896536b29b07b).
    shipped = load_low_level("ant")
    assert isinstance(shipped.policy.actor.mu, BatchedMeanOfHeads) and shipped.policy.n_members == 7
    assert low_level_identity("ant", shipped) == "sha256:8ae38455d9435335"


def reference_heads(mu, features):
    """BatchedMeanOfHeads' mean as it was computed before its loop looked the layers up once per call."""
    hidden = features.unsqueeze(0).expand(mu.n_heads, *features.shape)
    linear = 0
    for name in mu.order:
        if name in mu.activations:
            hidden = mu.activations[name](hidden)
        else:
            hidden = th.baddbmm(mu.biases[linear].unsqueeze(1), hidden, mu.weights[linear].transpose(1, 2))
            linear += 1
    return hidden.mean(dim=0)


def test_the_shipped_ants_actor_acts_as_sb3s_actor_bit_for_bit():
    # EnsembleActor.forward skips SB3's preprocess_obs (only .float() for these spaces) and BatchedMeanOfHeads
    # looks its layers up once per call: the same torch calls, so the same actions to the last bit, for
    # every batch size (a batched product rounds by its size, so each size is its own case).
    actor = load_low_level("ant").policy.actor
    assert actor.float_only_observations
    rng = np.random.default_rng(0)
    with th.no_grad():
        for rows in range(1, 26):
            obs = {
                key: th.as_tensor(rng.normal(size=(rows, *space.shape)) * 3)
                for key, space in actor.observation_space.spaces.items()
            }
            assert actor(obs).equal(Actor.forward(actor, obs))
            features = actor.features_extractor({key: value.float() for key, value in obs.items()})
            assert actor.mu(features).equal(reference_heads(actor.mu, features))


def test_bad_members_are_refused_with_the_member_named(tmp_path, members):
    with pytest.raises(ValueError, match=r"at least two member policies \(heads\), got 1"):
        build_ensemble(members[:1], body="point")
    sac = member(tmp_path, "sac", seed=0, algo="sac")
    with pytest.raises(ValueError, match=f"member {sac} holds a SAC"):
        build_ensemble([members[0], sac], body="point")
    wide = member(tmp_path, "wide", seed=0, net_arch=(32, 32))
    with pytest.raises(ValueError, match=f"member {wide} has policy settings"):
        build_ensemble([members[0], wide], body="point")
    with pytest.raises(ValueError, match="n_members must be an integer >= 1, got 0"):
        EnsemblePolicy(*policy_spaces(members[0]), n_members=0)


def policy_spaces(path):
    model = load_low_level("point", path)
    return model.observation_space, model.action_space, model.lr_schedule


def test_cli_ensemble_low_writes_the_zip_and_refuses_to_overwrite(tmp_path, members, capsys):
    out = tmp_path / "ens.zip"
    assert main(["ensemble-low", "--body", "point", *map(str, members[:2]), "--out", str(out)]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed["low_level_id"] == low_level_identity("point", load_low_level("point", out))
    assert printed["members"] == [str(path) for path in members[:2]]
    with pytest.raises(SystemExit) as exit_info:
        main(["ensemble-low", "--body", "point", *map(str, members[:2]), "--out", str(out)])
    assert exit_info.value.code == 2
    assert f"--out {out} exists; pass --force" in capsys.readouterr().err
    assert main(["ensemble-low", "--body", "point", *map(str, members), "--out", str(out), "--force"]) == 0
    assert load_low_level("point", out).policy.n_members == 3
    assert isinstance(load_low_level("point", out).policy.actor.mu, BatchedMeanOfHeads)
    argv = ["ensemble-low", "--body", "point", *map(str, members), "--out", str(out), "--force", "--sequential-heads"]
    assert main(argv) == 0
    assert isinstance(load_low_level("point", out).policy.actor.mu, MeanOfHeads)


def test_train_low_refuses_to_start_from_an_ensemble_in_one_line(tmp_path, members, capsys):
    ensemble = save_ensemble(members[:2], tmp_path / "ens.zip", body="point")
    argv = ["train-low", "--body", "point", "--timesteps", "200", "--out", str(tmp_path / "run")]
    with pytest.raises(SystemExit) as exit_info:
        main([*argv, "--init-from", str(ensemble)])
    assert exit_info.value.code == 2
    assert f"--init-from {ensemble} is an action ensemble; start from one of its member zips" in capsys.readouterr().err
