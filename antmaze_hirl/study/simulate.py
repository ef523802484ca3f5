"""Simulated participants: the scripted oracle plays a study through the page's HTTP API.

A simulated participant reads exactly what the page gets (``GET .../state``: walls, agent, goal, the
reach circle), plans its click with the oracle's planner (:func:`~antmaze_hirl.experts.oracle.plan_subgoal`),
adds Gaussian click noise, waits a reaction delay, and posts the click as the page does. After each
trial it answers the questionnaire from a seeded model. With no noise its clicks are the oracle's
labels, so a simulated study reproduces the experiment runner's numbers for the same trial seeds.

The questionnaire model (a stand-in, not a claim about people): each rating is
``round(3 + participant_offset + effect + N(0, 0.6))`` clipped to 1..5, where the effect grows with the
labels the trial cost per episode (workload items) or with its share of failed episodes (performance,
frustration), centred on the study's typical values.
"""

from __future__ import annotations

import json
import time
import urllib.error
import urllib.request
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any
from urllib.parse import parse_qs, quote, urlsplit

import numpy as np

from antmaze_hirl.envs.geometry import MazeGeometry
from antmaze_hirl.experts.oracle import plan_subgoal
from antmaze_hirl.study.questionnaire import ITEM_KEYS, SCALE_MAX, SCALE_MIN

WORKLOAD_ITEMS = ("mental_demand", "physical_demand", "temporal_demand", "effort")


class StudyClientError(RuntimeError):
    """The server refused a request (its status and JSON error message)."""


class StudyClient:
    """A minimal JSON client of the study API (standard library only).

    Args:
        url: The study URL with its token, as the server prints it (``http://127.0.0.1:8765/?token=...``).
        timeout: Seconds per request.

    Raises:
        ValueError: If the URL has no token.
    """

    def __init__(self, url: str, *, timeout: float = 600.0) -> None:
        parts = urlsplit(url)
        tokens = parse_qs(parts.query).get("token")
        if not tokens:
            raise ValueError(f"study URL {url!r} has no ?token=: use the URL the server printed")
        self.base = f"{parts.scheme}://{parts.netloc}"
        self.token = tokens[0]
        self.timeout = timeout
        self.last_server_seconds: float | None = None  # the server's own time for the last request

    def request(self, path: str, body: dict[str, Any] | None = None) -> dict[str, Any]:
        """``GET`` (no body) or ``POST`` (JSON body) ``path``; returns the JSON answer.

        Raises:
            StudyClientError: On an HTTP error status, with the server's message.
        """
        data = None if body is None else json.dumps(body).encode()
        headers = {"X-Study-Token": self.token}
        if data is not None:
            headers["Content-Type"] = "application/json"
        request = urllib.request.Request(self.base + path, data=data, headers=headers)
        try:
            with urllib.request.urlopen(request, timeout=self.timeout) as response:
                self.last_server_seconds = _server_seconds(response.headers.get("Server-Timing", ""))
                return json.loads(response.read())
        except urllib.error.HTTPError as error:
            message = error.read().decode(errors="replace")
            raise StudyClientError(f"{error.code} from {path}: {message}") from error

    def participant(self, participant_id: str, action: str, body: dict[str, Any] | None = None) -> dict[str, Any]:
        """A participant's endpoint (``state``, ``start``, ``label``, ``questionnaire``, ``pause``)."""
        return self.request(f"/api/participants/{quote(participant_id)}/{action}", body)


def _server_seconds(header: str) -> float | None:
    # "app;dur=12.3" (milliseconds), as the study server writes it
    for part in header.split(";"):
        if part.strip().startswith("dur="):
            return float(part.strip()[4:]) / 1000
    return None


@dataclass(frozen=True)
class SimulatedParticipant:
    """How a simulated participant clicks and rates.

    Attributes:
        noise: Std of the Gaussian click noise, metres.
        delay: Mean reaction delay before each click, seconds (exponentially distributed; 0: none).
        seed: Seeds the noise, delays and questionnaire answers.
    """

    noise: float = 0.0
    delay: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("noise", "delay"):
            value = getattr(self, name)
            if not np.isfinite(value) or value < 0:
                raise ValueError(f"{name} must be a finite number >= 0, got {value}")


def oracle_click(state: dict[str, Any]) -> np.ndarray:
    """The oracle's subgoal for a page state (what the page shows: walls, agent, goal, reach circle)."""
    maze = state["maze"]
    geometry = MazeGeometry(maze["rows"], maze["cols"], maze["scale"])
    subgoal = plan_subgoal(
        np.asarray(maze["walls"], dtype=bool),
        geometry,
        np.asarray(state["agent"], dtype=np.float64),
        np.asarray(state["goal"], dtype=np.float64),
        subgoal_reach_m=state["subgoal_reach_m"],
        clearance_m=0.2 * geometry.scale,  # the oracle's default, as in the experiments
    )
    inner_low = geometry.low + geometry.scale
    return np.clip(subgoal, inner_low, -inner_low)


MAX_RECLICKS = 20
"""Noisy clicks a simulated participant tries before settling for the oracle's own (which the page accepts)."""


def page_accepts(state: dict[str, Any], xy: np.ndarray) -> bool:
    """Whether the page sends a click at ``xy``: in bounds, on the floor, inside the reach circle.

    As study.js's ``refusalOf`` without its 3-pixel slack, so the server (which allows the slack) accepts it too.
    """
    maze = state["maze"]
    geometry = MazeGeometry(maze["rows"], maze["cols"], maze["scale"])
    low, high = (np.asarray(bound) for bound in maze["bounds"])
    distance = float(np.hypot(*(np.asarray(xy) - np.asarray(state["agent"]))))
    return bool(
        np.all(low <= xy)
        and np.all(xy <= high)
        and geometry.is_free(np.asarray(maze["walls"], dtype=bool), np.asarray(xy))
        and distance <= state["subgoal_reach_m"]
    )


def play_participant(
    client: StudyClient,
    participant_id: str,
    behaviour: SimulatedParticipant,
    *,
    rng: np.random.Generator,
    log: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Plays one participant's whole session (every trial and questionnaire) through the API.

    ``log`` (e.g. ``print``) hears a line as each trial starts: a whole study takes minutes.

    Returns:
        ``{"participant", "clicks", "trials", "latencies", "between"}``: each latency is a click's
        ``{"round_trip", "server", "episode_end"}`` (seconds; whether the click ended an episode), and
        ``between`` the ``{"round_trip", "server", "closed_trial", "walked"}`` of each ``next`` request that
        closed an episode (whether it closed the trial too; whether the learner walked that maze unasked).
    """
    state = client.participant(participant_id, "state")
    clicks, latencies, between, trial_clicks, trial_failures, trial_episodes = 0, [], [], 0, 0, 0
    offset = rng.normal(0.0, 0.5)  # how this participant tends to rate
    trials = 0
    while state["phase"] != "done":
        if state["phase"] == "intro":
            if log is not None:
                trial = state["trial"]
                part = f"part {trial['number']} of {state['trials']} ({trial['label']})"
                log(f"{participant_id}: {part}, {clicks} clicks so far")
            state = client.participant(participant_id, "start", {})
            trial_clicks = trial_failures = trial_episodes = 0
        elif state["phase"] == "label":
            click = oracle_click(state)
            if behaviour.noise > 0:
                low, high = (np.asarray(bound) for bound in state["maze"]["bounds"])
                for _ in range(MAX_RECLICKS):  # the page refuses a wall or a point past the circle: click again
                    noisy = np.clip(click + rng.normal(0.0, behaviour.noise, size=2), low, high)
                    if page_accepts(state, noisy):
                        click = noisy
                        break
            wait = float(rng.exponential(behaviour.delay)) if behaviour.delay > 0 else 0.0
            time.sleep(wait)
            started = time.perf_counter()
            result = client.participant(
                participant_id,
                "label",
                {"query": state["query"]["id"], "x": float(click[0]), "y": float(click[1]), "response_seconds": wait},
            )
            latencies.append(
                {
                    "round_trip": time.perf_counter() - started,
                    "server": client.last_server_seconds,
                    "episode_end": result["episode_end"] is not None,
                }
            )
            clicks += 1
            trial_clicks += 1
            state = result["state"]
            if result["episode_end"] is not None:
                trial_episodes += 1
                trial_failures += int(not result["episode_end"]["success"])
                state = _next_maze(client, participant_id, between, walked=False)
        elif state["phase"] == "episode_over":  # a gated method's learner walked the whole maze unasked
            trial_episodes += 1
            trial_failures += int(not state["episode_end"]["success"])
            state = _next_maze(client, participant_id, between, walked=True)
        elif state["phase"] == "questionnaire":
            ratings = _ratings(
                rng, offset, trial_clicks / max(trial_episodes, 1), trial_failures / max(trial_episodes, 1)
            )
            state = client.participant(
                participant_id, "questionnaire", {"trial": state["trial"]["number"], "ratings": ratings, "comment": ""}
            )
            trials += 1
        else:
            raise StudyClientError(f"participant {participant_id} is in unknown phase {state['phase']!r}")
    return {
        "participant": participant_id,
        "clicks": clicks,
        "trials": trials,
        "latencies": latencies,
        "between": between,
    }


def _next_maze(client: StudyClient, participant_id: str, between: list[dict[str, Any]], *, walked: bool) -> dict:
    # POST next, timed: the wait between two mazes, or after a part's last maze (the trial closed).
    started = time.perf_counter()
    state = client.participant(participant_id, "next", {})
    between.append(
        {
            "round_trip": time.perf_counter() - started,
            "server": client.last_server_seconds,
            "closed_trial": state["phase"] not in ("label", "episode_over"),
            "walked": walked,
        }
    )
    return state


def _ratings(
    rng: np.random.Generator, offset: float, labels_per_episode: float, failure_share: float
) -> dict[str, int]:
    # Centred on ~10 labels per episode and ~30% failures, the point experiment's typical values.
    workload = 0.15 * (labels_per_episode - 10.0)
    failing = 3.0 * (failure_share - 0.3)
    ratings = {}
    for key in ITEM_KEYS:
        effect = workload if key in WORKLOAD_ITEMS else failing
        value = round(3 + offset + effect + rng.normal(0.0, 0.6))
        ratings[key] = int(np.clip(value, SCALE_MIN, SCALE_MAX))
    return ratings


def simulate_study(
    url: str, participant_ids: list[str], behaviour: SimulatedParticipant, *, log: Callable[[str], None] | None = None
) -> list[dict[str, Any]]:
    """Plays ``participant_ids`` one after another on the study served at ``url``.

    Each participant's randomness is seeded by ``behaviour.seed`` and their position in the list.
    """
    client = StudyClient(url)
    results = []
    for position, participant_id in enumerate(participant_ids):
        rng = np.random.default_rng([behaviour.seed, position])
        results.append(play_participant(client, participant_id, behaviour, rng=rng, log=log))
    return results
