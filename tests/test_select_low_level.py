"""antmaze_lab.select_low_level: its mazes are selection sets, apart from every reported family."""

import json
import sys
from pathlib import Path

import pytest
from conftest import StillController

from antmaze_hirl.envs.layout_splits import layout_split
from antmaze_hirl.envs.layouts import validate_maze_map
from antmaze_lab import in_maze_protocol as in_maze
from antmaze_lab import select_low_level

pytestmark = pytest.mark.integration  # a lab check (antmaze_lab.select_low_level): the integration tier

SHIPPED = Path(__file__).parents[1] / "antmaze_hirl" / "policies" / "ant_td3.zip"


def test_the_families_follow_the_protocol_flags():
    assert select_low_level.selection_families(held_out_layouts=False, large_mazes=False) == ["ant3"]
    assert select_low_level.selection_families(held_out_layouts=True, large_mazes=False) == ["select4"]
    assert select_low_level.selection_families(held_out_layouts=True, large_mazes=True) == ["select4", "select6"]
    with pytest.raises(ValueError, match="--large-mazes needs --held-out-layouts"):
        select_low_level.selection_families(held_out_layouts=False, large_mazes=True)


def test_a_row_is_scored_on_the_selection_seeds_at_its_smoothing(monkeypatch):
    played = []

    def fake_play(paths, families, *, episodes, seed, smoothing, jobs):
        played.append((families, episodes, seed, smoothing))
        success = {"select4": 0.5, "select6": 0.25}
        return {
            in_maze.row_name(path, smoothing[0]): {
                "low_level_id": "id",
                "families": {f: {"success_rate": success[f], "flips_per_subgoal": 0.0} for f in families},
            }
            for path in paths
        }

    smoothed = []

    def fake_eval_low(path, smoothing, seed, episodes):
        smoothed.append((smoothing, seed, episodes))
        return {"eval_low": 0.75, "eval_low_mean_steps": 9.0}

    monkeypatch.setattr(select_low_level, "play_families", fake_play)
    monkeypatch.setattr(select_low_level, "eval_low", fake_eval_low)
    rows = select_low_level.score_rows([Path("p.zip")], 0.3, ["select4", "select6"], seed=100_000, episodes=2, mazes=3)
    assert played == [(["select4", "select6"], 3, select_low_level.SELECTION_MAZE_SEED, (0.3,))]
    assert smoothed == [(0.3, 100_000, 2)]  # both figures smoothed
    row = rows["p.zip smoothing=0.3"]
    assert row["score"] == pytest.approx((0.75 + 0.5 + 0.25) / 3)
    assert row["success"] == {"select4": 0.5, "select6": 0.25} and row["action_smoothing"] == 0.3


def walls_of(family, first_seed, count):
    env = in_maze.family_env(family, StillController())
    grids = []
    for seed in range(first_seed, first_seed + count):
        env.reset(seed=seed)
        grids.append(env.unwrapped.layout)
    env.close()
    return env, grids


def test_selection_mazes_share_no_wall_grid_with_the_reported_ant4_mazes():
    _, selection = walls_of("select4", select_low_level.SELECTION_MAZE_SEED, 15)
    _, reported = walls_of("ant4", 1_000_000, 15)
    assert {layout_split(layout) for layout in selection} == {"selection"}
    assert {layout_split(layout) for layout in reported} == {"eval"}
    assert not {layout.walls.tobytes() for layout in selection} & {layout.walls.tobytes() for layout in reported}


def test_the_large_selection_mazes_have_medium_s_grid_and_a_path_scaled_limit():
    env, layouts = walls_of("select6", select_low_level.SELECTION_MAZE_SEED, 5)
    assert {layout_split(layout) for layout in layouts} == {"selection"}
    assert {layout.walls.shape for layout in layouts} == {validate_maze_map("medium").shape}
    last = layouts[-1]
    assert env.max_steps == in_maze.step_limit(last.walls, last.start_cell, last.goal_cell, 4.0)
    small = in_maze.family_env("select4", StillController())
    small.reset(seed=select_low_level.SELECTION_MAZE_SEED)
    assert small.max_steps == 500  # ant4's budget, unscaled


def run_main(monkeypatch, *args):
    monkeypatch.setattr(sys, "argv", ["antmaze_lab.select_low_level", *map(str, args)])
    select_low_level.main()


@pytest.mark.integration  # end to end: the script's main plays the shipped ant in mazes
def test_main_scores_each_row_once_and_reuses_the_cache(monkeypatch, tmp_path, capsys):
    out = tmp_path / "selection.json"
    flags = [SHIPPED, "--held-out-layouts", "--episodes", 2, "--mazes", 1, "--action-smoothing", "0,0.5", "--out", out]
    run_main(monkeypatch, *flags)
    saved = json.loads(out.read_text())
    assert sorted(saved["scores"]) == [str(SHIPPED), f"{SHIPPED} smoothing=0.5"]
    assert saved["settings"]["families"] == ["select4"]
    assert saved["scores"][saved["best"]]["score"] == max(row["score"] for row in saved["scores"].values())

    def refuse(*args, **kwargs):
        raise AssertionError("a cached row was scored again")

    monkeypatch.setattr(select_low_level, "score_rows", refuse)
    run_main(monkeypatch, *flags)
    assert json.loads(out.read_text())["scores"] == saved["scores"]


@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (["--large-mazes"], "--large-mazes needs --held-out-layouts"),
        (["--action-smoothing", "0,1.5"], "action smoothing must lie in [0, 1), got 1.5"),
        (["--mazes", "0"], "--mazes must be >= 1, got 0"),
        (["--seed", "0"], "overlap range(0, 1000)"),
    ],
)
def test_bad_flags_are_refused_in_one_line(monkeypatch, capsys, flags, message):
    with pytest.raises(SystemExit):
        run_main(monkeypatch, SHIPPED, *flags)
    assert message in capsys.readouterr().err


def test_a_path_that_is_neither_policy_nor_run_is_named(monkeypatch, capsys, tmp_path):
    with pytest.raises(SystemExit):
        run_main(monkeypatch, tmp_path / "nothing")
    assert "nothing" in capsys.readouterr().err


def test_eval_low_plays_free_space_under_the_row_s_smoothing(monkeypatch):
    seen = []

    def fake_evaluate_reach(model, env, *, episodes, seed):
        seen.append((env.action_smoothing, episodes, seed))
        return {"success_rate": 0.5, "mean_steps": 7.0}

    monkeypatch.setattr(select_low_level, "load_low_level", lambda body, path: None)
    monkeypatch.setattr(select_low_level, "evaluate_reach", fake_evaluate_reach)
    assert select_low_level.eval_low(Path("p.zip"), 0.4, 100_000, 3) == {"eval_low": 0.5, "eval_low_mean_steps": 7.0}
    assert seen == [(0.4, 3, 100_000)]


def test_the_best_row_wins_a_tie_goes_to_the_first_and_large_mazes_get_their_own_file(monkeypatch, tmp_path):
    first, second, third = (tmp_path / f"{name}.zip" for name in ("first", "second", "third"))
    for path in (first, second, third):
        path.write_bytes(SHIPPED.read_bytes())
    scores = {"first": 0.8, "second": 0.8, "third": 0.7}

    def fake_score_rows(paths, smoothing, families, **kwargs):
        assert families == ["select4", "select6"]
        return {in_maze.row_name(p, smoothing): {"low_level_id": "x", "score": scores[p.stem]} for p in paths}

    monkeypatch.setattr(select_low_level, "score_rows", fake_score_rows)
    monkeypatch.setattr(select_low_level, "RESULTS", tmp_path)
    run_main(monkeypatch, first, second, third, "--held-out-layouts", "--large-mazes")
    saved = json.loads((tmp_path / "low_level_selection_held_out_large.json").read_text())
    assert saved["best"] == str(first)
