"""End to end in a real browser: Debian's chromium, driven by Playwright, clicks through a tiny study."""

import csv
import json
import shutil
import time
from pathlib import Path

import pytest
from study_helpers import make_tiny_study

from antmaze_hirl.study.simulate import oracle_click

# End to end (see pyproject.toml's markers): left out of the default unit tier, run by .ci/run.
pytestmark = pytest.mark.integration

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
SCREENSHOT = Path(__file__).resolve().parent.parent / "docs" / "images" / "study_page.png"

playwright_api = pytest.importorskip("playwright.sync_api", reason="playwright is a test dependency (.[dev])")
if not Path(CHROMIUM).exists():
    pytest.skip("Debian's chromium is not installed (.ci/setup installs it with apt-get)", allow_module_level=True)


def canvas_point(page, state, xy):
    """Page pixels of world point ``xy`` on the maze canvas (the page's own transform, read back)."""
    return page.evaluate(
        """([xy]) => {
            const canvas = document.getElementById('maze');
            const rect = canvas.getBoundingClientRect();
            const [px, py] = toCanvas(state.maze, xy);
            return [rect.left + px * rect.width / canvas.width, rect.top + py * rect.height / canvas.height];
        }""",
        [list(map(float, xy))],
    )


def click_until(page, phases, save_screenshot=False):
    """Clicks the oracle's subgoal on the canvas until the page's phase is one of ``phases``."""
    shot = False
    while True:
        page.wait_for_function("() => !busy && state", timeout=120_000)  # a replay of the learner's steps ends
        state = page.evaluate("() => state")
        if state["phase"] in phases:
            return state
        assert state["phase"] == "label", state
        if save_screenshot and not shot and state["query"]["label_index"] == 2:
            SCREENSHOT.parent.mkdir(parents=True, exist_ok=True)
            page.screenshot(path=str(SCREENSHOT))
            shot = True
        x, y = canvas_point(page, state, oracle_click(state))
        query = state["query"]["id"]
        page.mouse.click(x, y)
        page.wait_for_function(
            "([q]) => !busy && state && (state.phase !== 'label' || state.query.id !== q)", arg=[query], timeout=120_000
        )


def open_page(playwright, url):
    """Chromium on the study page, P01 picked; the list of page errors fills as they happen."""
    browser = playwright.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
    page = browser.new_page(viewport={"width": 1100, "height": 800})
    errors = []
    page.on("pageerror", lambda error: errors.append(str(error)))
    page.goto(url)
    page.get_by_role("button", name="P01").click()
    return browser, page, errors


def test_a_participant_clicks_through_practice_and_a_trial_in_chromium(tmp_path):
    from antmaze_hirl.study.server import StudyServer

    folder = make_tiny_study(tmp_path / "study", participants=1, methods=("dagger", "noise"), episodes=1, practice=1)
    with StudyServer(folder).running() as server, playwright_api.sync_playwright() as p:
        browser, page, errors = open_page(p, server.url)
        page.get_by_role("button", name="Start").wait_for()
        assert "Practice" in page.locator("#intro-title").inner_text()
        page.get_by_role("button", name="Start").click()
        page.wait_for_function("() => state && state.phase === 'label'")
        progress = page.locator("#progress").inner_text()
        assert "Participant P01" in progress and "Maze 1 of 1" in progress
        # P pauses: clicks are ignored meanwhile
        page.keyboard.press("p")
        page.wait_for_function("() => state.paused")
        assert page.locator("#paused").is_visible()
        page.keyboard.press("p")
        page.wait_for_function("() => !state.paused")
        state = click_until(page, ("intro",), save_screenshot=True)  # the practice ends: the first trial's intro
        assert state["trial"]["label"].startswith("Method ")
        assert "dagger" not in page.content() and "noise" not in page.locator("body").inner_text()
        page.get_by_role("button", name="Start").click()
        page.wait_for_function("() => state && state.phase === 'label'")
        click_until(page, ("questionnaire",))
        page.locator("#items input").first.wait_for()
        page.get_by_role("button", name="Submit").click()
        assert "Please answer" in page.locator("#form-error").inner_text()  # nothing sent while items are missing
        for item, value in zip(
            ("mental_demand", "physical_demand", "temporal_demand", "performance", "effort", "frustration"),
            (4, 1, 3, 2, 4, 2),
            strict=True,
        ):
            page.locator(f"input[name='{item}'][value='{value}']").check()
        page.locator("#comment").fill("the robot was slow")
        page.get_by_role("button", name="Submit").click()
        page.wait_for_function("() => state && state.phase === 'intro'")
        browser.close()
    assert errors == []
    participant = folder / "participants" / "P01"
    with (participant / "episodes.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert [(r["trial"], r["practice"]) for r in rows] == [("0", "True"), ("1", "False")]
    assert all(float(r["seconds_per_label"]) > 0 for r in rows)  # measured by the page
    (answer,) = [json.loads(line) for line in (participant / "answers.jsonl").open()]
    assert answer["ratings"]["mental_demand"] == 4 and answer["comment"] == "the robot was slow"
    events = [json.loads(line)["event"] for line in (participant / "events.jsonl").open()]
    assert events.count("pause") == events.count("resume") == 1
    assert SCREENSHOT.stat().st_size > 10_000


def test_a_gated_trial_replays_the_learners_own_steps_in_chromium(tmp_path, monkeypatch):
    from antmaze_hirl.dagger import GatedQuery
    from antmaze_hirl.study.server import StudyServer

    # Once D holds labels the gate opens only at no-ops: mazes are walked, in part or whole, without a question.
    monkeypatch.setattr(GatedQuery, "wants_label", lambda self, observation, subgoal, learner: False)
    folder = make_tiny_study(tmp_path / "study", participants=1, methods=("gated",), episodes=3, practice=0)
    with StudyServer(folder).running() as server, playwright_api.sync_playwright() as p:
        browser, page, errors = open_page(p, server.url)
        page.get_by_role("button", name="Start").click()
        page.wait_for_function("() => state && state.phase === 'label'")
        click_until(page, ("questionnaire",))
        browser.close()
    assert errors == []
    with (folder / "participants" / "P01" / "episodes.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 3 and sum(int(r["expert_cost"]) for r in rows[1:]) < sum(int(r["attempts"]) for r in rows[1:])


BUSY_LOG = """
window.busySeen = [];
new MutationObserver(() => {
  const box = document.getElementById('busy');
  const text = box && !box.hidden ? document.getElementById('busy-text').textContent : null;
  if (text && window.busySeen[window.busySeen.length - 1] !== text) { window.busySeen.push(text); }
}).observe(document, { subtree: true, attributes: true, childList: true, characterData: true });
"""
"""Records each sentence the busy indicator shows, however briefly (a DOM observer, set up before the page runs)."""


def press_tab_until(page, name, limit=30):
    """Tabs through the page until the focused element is the button ``name``: reachable by keyboard."""
    for _ in range(limit):
        page.keyboard.press("Tab")
        if page.evaluate("() => document.activeElement && document.activeElement.textContent.trim()") == name:
            return
    raise AssertionError(f"no Tab stop reaches the button {name!r}")


def refused_points(state):
    """A point too far for the circle, and one on an inner wall (if the maze has one), both inside the bounds."""
    maze = state["maze"]
    low, high = maze["bounds"]
    agent, scale = state["agent"], maze["scale"]
    too_far = wall = None
    for row, cells in enumerate(maze["walls"]):
        for col, is_wall in enumerate(cells):
            xy = [maze["low"][0] + (col + 0.5) * scale, maze["high"][1] - (row + 0.5) * scale]
            if not (low[0] <= xy[0] <= high[0] and low[1] <= xy[1] <= high[1]):
                continue
            far = ((xy[0] - agent[0]) ** 2 + (xy[1] - agent[1]) ** 2) ** 0.5 > 1.2 * state["subgoal_reach_m"]
            if is_wall and wall is None:
                wall = xy
            elif far and not is_wall and too_far is None:
                too_far = xy
    return too_far, wall


@pytest.mark.parametrize(("width", "height"), [(1280, 800), (1024, 640)])
def test_the_page_refuses_bad_clicks_shows_busy_and_summary_and_fits_the_window(tmp_path, width, height):
    from antmaze_hirl.study.server import StudyServer

    folder = make_tiny_study(
        tmp_path / "study", participants=1, methods=("dagger",), episodes=1, practice=2, background_updates=True
    )
    images = SCREENSHOT.parent
    with StudyServer(folder).running() as server, playwright_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        page = browser.new_page(viewport={"width": width, "height": height})
        errors, labels = [], []
        page.on("pageerror", lambda error: errors.append(str(error)))
        page.on("request", lambda request: labels.append(request.url) if request.url.endswith("/label") else None)
        page.add_init_script(BUSY_LOG)
        page.goto(server.url)
        page.get_by_role("button", name="P01").wait_for()
        press_tab_until(page, "P01")  # keyboard only, up to the first maze
        page.keyboard.press("Enter")
        page.get_by_role("button", name="Start").wait_for()
        assert page.locator("#intro-learner").is_visible()  # the orange suggestion is explained
        assert "This part has 2 mazes and takes about" in page.locator("#intro-length").inner_text()
        press_tab_until(page, "Start")
        page.keyboard.press("Enter")
        page.keyboard.press("Enter")  # a double start sends one request and shows no protocol error
        page.wait_for_function("() => state && state.phase === 'label' && !busy", timeout=120_000)
        assert "maze is loading" in " ".join(page.evaluate("() => window.busySeen"))
        assert page.locator("#error").inner_text() == ""
        # The scaled canvas fits the window whole, and clicks still land where the page means them.
        box = page.locator("#maze").bounding_box()
        rect = [box["x"] + box["width"], box["y"] + box["height"], box["width"]]
        assert rect[0] <= width and rect[1] <= height, rect
        if height <= 640:
            assert rect[2] < 640  # scaled down
        walls_refused = 0
        while True:
            state = page.evaluate("() => state")
            if state["phase"] != "label":
                break
            too_far, wall = refused_points(state)
            for xy, words in ((too_far, "Too far"), (wall, "wall")):
                if xy is None:
                    continue
                sent = len(labels)
                page.mouse.click(*canvas_point(page, state, xy))
                assert words in page.locator("#status").inner_text()
                assert len(labels) == sent  # refused on the page: nothing was sent
                walls_refused += words == "wall"
            if state["query"]["label_index"] == 1 and not (images / f"study_page_{width}x{height}.png").exists():
                page.screenshot(path=str(images / f"study_page_{width}x{height}.png"))
            state = click_until_next_query(page, state)
            if state["phase"] == "intro":
                break
        assert state["phase"] == "intro" and page.locator("#summary").is_visible()
        summary = page.locator("#summary").inner_text()
        assert summary.startswith("Practice finished: the robot reached the goal in ") and " of 2 mazes" in summary
        assert any("learning from your points" in text for text in page.evaluate("() => window.busySeen"))
        page.screenshot(path=str(images / f"study_summary_{width}x{height}.png"))
        text = page.locator("body").inner_text()
        assert "'label'" not in text and "'intro'" not in text and "episode_over" not in text
        # What the server's refusals (HTTP 409) become on the page: instructions, never its state names.
        shown = page.evaluate(
            """() => [
                plainMessage(new StudyError(409, "no trial to start: participant P01 is at 'label'"), "start"),
                plainMessage(new StudyError(409, "no episode has just ended (participant P01 is at 'intro')"), "next"),
                plainMessage(new StudyError(409, "the study is paused: resume before clicking"), "label"),
                plainMessage(new StudyError(409, "participant P01: progress.json is not a participant's"), "load"),
            ]"""
        )
        assert shown == [
            "Please wait, the maze is loading.",
            "Please wait, the next maze is loading.",
            "The study is paused: press P to continue.",
            "Your session cannot go on from here: please call the experimenter.",
        ]
        browser.close()
    assert errors == []
    assert walls_refused >= 1  # the seeded mazes have inner walls: the wall refusal was tried


def click_until_next_query(page, state):
    """One oracle click; waits until the page shows the next query or leaves the maze phase."""
    x, y = canvas_point(page, state, oracle_click(state))
    query = state["query"]["id"]
    page.mouse.click(x, y)
    page.wait_for_function(
        "([q]) => !busy && state && (state.phase !== 'label' || state.query.id !== q)", arg=[query], timeout=120_000
    )
    return page.evaluate("() => state")


def test_the_page_says_plainly_when_a_finished_parts_results_are_not_saved_yet(tmp_path, monkeypatch):
    from study_helpers import ClosingDisk, play_trial

    from antmaze_hirl.study.server import StudyServer
    from antmaze_hirl.study.session import TrialClosing

    monkeypatch.setattr(TrialClosing, "RETRY_FIRST_SECONDS", 0.05)
    monkeypatch.setattr(TrialClosing, "RETRY_MAX_SECONDS", 0.05)
    folder = make_tiny_study(
        tmp_path / "study", participants=1, methods=("dagger",), episodes=1, practice=0, background_updates=True
    )
    disk = ClosingDisk(monkeypatch, lambda path: True)  # the finished part's last writes fail until freed
    with StudyServer(folder).running() as server, playwright_api.sync_playwright() as p:
        session = server.study.session("P01")
        play_trial(session)  # to the questionnaire, through the session (the page's clicks are tested above)
        deadline = time.monotonic() + 60
        while not session.state().get("unsaved"):
            assert time.monotonic() < deadline, "the closing's writes never failed"
            time.sleep(0.05)
        browser, page, errors = open_page(p, server.url)
        page.wait_for_function("() => state && state.phase === 'questionnaire'")
        notice = page.locator("#unsaved")
        assert notice.is_visible()
        assert notice.inner_text() == (
            f"Not everything is saved yet: the results of {session.trial.label} could not be written (No space "
            "left on device), and the computer keeps trying. You can go on, but please tell the experimenter."
        )
        # An alert is announced again whenever its text is written: a render with the same notice writes nothing.
        page.evaluate(
            "() => { window.unsavedWrites = 0; new MutationObserver((m) => { window.unsavedWrites += m.length; })"
            ".observe(document.getElementById('unsaved'), {childList: true, characterData: true, subtree: true}); }"
        )
        page.evaluate("async () => { await render(); await render(); }")
        assert page.evaluate("() => new Promise((done) => setTimeout(() => done(window.unsavedWrites), 100))") == 0
        disk.free()
        while session.state().get("unsaved"):  # until a retry gets through (wait_for_closed_trials raises meanwhile)
            assert time.monotonic() < deadline + 60, "the closing's writes never got through"
            time.sleep(0.05)
        assert session.wait_for_closed_trials(timeout=60)
        for item in ("mental_demand", "physical_demand", "temporal_demand", "performance", "effort", "frustration"):
            page.locator(f"input[name='{item}'][value='3']").check()
        page.get_by_role("button", name="Submit").click()
        page.wait_for_function("() => state && state.phase === 'done'")
        assert not notice.is_visible()  # saved: the notice is gone
        browser.close()
    assert errors == []
