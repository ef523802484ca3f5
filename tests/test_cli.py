import subprocess
import sys
from pathlib import Path

import pytest

from antmaze_hirl.cli import build_parser, main


@pytest.mark.parametrize("command", ["demo", "train-low", "eval-low", "experiment"])
def test_every_subcommand_has_help(command, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main([command, "--help"])
    assert exit_info.value.code == 0
    assert f"antmaze-hirl {command}" in capsys.readouterr().out


def test_demo_writes_picture_and_reports(tmp_path, capsys):
    assert main(["demo", "--seed", "1", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("success:") and "subgoals" in out
    picture = tmp_path / "demo.png"
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_console_script_is_installed():
    script = Path(sys.executable).parent / "antmaze-hirl"
    result = subprocess.run([str(script), "--help"], capture_output=True, text=True, check=True)
    assert "demo" in result.stdout and "train-low" in result.stdout


def test_unknown_body_is_rejected(capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args(["demo", "--body", "spider"])
    assert "invalid choice: 'spider'" in capsys.readouterr().err
