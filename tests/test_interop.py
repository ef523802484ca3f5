import numpy as np
import pytest
import torch as th

pytest.importorskip("imitation", reason="the imitation extra is not installed")

from conftest import point_maze
from imitation.algorithms import bc

from antmaze_hirl import PathOracle
from antmaze_hirl.dagger import DAggerTrainer, HighLevelPolicy, RewardBasedQuery
from antmaze_hirl.dagger.interop import BCLearner, to_transitions


def test_labels_export_to_imitation_transitions_and_bc_trains_on_them():
    env = point_maze()
    rng = np.random.default_rng(0)
    trainer = DAggerTrainer(
        env=env,
        expert=PathOracle.for_env(env),
        learner=HighLevelPolicy.for_env(env, rng=rng),
        rng=rng,
        gradient_steps=2,
    )
    trainer.train(2)
    transitions = to_transitions(trainer.dataset)
    assert len(transitions) == len(trainer.dataset)
    np.testing.assert_array_equal(transitions.acts, trainer.dataset.subgoals().astype(np.float32))
    assert transitions.obs.get("image").shape == (len(trainer.dataset), *env.observation_space["image"].shape)
    assert transitions.dones.sum() == 2  # one episode end per training episode
    np.testing.assert_array_equal(transitions.next_obs.get("state")[0], transitions.obs.get("state")[1])
    th.manual_seed(0)  # BC builds its policy from torch's global RNG
    cloner = bc.BC(
        observation_space=env.observation_space,
        action_space=env.action_space,
        rng=rng,
        demonstrations=transitions,
        batch_size=4,  # two short point episodes give ~6 labels
    )

    def negative_log_likelihood():
        observations = {key: transitions.obs.get(key) for key in ("image", "state")}
        obs_tensor, _ = cloner.policy.obs_to_tensor(observations)
        with th.no_grad():
            _, log_prob, _ = cloner.policy.evaluate_actions(obs_tensor, th.as_tensor(transitions.acts))
        return float(-log_prob.mean())

    before = negative_log_likelihood()
    cloner.train(n_batches=60, progress_bar=False)
    # BC fitted the exported labels: their likelihood under its policy rose (a loss on anything else would not).
    after = negative_log_likelihood()
    assert after < before - 0.3, (before, after)


def test_bc_serves_as_dagger_learner_with_reward_based_filtering():
    env = point_maze()
    rng = np.random.default_rng(1)
    learner = BCLearner(env, rng=rng, batch_size=4)
    before = [p.detach().clone() for p in learner.bc.policy.parameters()]
    trainer = DAggerTrainer(
        env=env, expert=PathOracle.for_env(env), learner=learner, rng=rng, strategy=RewardBasedQuery(), gradient_steps=4
    )
    records = trainer.train(3)
    assert trainer.updates == 3 and records[-1].dataset_size == len(trainer.dataset) >= 4
    assert any(not (a == b).all() for a, b in zip(before, learner.bc.policy.parameters(), strict=True))
    obs, _ = env.reset(seed=0)
    assert env.action_space.contains(learner.predict(obs).astype(np.float32))
