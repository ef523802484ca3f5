"""antmaze_hirl.experiments.labels_vs_steps: the leaderboard figure's points, one series per trainer and seed."""

import shutil
from pathlib import Path

from antmaze_hirl.experiments.labels_vs_steps import figure_points

LEADERBOARD = Path(__file__).resolve().parents[1] / "results" / "leaderboard"


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
