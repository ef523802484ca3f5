import os

import pytest

from antmaze_hirl.atomic_io import atomic_write_json, atomic_write_with


def test_a_failed_write_keeps_the_old_file_and_leaves_no_temp_file(tmp_path):
    target = atomic_write_json(tmp_path / "study.json", {"participants": 3})

    def crash_half_way(tmp):
        tmp.write_text('{"participa')
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        atomic_write_with(target, crash_half_way)
    assert target.read_text() == '{\n  "participants": 3\n}\n'
    assert os.listdir(tmp_path) == ["study.json"]


def test_writers_get_their_own_temp_file_beside_the_target(tmp_path):
    seen = []
    for _ in range(2):
        atomic_write_with(tmp_path / "policy.zip", lambda tmp: seen.append(tmp) or tmp.write_bytes(b"PK"))
    assert seen[0] != seen[1] and all(tmp.parent == tmp_path and tmp.suffix == ".zip" for tmp in seen)
    plain = tmp_path / "plain.bin"
    plain.write_bytes(b"")  # a file written the usual way: the permissions the umask gives
    assert oct((tmp_path / "policy.zip").stat().st_mode & 0o777) == oct(plain.stat().st_mode & 0o777)


def test_strict_json_refuses_nan_and_infinity_and_keeps_the_old_file(tmp_path):
    target = atomic_write_json(tmp_path / "settings.json", {"subgoal_reach_m": 2.0})
    for bad in (float("nan"), float("inf")):
        with pytest.raises(ValueError, match=r"settings.json: .*not JSON"):
            atomic_write_json(target, {"subgoal_reach_m": bad}, allow_nan=False)
    assert target.read_text() == '{\n  "subgoal_reach_m": 2.0\n}\n'
    assert os.listdir(tmp_path) == ["settings.json"]


def test_trim_torn_tail_cuts_only_a_partial_last_line(tmp_path):
    from antmaze_hirl.atomic_io import trim_torn_tail

    log = tmp_path / "events.jsonl"
    assert trim_torn_tail(log) == b""  # missing: nothing to do
    log.write_bytes(b'{"a": 1}\n{"b": 2}\n')
    assert trim_torn_tail(log) == b"" and log.read_bytes() == b'{"a": 1}\n{"b": 2}\n'
    log.write_bytes(b'{"a": 1}\n{"b": 2}\n{"c"')
    assert trim_torn_tail(log) == b'{"c"' and log.read_bytes() == b'{"a": 1}\n{"b": 2}\n'
    log.write_bytes(b"x" * 200_000)  # a torn first line longer than one read block
    assert len(trim_torn_tail(log)) == 200_000 and log.read_bytes() == b""
