"""Whole studies: simulated participants over HTTP, the report, the oracle's numbers, and a kill -9 mid-trial."""

import csv
import json
import os
import signal
import subprocess
import sys
import time

import httpx
import numpy as np
import pytest
from study_helpers import TINY_SETTINGS, make_tiny_study

from antmaze_hirl.dagger import GatedQuery
from antmaze_hirl.experiments.runner import run_trial
from antmaze_hirl.study.analysis import analyze
from antmaze_hirl.study.plan import load_plan
from antmaze_hirl.study.server import TOKEN_ENV, StudyServer, bind_socket
from antmaze_hirl.study.settings import load_settings
from antmaze_hirl.study.simulate import SimulatedParticipant, StudyClient, oracle_click, simulate_study

# End to end (see pyproject.toml's markers): left out of the default unit tier, run by .ci/run.
pytestmark = pytest.mark.integration

COMPARED = ("episode", "success", "expert_cost", "cumulative_expert_cost", "attempts", "low_level_steps", "beta")


def read_csv(path):
    with path.open() as handle:
        return list(csv.DictReader(handle))


def test_a_simulated_three_participant_study_runs_over_http_and_is_analysed(tmp_path):
    folder = make_tiny_study(tmp_path / "study", participants=3)
    with StudyServer(folder).running() as server:
        lines = []
        participants = ["P01", "P02", "P03"]
        results = simulate_study(
            server.url, participants, SimulatedParticipant(noise=0.1, delay=0.01, seed=3), log=lines.append
        )
    assert [r["trials"] for r in results] == [2, 2, 2]  # practice is not rated
    assert [line.split(":")[0] for line in lines] == [p for p in participants for _ in range(3)]  # a line per trial
    assert "part 1 of 3 (Practice)" in lines[0]
    plan = load_plan(folder)
    for participant in plan.participants:
        rows = read_csv(folder / "participants" / participant.id / "episodes.csv")
        assert [(int(r["trial"]), int(r["episode"])) for r in rows] == [(0, 0), (1, 0), (1, 1), (2, 0), (2, 1)]
        assert [r["method"] for r in rows[1:]] == [m for m in participant.order for _ in range(2)]
        assert all(r["label"] != r["method"] for r in rows)  # the page shows neutral labels only
        assert all(float(r["seconds_per_label"]) >= 0 for r in rows)
        assert all(0 <= float(r["time_on_task"]) < 60 for r in rows)  # seconds from the episode start to its last click
        clicks = (folder / "participants" / participant.id / "clicks.jsonl").read_text().splitlines()
        assert len(clicks) == sum(int(r["expert_cost"]) for r in rows)
        answers = [json.loads(line) for line in (folder / "participants" / participant.id / "answers.jsonl").open()]
        assert [a["method"] for a in answers] == list(participant.order)
        for trial in participant.trials:
            assert (folder / "participants" / participant.id / f"trial{trial.index}" / "learner.zip").is_file()
    report = analyze(folder)
    text = (report / "report.md").read_text()
    for method, label in plan.labels:
        assert label in text and method in text
    assert "ANOVA" in text
    for name in ("panels.png", "likert.png", "seconds_per_label.png", "stats.json"):
        assert (report / name).stat().st_size > 0


def test_a_noise_free_simulated_participant_gives_the_oracle_experiments_numbers(tmp_path):
    # One trainer, any expert: clicks planned from the page's state equal the oracle's labels, so the
    # study trial reproduces the experiment runner's trial with the same seed, episode for episode.
    folder = make_tiny_study(tmp_path / "study", participants=1, methods=("dagger", "reward"), episodes=3, practice=0)
    with StudyServer(folder).running() as server:
        simulate_study(server.url, ["P01"], SimulatedParticipant())
    plan, settings = load_plan(folder), load_settings(folder)
    rows = read_csv(folder / "participants" / "P01" / "episodes.csv")
    for trial in plan.participants[0].trials:
        expected = run_trial(trial.method, trial.seed, settings.experiment_config(trial.episodes))
        got = [r for r in rows if int(r["trial"]) == trial.index]
        assert [[str(e[c]) for c in COMPARED] for e in expected] == [[g[c] for c in COMPARED] for g in got]
        assert expected[-1]["eval_success"] == float(got[-1]["eval_success"])  # the final evaluation too


SLOW_UPDATES = (
    "import time; from antmaze_hirl.dagger import DAggerTrainer; update = DAggerTrainer._update; "
    "DAggerTrainer._update = lambda self, steps: (time.sleep(30), update(self, steps))[1]; "
    "from antmaze_hirl.cli import main; main()"
)
"""A server whose learner updates take 30 s longer (``_serve(..., program=SLOW_UPDATES)``)."""


def _serve(folder, port, token, program=None):
    env = {**os.environ, "PYTHONUNBUFFERED": "1", TOKEN_ENV: token}  # from the environment: not visible in `ps`
    start = ["-m", "antmaze_hirl.cli"] if program is None else ["-c", program]
    command = [sys.executable, *start, "study", "serve", str(folder), "--port", str(port)]
    process = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    deadline = time.time() + 120
    while time.time() < deadline:
        try:
            httpx.get(f"http://127.0.0.1:{port}/api/study", headers={"X-Study-Token": token}, timeout=2)
            return process
        except httpx.TransportError:
            if process.poll() is not None:
                raise RuntimeError(process.stdout.read().decode()) from None
            time.sleep(0.2)
    process.kill()
    raise TimeoutError("study server did not start")


def test_kill_9_mid_trial_loses_at_most_the_episode_in_progress(tmp_path):
    folder = make_tiny_study(tmp_path / "study", participants=1, methods=("dagger", "reward"), episodes=3, practice=0)
    probe = bind_socket("127.0.0.1", 0)
    port = probe.getsockname()[1]
    probe.close()
    token = "kill-test-token-0123456789"
    client = StudyClient(f"http://127.0.0.1:{port}/?token={token}")
    server = _serve(folder, port, token)
    try:
        state = client.participant("P01", "start", {})
        finished = 0
        while finished < 1 or state["query"]["label_index"] < 2:  # one whole episode, then two clicks into the next
            click = oracle_click(state)
            result = client.participant("P01", "label", {"query": state["query"]["id"], "x": click[0], "y": click[1]})
            state = result["state"]
            if result["episode_end"] is not None:
                finished += 1
                state = client.participant("P01", "next", {})
        participant = folder / "participants" / "P01"
        saved = {name: (participant / name).read_bytes() for name in ("episodes.csv", "clicks.jsonl", "events.jsonl")}
        trial_folder = participant / "trial1"  # without a practice trial the first compared trial is 1
        checkpoint = (trial_folder / "checkpoint.pt").read_bytes()
    finally:
        server.send_signal(signal.SIGKILL)
        server.wait()
    server = _serve(folder, port, token)
    try:
        resumed = client.participant("P01", "state")
        assert (
            resumed["phase"] == "label" and resumed["episode"]["number"] == 2 and resumed["query"]["label_index"] == 0
        )
        assert resumed["labels"] == int(read_csv(participant / "episodes.csv")[0]["expert_cost"])
        for name, content in saved.items():
            assert (participant / name).read_bytes().startswith(content), name  # earlier data intact
        assert (trial_folder / "checkpoint.pt").read_bytes() == checkpoint
        events = [json.loads(line)["event"] for line in (participant / "events.jsonl").open()]
        assert events[-1] == "restored"
        while resumed["phase"] == "label":  # the participant goes on to the end of the trial
            click = oracle_click(resumed)
            query = {"query": resumed["query"]["id"], "x": click[0], "y": click[1]}
            resumed = client.participant("P01", "label", query)["state"]
            if resumed["phase"] == "episode_over":
                resumed = client.participant("P01", "next", {})
        assert resumed["phase"] == "questionnaire"
        rows = read_csv(participant / "episodes.csv")
        assert [int(r["episode"]) for r in rows] == [0, 1, 2]
    finally:
        server.send_signal(signal.SIGKILL)
        server.wait()


def test_kill_9_while_a_closed_part_updates_is_resumed_by_the_next_start(tmp_path):
    # Background updates: the part's last maze closes it at once; its update (30 s slower here) runs after.
    # A kill -9 then loses only that work in progress; the next server start (updates at their speed) runs it again.
    folder = make_tiny_study(tmp_path / "study", methods=("dagger",), episodes=2, practice=0, background_updates=True)
    probe = bind_socket("127.0.0.1", 0)
    port = probe.getsockname()[1]
    probe.close()
    token = "kill-test-token-0123456789"
    client = StudyClient(f"http://127.0.0.1:{port}/?token={token}")
    participant = folder / "participants" / "P01"
    server = _serve(folder, port, token, program=SLOW_UPDATES)
    try:
        state = client.participant("P01", "start", {})
        while state["phase"] != "questionnaire":
            click = oracle_click(state)
            result = client.participant("P01", "label", {"query": state["query"]["id"], "x": click[0], "y": click[1]})
            state = client.participant("P01", "next", {}) if result["episode_end"] else result["state"]
        assert not (participant / "trial1" / "learner.zip").exists()  # the final update still runs
    finally:
        server.send_signal(signal.SIGKILL)
        server.wait()
    episodes = participant / "episodes.csv"
    assert not episodes.exists() or len(read_csv(episodes)) < 2  # the last row waits for the final evaluation
    server = _serve(folder, port, token)  # no participant request: the start itself resumes the update
    try:
        deadline = time.time() + 180
        while not (participant / "trial1" / "learner.zip").exists() and time.time() < deadline:
            time.sleep(0.5)
        assert (participant / "trial1" / "learner.zip").exists()
        assert client.participant("P01", "state")["phase"] == "questionnaire"
        rows = read_csv(participant / "episodes.csv")
        assert [row["episode"] for row in rows] == ["0", "1"] and rows[-1]["eval_success"] != ""
        events = [json.loads(line) for line in (participant / "events.jsonl").open()]
        assert [event["resumed"] for event in events if event["event"] == "final_update"] == [True]
    finally:
        server.send_signal(signal.SIGKILL)
        server.wait()


@pytest.mark.parametrize("episodes", [TINY_SETTINGS["eval_every"]])
def test_evaluations_land_on_the_paper_schedule(tmp_path, episodes):
    folder = make_tiny_study(tmp_path / "study", participants=1, methods=("dagger", "noise"), episodes=episodes + 1)
    with StudyServer(folder).running() as server:
        simulate_study(server.url, ["P01"], SimulatedParticipant(seed=1))
    rows = [r for r in read_csv(folder / "participants" / "P01" / "episodes.csv") if r["practice"] == "False"]
    evaluated = [int(r["episode"]) for r in rows if r["eval_success"] != ""]
    # every eval_every-th episode, and the last one (with the final evaluation's mazes)
    assert evaluated == [1, 2, 1, 2]


def test_a_gated_trial_asks_less_and_gives_the_oracle_experiments_numbers(tmp_path):
    folder = make_tiny_study(tmp_path / "study", participants=1, methods=("gated",), episodes=4, practice=0)
    with StudyServer(folder).running() as server:
        simulate_study(server.url, ["P01"], SimulatedParticipant())
    plan, settings = load_plan(folder), load_settings(folder)
    (trial,) = plan.participants[0].trials
    rows = read_csv(folder / "participants" / "P01" / "episodes.csv")
    expected = run_trial(trial.method, trial.seed, settings.experiment_config(trial.episodes))
    assert [[str(e[c]) for c in COMPARED] for e in expected] == [[g[c] for c in COMPARED] for g in rows]
    clicks = (folder / "participants" / "P01" / "clicks.jsonl").read_text().splitlines()
    assert len(clicks) == sum(int(r["expert_cost"]) for r in rows) < sum(int(r["attempts"]) for r in rows)
    with np.load(folder / "participants" / "P01" / f"trial{trial.index}" / "demonstrations.npz") as log:
        assert len(log["labelled"]) == sum(int(r["attempts"]) for r in rows)  # every step, asked or not
        assert log["labelled"].sum() == len(clicks) and np.isnan(log["labels"][~log["labelled"]]).all()


def test_a_maze_the_learner_walks_unasked_is_shown_and_closed(tmp_path, monkeypatch):
    # The gate never opens once D holds labels: after the first maze the page asks only at no-ops.
    monkeypatch.setattr(GatedQuery, "wants_label", lambda self, observation, subgoal, learner: False)
    # Five mazes: the tiny learner's subgoal is a no-op somewhere in some mazes (the gate opens there).
    # On 3x3 mazes (held out by seed only: that family has no selection part up to symmetry), as the test was made.
    folder = make_tiny_study(
        tmp_path / "study",
        participants=1,
        methods=("gated",),
        episodes=5,
        practice=0,
        maze_size=3,
        held_out_layouts=False,
    )
    with StudyServer(folder).running() as server:
        client = StudyClient(server.url)
        state, unasked_mazes = client.participant("P01", "start", {}), []
        while state["phase"] in ("label", "episode_over"):
            if state["phase"] == "episode_over":  # walked to its end without a question
                assert state["query"] is None and state["walk"] and not any(step["asked"] for step in state["walk"])
                unasked_mazes.append(state["episode_end"]["number"])
                state = client.participant("P01", "next", {})
                continue
            click = oracle_click(state)
            result = client.participant("P01", "label", {"query": state["query"]["id"], "x": click[0], "y": click[1]})
            state = client.participant("P01", "next", {}) if result["episode_end"] else result["state"]
    assert unasked_mazes and 1 not in unasked_mazes  # the first maze is always asked (no labels yet)
    rows = read_csv(folder / "participants" / "P01" / "episodes.csv")
    assert [int(r["expert_cost"]) == 0 for r in rows[1:]] == [n in unasked_mazes for n in range(2, 6)]
