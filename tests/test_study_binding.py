"""Token and binding: the token from the environment, long enough; a wildcard host prints a URL that works."""

import json

import httpx
import pytest
from study_helpers import make_tiny_study

from antmaze_hirl.cli import main
from antmaze_hirl.study.plan import load_plan
from antmaze_hirl.study.server import MIN_TOKEN_CHARS, TOKEN_ENV, StudyServer, resolve_token, url_host_and_allowed


def test_a_token_under_16_characters_is_refused(tmp_path, monkeypatch, capsys):
    folder = make_tiny_study(tmp_path / "study")
    with pytest.raises(ValueError, match=f"at least {MIN_TOKEN_CHARS} characters, got 15"):
        StudyServer(folder, token="x" * 15)
    monkeypatch.setenv(TOKEN_ENV, "short")
    with pytest.raises(SystemExit) as exited:  # the CLI in-process, as the console script runs it
        main(["study", "serve", str(folder), "--port", "0"])
    stderr = capsys.readouterr().err
    assert exited.value.code == 2 and stderr.count("\n") == 1, stderr
    assert "at least 16 characters, got 5" in stderr
    assert not (folder / "server.lock").exists() or StudyServer(folder, token="y" * 16).stop() is None  # released


def test_the_token_comes_from_the_environment_so_it_is_not_in_ps(monkeypatch):
    monkeypatch.setenv(TOKEN_ENV, "from-the-environment-0123")
    assert resolve_token(None) == "from-the-environment-0123"
    assert resolve_token("given-on-the-command-line") == "given-on-the-command-line"
    monkeypatch.delenv(TOKEN_ENV)
    assert len(resolve_token(None)) >= 32  # a fresh random one


def test_a_wildcard_host_prints_a_url_its_own_host_check_accepts(tmp_path):
    folder = make_tiny_study(tmp_path / "study")
    url_host, hosts = url_host_and_allowed("0.0.0.0")
    assert url_host not in ("0.0.0.0", "") and url_host.lower() in hosts
    with StudyServer(folder, host="0.0.0.0", token="wildcard-token-0123456789").running() as server:
        assert server.url.startswith(f"http://{url_host}:")
        # Whatever the name resolves to, the browser sends it as Host: connect by loopback, present it.
        page = httpx.get(
            f"http://127.0.0.1:{server.port}/",
            params={"token": server.token},
            headers={"Host": f"{url_host}:{server.port}"},
        )
        assert page.status_code == 200
        foreign = httpx.get(
            f"http://127.0.0.1:{server.port}/", params={"token": server.token}, headers={"Host": "evil.example"}
        )
        assert foreign.status_code == 403


def test_plan_ids_are_validated_as_safe_names_on_load(tmp_path):
    folder = make_tiny_study(tmp_path / "study")
    plan = json.loads((folder / "plan.json").read_text())
    for bad in ("../../x", "a/b", "P\x0001", "", "..", "Pé"):
        plan["participants"][0]["id"] = bad
        (folder / "plan.json").write_text(json.dumps(plan))
        with pytest.raises(ValueError, match="not a safe name"):
            load_plan(folder)


def test_study_settings_never_hold_nan_or_infinity():
    from antmaze_hirl.study.settings import StudySettings

    for value in (float("inf"), float("nan")):
        with pytest.raises(ValueError, match="subgoal_reach_m must be"):
            StudySettings.for_body("point", subgoal_reach_m=value)


def test_deleting_server_lock_lets_no_second_server_in(tmp_path):
    from study_helpers import make_tiny_study

    from antmaze_hirl.study.store import StudyInUse, StudyLock

    folder = make_tiny_study(tmp_path / "study")
    first = StudyLock(folder)
    try:
        (folder / StudyLock.FILE_NAME).unlink()  # the file goes; the folder's OS lock stays
        with pytest.raises(StudyInUse, match="already served"):
            StudyLock(folder)
    finally:
        first.release()
    StudyLock(folder).release()  # free again once the first lets go
