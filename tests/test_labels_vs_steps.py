"""antmaze_lab.labels_vs_steps: the leaderboard figure's points, one series per trainer and seed."""

import json
import shutil
from pathlib import Path

import pytest

from antmaze_lab.labels_vs_steps import figure_points

LEADERBOARD = Path(__file__).resolve().parents[1] / "results" / "leaderboard"

pytestmark = pytest.mark.integration  # every test reads the committed leaderboard reports


def test_an_active_methods_curve_is_its_own_series_beside_plain_daggers(tmp_path):
    for name in ("point5_dagger_protocol_s0_100.json", "point5_gated_protocol_s0_100.json", "point5_oracle.json"):
        shutil.copy(LEADERBOARD / name, tmp_path / name)
    points, lines = figure_points(tmp_path)
    assert sorted(point.series for point in points) == [
        "DAgger (plain), protocol learner, seed 0",
        "DAgger with `gated`, protocol learner, seed 0",
    ]
    assert all(point.x_kind == "labels" and 100 <= point.x <= 110 for point in points)
    assert set(lines) == {"oracle"}


def test_each_rl_seed_is_its_own_series(tmp_path):
    report = json.loads((LEADERBOARD / "point5_ppo_rl_s0.json").read_text())
    for seed in (0, 1):
        report["training"]["seed"] = seed
        (tmp_path / f"point5_ppo_rl_s{seed}.json").write_text(json.dumps(report))
    points, _ = figure_points(tmp_path)
    assert [point.series for point in points] == [
        "SB3 PPO on the high level, 8 mazes, seed 0",
        "SB3 PPO on the high level, 8 mazes, seed 1",
    ]


def test_each_family_suite_has_its_own_figure_and_points(tmp_path):
    from antmaze_lab.labels_vs_steps import figure_path

    for name in ("point5_dagger_protocol_s0_100.json", "ant4_dagger_protocol_s0_100.json", "ant4_oracle.json"):
        shutil.copy(LEADERBOARD / name, tmp_path / name)
    points, lines = figure_points(tmp_path, "ant4")
    assert [point.file for point in points] == ["ant4_dagger_protocol_s0_100.json"] and set(lines) == {"oracle"}
    assert figure_path("ant4").name == "ant4_labels_vs_steps.png"
    with pytest.raises(ValueError, match="suite 'u' has no labels-against-steps figure"):
        figure_points(tmp_path, "u")
