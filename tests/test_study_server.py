"""The study server over real HTTP: token, Host and Origin checks, and every bad input refused without a trace."""

import socket

import httpx
import pytest
from study_helpers import make_tiny_study, snapshot

from antmaze_hirl.study.server import MAX_BODY_BYTES, StudyServer, parse_json_object
from antmaze_hirl.study.session import BadInput


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    folder = make_tiny_study(tmp_path_factory.mktemp("study"), participants=2)
    server = StudyServer(folder, token="secret-token-0123456789")
    with server.running():
        yield server, folder


@pytest.fixture
def client(served):
    server, _ = served
    with httpx.Client(base_url=server.base_url, headers={"X-Study-Token": server.token}, timeout=120) as client:
        yield client


def test_the_page_and_the_api_need_the_token(served):
    server, _ = served
    with httpx.Client(base_url=server.base_url, timeout=30) as anonymous:
        assert anonymous.get("/").status_code == 403
        assert anonymous.get("/api/study").status_code == 403
        assert anonymous.get("/api/study", params={"token": "wrong"}).status_code == 403
        longer = {"X-Study-Token": server.token + "-but-longer"}
        assert anonymous.get("/api/study", headers=longer).status_code == 403
        page = anonymous.get("/", params={"token": server.token})
        assert page.status_code == 200 and "<canvas" in page.text
        study = anonymous.get("/api/study", params={"token": server.token}).json()
        assert [p["id"] for p in study["participants"]] == ["P01", "P02"]
        assert anonymous.get("/static/study.js").status_code == 200  # code, no data: served without the token


def test_foreign_host_and_cross_site_origin_are_refused(served, client):
    server, _ = served
    rebinding = client.get("/api/study", headers={"Host": f"attacker.example:{server.port}"})
    assert rebinding.status_code == 403 and "Host" in rebinding.json()["error"]
    cross_site = client.post(
        "/api/participants/P01/pause", json={"paused": True}, headers={"Origin": "http://attacker.example"}
    )
    assert cross_site.status_code == 403 and "Origin" in cross_site.json()["error"]
    same_site = client.get("/api/study", headers={"Origin": server.base_url, "Host": f"localhost:{server.port}"})
    assert same_site.status_code == 403  # Origin 127.0.0.1 vs Host localhost: not the same origin
    assert client.get("/api/study", headers={"Origin": server.base_url}).status_code == 200


@pytest.mark.parametrize(
    "headers", [{"Host": "[::1"}, {"Host": "[::1:8765"}, {"Origin": "http://[::1"}, {"Origin": "http://]x["}], ids=str
)
def test_a_malformed_host_or_origin_is_a_403_with_a_json_error_not_a_500(served, headers):
    server, _ = served
    raw = "".join(f"{name}: {value}\r\n" for name, value in {"Host": f"127.0.0.1:{server.port}", **headers}.items())
    with socket.create_connection(("127.0.0.1", server.port), timeout=30) as connection:
        request = f"GET /api/study HTTP/1.1\r\n{raw}X-Study-Token: {server.token}\r\nConnection: close\r\n\r\n"
        connection.sendall(request.encode())
        chunks = []
        while chunk := connection.recv(65536):
            chunks.append(chunk)
    reply = b"".join(chunks).decode()
    status = int(reply.split(" ", 2)[1])
    assert status == 403, reply
    assert '"error"' in reply


def test_bad_requests_get_a_4xx_with_a_message_and_change_nothing(served, client):
    _, folder = served
    assert client.post("/api/participants/P02/start", json={}).status_code == 200
    query = client.get("/api/participants/P02/state").json()["query"]["id"]
    before = snapshot(folder)
    bad = [
        ("/api/participants/P99/state", None, None, 404, "unknown participant"),
        ("/api/participants/P02/label", {"query": query, "x": 1e6, "y": 0.0}, None, 400, "outside the maze"),
        ("/api/participants/P02/label", None, b'{"query": 1, "x": NaN, "y": 0}', 400, "not valid JSON"),
        ("/api/participants/P02/label", None, b'{"query": 1, "x": 1e999, "y": 0}', 400, "finite"),
        ("/api/participants/P02/label", {"query": query, "x": "left", "y": 0.0}, None, 400, "finite number"),
        ("/api/participants/P02/label", {"query": query, "x": 0.0, "y": 0.0, "z": 1}, None, 400, "unknown field"),
        (
            "/api/participants/P02/label",
            {"query": query, "x": 0.0, "y": 0.0, "response_seconds": 1e308},
            None,
            400,
            "response_seconds",
        ),
        ("/api/participants/P02/label", None, b"not json", 400, "not valid JSON"),
        ("/api/participants/P02/label", None, b"[1, 2]", 400, "JSON object"),
        ("/api/participants/P02/label", None, b"{" + b" " * MAX_BODY_BYTES + b"}", 413, "larger than"),
        ("/api/participants/P02/label", {"query": query + 7, "x": 0.0, "y": 0.0}, None, 409, "not open"),
        ("/api/participants/P02/label", {"query": True, "x": 0.0, "y": 0.0}, None, 400, "integer id"),
        ("/api/participants/P02/questionnaire", {"trial": 1, "ratings": {}}, None, 409, "no questionnaire"),
        ("/api/participants/P02/start", {}, None, 409, "no trial to start"),
        ("/api/participants/P02/next", {}, None, 409, "no episode has just ended"),
        ("/api/participants/P01/label", {"query": 1, "x": 0.0, "y": 0.0}, None, 409, "no label is asked"),
        ("/api/participants/P02/pause", {"paused": "yes"}, None, 400, "true or false"),
    ]
    for path, payload, raw, status, message in bad:
        if payload is None and raw is None:
            response = client.get(path)
        elif raw is not None:
            response = client.post(path, content=raw, headers={"Content-Type": "application/json"})
        else:
            response = client.post(path, json=payload)
        assert response.status_code == status, (path, payload, raw, response.text)
        assert message in response.json()["error"], (path, response.json())
    assert snapshot(folder) == before


def test_a_label_is_taken_once(served, client):
    state = client.get("/api/participants/P02/state").json()
    query = state["query"]["id"]
    x, y = state["agent"]
    first = client.post("/api/participants/P02/label", json={"query": query, "x": x + 0.3, "y": y})
    assert first.status_code == 200 and first.json()["walked"]
    again = client.post("/api/participants/P02/label", json={"query": query, "x": x + 0.3, "y": y})
    assert again.status_code == 409 and "already answered" in again.json()["error"]


def test_json_parsing_refuses_non_finite_constants():
    for text in (b"NaN", b'{"x": -Infinity}', b"\xff"):
        with pytest.raises(BadInput):
            parse_json_object(text)
    assert parse_json_object(b'{"x": 1.5}') == {"x": 1.5}


def test_the_overview_reads_saved_progress_without_building_sessions(tmp_path):
    from antmaze_hirl.study.store import Study, UnknownParticipant

    study = Study(make_tiny_study(tmp_path / "study", participants=2))
    assert [study.progress(pid) for pid in study.participant_ids] == [(0, "intro"), (0, "intro")]
    assert study._sessions == {}  # no simulators were made for the picker
    study.session("P01").start_trial()
    assert study.progress("P01") == (0, "label")
    with pytest.raises(UnknownParticipant, match="P99"):
        study.progress("P99")
    study.close()


def test_a_click_on_a_wall_or_beyond_the_reach_circle_is_a_400_and_changes_nothing(served, client):
    """The page's wall and reach checks are repeated on the server: a request sent around the page is refused."""
    import numpy as np

    from antmaze_hirl.envs.geometry import MazeGeometry

    _, folder = served
    if client.get("/api/participants/P01/state").json()["phase"] == "intro":
        assert client.post("/api/participants/P01/start", json={}).status_code == 200
    state = client.get("/api/participants/P01/state").json()
    maze, agent = state["maze"], np.asarray(state["agent"])
    geometry = MazeGeometry(maze["rows"], maze["cols"], maze["scale"])
    walls = np.asarray(maze["walls"], dtype=bool)
    low, high = (np.asarray(b) for b in maze["bounds"])
    centres = [
        (geometry.cell_to_xy((r, c)), bool(walls[r, c])) for r in range(maze["rows"]) for c in range(maze["cols"])
    ]
    inside = [(xy, wall) for xy, wall in centres if np.all(low <= xy) and np.all(xy <= high)]
    wall = next(xy for xy, is_wall in inside if is_wall)
    far = max((xy for xy, is_wall in inside if not is_wall), key=lambda xy: np.hypot(*(xy - agent)))
    assert np.hypot(*(far - agent)) > state["subgoal_reach_m"] + 0.1
    before = snapshot(folder)
    query = state["query"]["id"]
    for xy, message in ((wall, "on a wall"), (far, "beyond the reach circle")):
        response = client.post("/api/participants/P01/label", json={"query": query, "x": xy[0], "y": xy[1]})
        assert response.status_code == 400, response.text
        assert message in response.json()["error"] and f"{xy[0]:.3f}" in response.json()["error"]
    assert snapshot(folder) == before
    assert client.get("/api/participants/P01/state").json()["query"]["id"] == query  # still open
