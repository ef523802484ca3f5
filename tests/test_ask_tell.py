"""The trainer's ask/tell interface: an expert that answers later drives the same DAgger loop."""

import pickle

import numpy as np
import pytest
from conftest import make_point_trainer

from antmaze_hirl.dagger import MultiPolicyQuery, RewardBasedQuery
from antmaze_hirl.envs.state_layout import STATE_LAYOUT


def drive_by_hand(trainer, episodes):
    """The study server's way: read each request, answer it later with the oracle's label."""
    oracle = trainer.expert
    records, requests = [], []
    for _ in range(episodes):
        run = trainer.start_episode()
        while not run.done:
            requests.append(run.request)
            executed = run.answer(oracle.label(run.request.observation))
            assert len(executed) == 1
            assert run.done or executed[0].info["attempts"] == run.request.label_index  # the next request's index
        records.append(run.record)
    return records, requests


@pytest.mark.parametrize("make_strategy", [lambda: None, RewardBasedQuery, lambda: MultiPolicyQuery(n_policies=2)])
def test_ask_tell_gives_the_same_episodes_as_run_episode(make_strategy):
    synchronous = make_point_trainer(strategy=make_strategy())
    by_hand = make_point_trainer(strategy=make_strategy())
    expected = [r.to_dict() for r in synchronous.train(2)]
    records, requests = drive_by_hand(by_hand, 2)
    assert [r.to_dict() for r in records] == expected
    assert (
        sum(r.expert_cost for r in records) == len(requests) == len(by_hand.dataset) + sum(r.removed for r in records)
    )
    np.testing.assert_array_equal(by_hand.dataset.subgoals(), synchronous.dataset.subgoals())


def test_requests_carry_the_learners_proposal_and_the_steps_report_what_ran():
    trainer = make_point_trainer()
    run = trainer.start_episode()
    request = run.request
    np.testing.assert_array_equal(request.learner_subgoal, trainer.learner.predict(request.observation))
    assert (request.episode, request.label_index, request.beta) == (0, 0, 1.0)
    label = trainer.expert.label(request.observation)
    (step,) = run.answer(label)
    np.testing.assert_array_equal(step.expert_subgoal, label)
    np.testing.assert_allclose(
        step.subgoal, np.clip(label, trainer.env.unwrapped.action_space.low, trainer.env.unwrapped.action_space.high)
    )
    np.testing.assert_allclose(
        step.info["agent_path"][0], STATE_LAYOUT.agent_xy(request.observation["state"]), atol=1e-6
    )
    assert run.request is None or run.request.label_index == 1


def test_a_bad_label_is_refused_and_leaves_the_episode_as_it_was():
    trainer = make_point_trainer()
    run = trainer.start_episode()
    request = run.request
    for bad in ([np.nan, 0.0], [1.0], "left", [np.inf, 1.0]):
        with pytest.raises(ValueError, match="expert subgoal"):
            run.answer(bad)
    assert run.request is request and len(trainer.dataset) == 0
    run.answer(trainer.expert.label(request.observation))
    assert len(trainer.dataset) == 1


def test_answering_an_ended_episode_raises():
    trainer = make_point_trainer()
    run = trainer.start_episode()
    while not run.done:
        run.answer(trainer.expert.label(run.request.observation))
    with pytest.raises(RuntimeError, match="has ended"):
        run.answer([0.0, 0.0])


def test_a_trainer_pickles_between_episodes_and_goes_on_identically():
    trainer = make_point_trainer(strategy=MultiPolicyQuery(n_policies=2))
    trainer.train(2)
    env, expert = trainer.env, trainer.expert
    trainer.env = trainer.expert = None
    copy = pickle.loads(pickle.dumps(trainer))
    trainer.env, trainer.expert = env, expert
    copy.env, copy.expert = make_point_trainer().env, expert
    assert copy.train(1)[0].to_dict() == trainer.train(1)[0].to_dict()


def test_the_update_waits_for_finish_or_the_next_episode():
    trainer = make_point_trainer()
    run = trainer.start_episode()
    with pytest.raises(RuntimeError, match="still running"):
        run.finish()
    while not run.done:
        run.answer(trainer.expert.label(run.request.observation))
    assert (trainer.updates, trainer.learner.gradient_steps) == (0, 0)  # the page shows the end before any training
    run.finish()
    run.finish()  # a second call has nothing left to do
    assert (trainer.updates, trainer.learner.gradient_steps) == (1, 5)
    second = trainer.start_episode()
    while not second.done:
        second.answer(trainer.expert.label(second.request.observation))
    trainer.start_episode()  # an unfinished update runs before the next episode draws its maze
    assert (trainer.updates, trainer.learner.gradient_steps) == (2, 10)
