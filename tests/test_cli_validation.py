"""Every numeric option of every subcommand is bounded at parse time: exit 0 or 2 with one line, never a traceback."""

import argparse
import math
import os
import subprocess
import sys

import pytest

from antmaze_hirl.cli import build_parser
from antmaze_hirl.cli_validation import FloatBounds, IntBounds, apply_bounds, numeric_options

HOSTILE = ["0", "-1", "nan", "inf", "1e309", "99999999999999999999", "-99999999999999999999"]
"""What the attack gave every option: zero, negative, NaN, infinity, past a float, 20-digit integers."""

REQUIRED = {
    "demo": [],
    "train-low": ["--body", "point", "--timesteps", "10", "--out", "runs/x"],
    "eval-low": ["--body", "point"],
    "ensemble-low": ["--body", "point", "--out", "x.zip"],
    "experiment": ["--out", "runs/x"],
    "study init": ["runs/x", "--body", "point", "--participants", "2"],
    "study serve": ["runs/x"],
    "study simulate": ["runs/x"],
    "benchmark": ["point5", "--policy", "random"],
    "submit": ["report.json"],
}
"""What each subcommand needs besides the option under test, so that an accepted value parses whole."""

OPTIONS = [(command, action) for command, action in numeric_options(build_parser())]


def test_the_parsers_declare_numeric_options_and_every_one_is_bounded():
    assert len(OPTIONS) >= 30  # the walk found the subcommands' options, not only the top level
    assert {command for command, _ in OPTIONS} <= set(REQUIRED)
    for command, action in OPTIONS:
        assert isinstance(action.bounds, IntBounds | FloatBounds), (command, action.option_strings)


def test_an_option_without_declared_bounds_is_refused_when_the_parser_is_built():
    parser = argparse.ArgumentParser(prog="antmaze-hirl")
    parser.add_argument("--new-knob", type=int, default=1)
    with pytest.raises(KeyError, match="--new-knob"):
        apply_bounds(parser)


@pytest.mark.parametrize(
    ("command", "option"),
    [(command, action.option_strings[0]) for command, action in OPTIONS],
    ids=[f"{command}{action.option_strings[0]}" for command, action in OPTIONS],
)
def test_hostile_values_exit_0_or_2_with_one_line_and_no_traceback(command, option, capsys):
    parser = build_parser()
    for value in HOSTILE:
        argv = [*command.split(), *REQUIRED[command], f"{option}={value}"]
        try:
            args = parser.parse_args(argv)
        except SystemExit as exit_info:
            assert exit_info.code == 2, (argv, exit_info.code)
            err = capsys.readouterr().err
            assert err.count("\n") == 1 and f"error: {option} must be " in err, (argv, err)
            assert "Traceback" not in err and value[:20] in err  # names the value
            continue
        # Accepted: a finite value within the declared bounds (0 for a practice count, a port, a seed...).
        parsed = getattr(args, next(a.dest for c, a in OPTIONS if c == command and option in a.option_strings))
        assert math.isfinite(parsed) and value in ("0",), (argv, parsed)


def test_refused_values_write_nothing_and_import_no_torch(tmp_path):
    out = tmp_path / "results"
    code = (
        "import sys\nfrom antmaze_hirl.cli import main\n"
        "try:\n    main(sys.argv[1:])\nexcept SystemExit as e:\n"
        "    assert 'torch' not in sys.modules, 'torch imported'\n    raise\n"
    )
    cases = [
        ["experiment", "--decay", "nan", "--out", str(out)],
        ["experiment", "--maze-size", "99999999999999999999", "--out", str(out)],
        ["experiment", "--subgoal-reach-m", "inf", "--out", str(out)],
        ["study", "init", str(out), "--body", "point", "--participants", "2", "--subgoal-reach-m", "inf"],
    ]
    env = {**os.environ, "PYTHONPATH": os.getcwd()}
    for argv in cases:
        run = subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True, env=env, timeout=60)
        assert run.returncode == 2 and run.stderr.count("\n") == 1, (argv, run.stderr)
        assert not out.exists(), argv
