"""Low levels by name (the ant's ``ensemble`` stays loadable and replays the default), and bad low-level zips."""

import dataclasses
import importlib
import json
import zipfile

import pytest

from antmaze_hirl.cli import main
from antmaze_hirl.experiments.benchmark import load_report
from antmaze_hirl.sb3_ext.config import load_config
from antmaze_hirl.sb3_ext.loading import load_low_level, low_level_path, policy_fingerprint, save_policy
from antmaze_hirl.sb3_ext.shipped import shipped_policy_path
from antmaze_hirl.sb3_ext.training import make_model, train_low_level

STAGE6 = "8ae38455d9435335"
"""The fingerprint every committed ant row records (``low_level`` of the benchmark reports, ``low_level_id``)."""


def test_the_ensemble_and_shipped_names_load_the_stage6_ensemble():
    assert low_level_path("ant", "ensemble") == low_level_path("ant", "shipped") == shipped_policy_path("ant")
    assert low_level_path("ant", None) == shipped_policy_path("ant")
    assert policy_fingerprint(load_low_level("ant", "ensemble")) == STAGE6
    assert low_level_path("ant", "runs/x/policy.zip").as_posix() == "runs/x/policy.zip"  # a path stays a path
    with pytest.raises(ValueError, match=r"unknown low level 'single' for the ant: give a zip path or one of"):
        low_level_path("ant", "single")
    with pytest.raises(ValueError, match=r"unknown low level 'ensemble' for the point"):
        low_level_path("point", "ensemble")


def benchmark(tmp_path, name, *extra):
    out = tmp_path / f"{name}.json"
    argv = ["benchmark", "ant4", "--policy", "oracle", "--tasks", "0", "--num-envs", "1", "--no-progress"]
    assert main([*argv, "--json", str(out), *extra]) == 0
    return load_report(out)


def test_the_ensemble_by_name_plays_what_the_default_plays_and_is_recorded(tmp_path):
    default = benchmark(tmp_path, "default")
    by_name = benchmark(tmp_path, "ensemble", "--low-level", "ensemble")
    assert by_name["episode_outcomes"] == default["episode_outcomes"]
    assert default["low_level"] == f"shipped ant policy {STAGE6}"
    assert by_name["low_level"] == f"ensemble: TD3 {STAGE6}"
    assert by_name["command"].endswith("--low-level ensemble --tasks 0")


def damaged_zips(folder):
    """A low-level zip of the wrong body, and ant zips damaged in three ways."""
    shipped = shipped_policy_path("ant").read_bytes()
    truncated = folder / "truncated.zip"
    truncated.write_bytes(shipped[:5000])
    flipped = folder / "flipped.zip"
    middle = bytearray(shipped)
    for index in range(len(middle) // 2, len(middle) // 2 + 200):
        middle[index] ^= 0xFF
    flipped.write_bytes(bytes(middle))
    garbled = folder / "garbled_weights.zip"
    with zipfile.ZipFile(shipped_policy_path("ant")) as source, zipfile.ZipFile(garbled, "w") as target:
        for name in source.namelist():
            target.writestr(name, b"garbage" if name == "policy.pth" else source.read(name))
    return {
        "wrong body": (shipped_policy_path("point"), "wrong checkpoint for this body"),
        "truncated": (truncated, "is not an SB3 policy zip"),
        "flipped bytes": (flipped, "is not a loadable SB3 TD3 zip"),
        "garbled weights": (garbled, "is not a loadable SB3 TD3 zip"),
        "unknown name": ("steady", "unknown low level 'steady' for the ant"),
        "missing file": (folder / "missing.zip", "no low-level policy at"),
    }


CASES = ["wrong body", "truncated", "flipped bytes", "garbled weights", "unknown name", "missing file"]


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("command", ["eval-low", "benchmark"])
def test_a_bad_low_level_is_one_line_naming_it_and_exit_2(tmp_path, capsys, command, case):
    value, message = damaged_zips(tmp_path)[case]
    if command == "eval-low":
        argv = ["eval-low", "--body", "ant", "--policy", str(value), "--episodes", "1"]
    else:
        argv = ["benchmark", "ant4", "--policy", "oracle", "--tasks", "0", "--low-level", str(value), "--no-progress"]
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert exit_info.value.code == 2
    assert len(lines) == 1 and lines[0].startswith(f"antmaze-hirl {command}: error: "), captured.err
    assert message in lines[0] and str(value) in lines[0]
    assert "Traceback" not in captured.err + captured.out


def test_eval_low_takes_the_ensemble_by_name(tmp_path, capsys):
    out = tmp_path / "eval.json"
    assert main(["eval-low", "--body", "ant", "--policy", "ensemble", "--episodes", "2", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["low_level_id"] == f"sha256:{STAGE6}"


@pytest.fixture(scope="module")
def ant_single_actors(tmp_path_factory):
    """Untrained single-actor ant TD3 zips: one of the shipped networks' sizes, one smaller (seed 1: a
    ``train-low`` model of seed 0 holds other weights unless it was warm-started)."""
    folder = tmp_path_factory.mktemp("ant_zips")
    config = load_config("ant")
    zips = {}
    for name, net_arch in {"plain": config.net_arch, "small": (64, 64)}.items():
        # A small replay buffer: the zips hold the policy alone, and a million-step buffer takes seconds to allocate.
        model = make_model("ant", "td3", dataclasses.replace(config, net_arch=net_arch, buffer_size=1_000), seed=1)
        zips[name] = save_policy(model, folder / f"{name}.zip")
    return zips


def bad_warm_starts(folder, single_actors):
    """``train-low --init-from`` values it must refuse, with what the one line says."""
    garbled = folder / "garbled_single.zip"
    with zipfile.ZipFile(single_actors["plain"]) as source, zipfile.ZipFile(garbled, "w") as target:
        for name in source.namelist():
            target.writestr(name, b"garbage" if name == "policy.pth" else source.read(name))
    cases = damaged_zips(folder)
    return {
        "wrong body": cases["wrong body"],
        "truncated": cases["truncated"],
        "garbled weights": (garbled, "is not a loadable SB3 TD3 zip"),
        "unknown name": cases["unknown name"],
        "missing file": (folder / "missing.zip", "no such file"),
        "ensemble": (shipped_policy_path("ant"), "is an action ensemble"),
        "other networks": (single_actors["small"], "holds networks that differ from this config's"),
    }


@pytest.mark.parametrize(
    "case", ["wrong body", "truncated", "garbled weights", "unknown name", "missing file", "ensemble", "other networks"]
)
def test_a_bad_warm_start_is_one_line_naming_it_exit_2_and_no_run(tmp_path, capsys, ant_single_actors, case):
    value, message = bad_warm_starts(tmp_path, ant_single_actors)[case]
    out = tmp_path / "run"
    argv = ["train-low", "--body", "ant", "--timesteps", "1", "--out", str(out), "--init-from", str(value)]
    with pytest.raises(SystemExit) as exit_info:
        main([*argv, "--no-progress"])
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert exit_info.value.code == 2
    assert len(lines) == 1 and lines[0].startswith("antmaze-hirl train-low: error: "), captured.err
    assert message in lines[0] and str(value) in lines[0]
    assert "Traceback" not in captured.err + captured.out
    assert not (out / "policy.zip").exists()


@pytest.mark.integration
def test_a_single_actor_ant_zip_warm_starts_every_weight(tmp_path, ant_single_actors):
    source = policy_fingerprint(load_low_level("ant", ant_single_actors["plain"]))
    cold = train_low_level("ant", "td3", 0, tmp_path / "cold", seed=0, progress_bar=False)
    warm = train_low_level(
        "ant", "td3", 0, tmp_path / "warm", seed=0, init_from=ant_single_actors["plain"], progress_bar=False
    )
    assert policy_fingerprint(warm) == source != policy_fingerprint(cold)


SCRIPT_ARGV = {
    "in_maze": ["--episodes", "1", "--families", "ant3", "--low-level"],
    "select_low_level": ["--episodes", "1", "--mazes", "1"],  # the policy file goes last
}
"""Each lab module that plays a low-level zip (``python -m antmaze_lab.X``), with the arguments before the bad value."""


@pytest.mark.integration  # a lab check (antmaze_lab.in_maze and select_low_level)
@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("script", sorted(SCRIPT_ARGV))
def test_the_lab_scripts_refuse_a_bad_low_level_in_one_line_before_any_episode(
    tmp_path, capsys, monkeypatch, script, case
):
    value, message = damaged_zips(tmp_path)[case]
    if script == "select_low_level" and case in ("unknown name", "missing file"):
        message = "neither a policy file nor a run with a snapshots/ folder"  # it takes files and run folders
    module = importlib.import_module(f"antmaze_lab.{script}")
    out = tmp_path / "out.json"
    monkeypatch.setattr("sys.argv", [f"{script}.py", *SCRIPT_ARGV[script], str(value), "--out", str(out)])
    with pytest.raises(SystemExit) as exit_info:
        module.main()
    captured = capsys.readouterr()
    last = captured.err.strip().splitlines()[-1]  # argparse's usage, then the one error line
    assert exit_info.value.code == 2
    assert last.startswith(f"python -m antmaze_lab.{script}: error: "), captured.err
    assert message in last and str(value) in last, captured.err
    assert "Traceback" not in captured.err + captured.out
    assert not out.exists()
