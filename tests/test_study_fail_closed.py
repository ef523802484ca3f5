"""The study server fails closed: every bad request is a 4xx with a JSON error, and changes nothing on disk."""

import asyncio
import json
import logging

import httpx
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from study_helpers import make_tiny_study, snapshot

from antmaze_hirl.study.server import (
    MAX_BODY_BYTES,
    MAX_JSON_DEPTH,
    ROUTE_FIELDS,
    SECURITY_HEADERS,
    BodyTooLarge,
    StudyServer,
    read_body,
)

TOKEN = "fail-closed-token-0123456789"


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    folder = make_tiny_study(tmp_path_factory.mktemp("study"), participants=2)
    server = StudyServer(folder, token=TOKEN)
    with server.running():
        with httpx.Client(base_url=server.base_url, headers={"X-Study-Token": TOKEN}, timeout=120) as client:
            assert client.post("/api/participants/P01/start", json={}).status_code == 200
            yield server, folder, client


def post_raw(client, path, raw):
    return client.post(path, content=raw, headers={"Content-Type": "application/json"})


def assert_refused(response, status, words):
    assert response.status_code == status, response.text
    assert words in response.json()["error"], response.json()


def test_an_integer_too_large_for_a_float_is_a_400_not_a_500(served):
    _, folder, client = served
    state = client.get("/api/participants/P01/state").json()
    x, y = state["agent"]  # inside the maze: only the huge value is wrong
    before = snapshot(folder)
    huge = "9" * 400  # within Python's digit limit, past a float's range
    for field in ("x", "y", "response_seconds"):
        values = {"query": state["query"]["id"], "x": x, "y": y, "response_seconds": 1.0, field: huge}
        raw = "{" + ", ".join(f'"{key}": {value}' for key, value in values.items()) + "}"
        assert_refused(post_raw(client, "/api/participants/P01/label", raw.encode()), 400, "finite number")
    five_thousand = '{"query": 1, "x": ' + "9" * 5000 + ', "y": 0}'  # past the digit limit: not JSON Python reads
    assert_refused(post_raw(client, "/api/participants/P01/label", five_thousand.encode()), 400, "not valid JSON")
    assert snapshot(folder) == before


def test_deep_json_nesting_is_a_400_on_every_post_route(served):
    _, folder, client = served
    before = snapshot(folder)
    deep = b'{"a": ' + b"[" * 8000 + b"]" * 8000 + b"}"
    just_over = b'{"a": ' + b"[" * MAX_JSON_DEPTH + b"]" * MAX_JSON_DEPTH + b"}"
    for route in ROUTE_FIELDS:
        for body in (deep, just_over):
            assert_refused(post_raw(client, f"/api/participants/P01/{route}", body), 400, "nested more than")
    strings = b'{"comment": "[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[["}'  # brackets inside a string are no nesting
    assert "nested" not in post_raw(client, "/api/participants/P01/questionnaire", strings).json()["error"]
    assert snapshot(folder) == before


def test_a_chunked_body_over_the_limit_is_a_413(served):
    _, folder, client = served
    before = snapshot(folder)

    def chunks():  # no Content-Length: httpx sends it chunked
        for _ in range(64):
            yield b" " * 4096

    response = client.post("/api/participants/P01/pause", content=chunks())
    assert_refused(response, 413, "larger than")
    assert snapshot(folder) == before


def test_a_streamed_body_is_cut_off_while_reading_not_read_whole():
    pulled = []

    class EndlessRequest:  # what a 200 MB chunked upload looks like to the route
        async def stream(self):
            while True:
                pulled.append(4096)
                yield b"x" * 4096

    with pytest.raises(BodyTooLarge, match="larger than"):
        asyncio.run(read_body(EndlessRequest()))
    assert sum(pulled) <= MAX_BODY_BYTES + 4096  # stopped at the first chunk past the limit


@pytest.mark.parametrize("route", sorted(ROUTE_FIELDS))
def test_unknown_fields_are_refused_on_every_route(served, route):
    _, folder, client = served
    before = snapshot(folder)
    fields = dict.fromkeys(ROUTE_FIELDS[route], 1)
    assert_refused(client.post(f"/api/participants/P01/{route}", json={**fields, "extra": 1}), 400, "unknown field")
    assert snapshot(folder) == before


def test_404_and_405_answer_with_the_documented_error_shape(served):
    _, _, client = served
    for response, status in (
        (client.get("/api/nothing-here"), 404),
        (client.get("/static/missing.js"), 404),
        (client.get("/api/participants/P01/start"), 405),
        (client.delete("/api/study"), 405),
        (client.get("/api/participants/P99/state"), 404),
    ):
        assert response.status_code == status, response.text
        assert set(response.json()) == {"error"} and response.json()["error"]


def test_every_response_carries_the_security_headers(served):
    server, _, client = served
    anonymous = httpx.Client(base_url=server.base_url, timeout=30)
    responses = {
        "page": client.get("/", params={"token": TOKEN}),
        "api": client.get("/api/study"),
        "static": client.get("/static/study.js"),
        "refused token": anonymous.get("/api/study"),
        "refused host": client.get("/api/study", headers={"Host": "attacker.example"}),
        "404": client.get("/api/nothing-here"),
        "400": post_raw(client, "/api/participants/P01/pause", b"not json"),
    }
    anonymous.close()
    for name, response in responses.items():
        for header, value in SECURITY_HEADERS.items():
            assert response.headers.get(header) == value, (name, header)
        assert "frame-ancestors 'self'" in response.headers["Content-Security-Policy"]
        if name != "static":
            assert response.headers["Cache-Control"] == "no-store", name


def test_refused_requests_are_logged_as_warnings_without_the_token(served, caplog):
    _, _, client = served
    with caplog.at_level(logging.WARNING, logger="antmaze_hirl.study.server"):
        client.get("/api/study", headers={"X-Study-Token": "wrong-token-0123456789"}, params={"token": TOKEN + "x"})
        post_raw(client, "/api/participants/P01/pause", b"[]")
    messages = [record.getMessage() for record in caplog.records if record.levelno == logging.WARNING]
    assert any("403" in message and "/api/study" in message for message in messages)
    assert any("400" in message and "JSON object" in message for message in messages)
    assert not any(TOKEN in message for message in messages)


_JSON = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(min_value=-(10**400), max_value=10**400)
    | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(max_size=20),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=20,
)


def fuzzed_json_body_is_refused_or_served(served, data):
    """One fuzzed POST: never a 5xx, and a 4xx names its error and leaves the folder as it was."""
    _, folder, client = served
    route = data.draw(st.sampled_from(sorted(ROUTE_FIELDS)), label="route")
    state = client.get("/api/participants/P01/state").json()
    open_query = (state.get("query") or {}).get("id", 1)
    fields = st.fixed_dictionaries(
        {},
        optional={field: (st.just(open_query) | _JSON) if field == "query" else _JSON for field in ROUTE_FIELDS[route]},
    )
    body = data.draw(fields | _JSON | st.dictionaries(st.text(max_size=8), _JSON, max_size=3), label="body")
    before = snapshot(folder)
    response = client.post(f"/api/participants/P01/{route}", content=json.dumps(body).encode())
    assert response.status_code < 500, response.text
    if response.status_code >= 400:
        assert isinstance(response.json()["error"], str)
        assert snapshot(folder) == before, (route, body, response.text)


_FUZZ = {"deadline": None, "suppress_health_check": [HealthCheck.function_scoped_fixture]}
# The unit tier fuzzes 30 bodies; the slow tier (CI's second run) the full 120 of before.
test_fuzzed_json_bodies_never_get_a_5xx_and_a_4xx_changes_nothing = settings(max_examples=30, **_FUZZ)(
    given(data=st.data())(fuzzed_json_body_is_refused_or_served)
)
test_fuzzed_json_bodies_120_examples = pytest.mark.slow(
    settings(max_examples=120, **_FUZZ)(given(data=st.data())(fuzzed_json_body_is_refused_or_served))
)


def test_study_init_refuses_a_maze_size_whose_family_has_no_selection_part(tmp_path):
    """The 3x3 point family has no wall grid in the "selection" part: refused at init, naming the value."""
    import argparse

    from antmaze_hirl.study.cli import add_study_parser
    from antmaze_hirl.study.settings import StudySettings

    with pytest.raises(ValueError, match=r"maze_size 3 .*'selection'"):
        StudySettings.for_body("point", maze_size=3)
    with pytest.raises(ValueError, match="maze_size 3"):
        StudySettings(body="point", maze_size=3, held_out_layouts=True)  # settings.json's path too
    assert StudySettings(body="point", maze_size=3).maze_size == 3  # without held-out layouts every size draws
    parser = argparse.ArgumentParser()
    add_study_parser(parser.add_subparsers(dest="command"))
    folder = tmp_path / "st4"
    args = parser.parse_args(
        ["study", "init", str(folder), "--body", "point", "--participants", "2", "--maze-size", "3"]
    )
    with pytest.raises(ValueError, match="maze_size 3") as refused:
        args.handler(args)
    assert "\n" not in str(refused.value)  # the CLI prints it as one line
    assert not folder.exists()  # nothing written


def test_a_trial_that_cannot_be_built_is_a_409_and_writes_nothing(tmp_path, monkeypatch):
    """A ValueError while building the trial: a JSON 4xx, no progress or event written, and a retry is possible."""
    from antmaze_hirl.study import session as session_module

    folder = make_tiny_study(tmp_path / "study", participants=1)

    def no_mazes(config, low_level=None):
        raise ValueError("no layout in split 'selection' in 1000 draws")

    real = session_module.TrialEnvs
    monkeypatch.setattr(session_module, "TrialEnvs", no_mazes)
    server = StudyServer(folder, token=TOKEN)
    with (
        server.running(),
        httpx.Client(base_url=server.base_url, headers={"X-Study-Token": TOKEN}, timeout=120) as client,
    ):
        before = snapshot(folder)
        refused = client.post("/api/participants/P01/start", json={})
        assert refused.status_code == 409, refused.text
        assert "cannot start" in refused.json()["error"] and "selection" in refused.json()["error"]
        assert snapshot(folder) == before
        state = client.get("/api/participants/P01/state").json()
        assert state["phase"] == "intro"
        monkeypatch.setattr(session_module, "TrialEnvs", real)
        started = client.post("/api/participants/P01/start", json={})
        assert started.status_code == 200, started.text
        assert started.json()["phase"] == "label" and started.json()["query"] is not None
