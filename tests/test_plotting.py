"""The one plotting module: real lines in the PNGs, no backend change at import, the old module still works."""

import importlib
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from matplotlib.image import imread

from antmaze_hirl import plotting

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def saved_figures(monkeypatch):
    """The figures ``plotting`` saves (still written for real), to read back what was drawn."""
    figures = []
    real_save = plotting.save_figure

    def keep(figure, out_file, **kwargs):
        figures.append(figure)
        return real_save(figure, out_file, **kwargs)

    monkeypatch.setattr(plotting, "save_figure", keep)
    return figures


def colour_pixels(png: Path, colour: str) -> int:
    """Pixels of ``png`` within a small distance of ``colour`` (a hex string)."""
    rgb = np.array([int(colour[i : i + 2], 16) / 255 for i in (1, 3, 5)])
    image = imread(png)[..., :3]
    return int((np.abs(image - rgb).max(axis=-1) < 0.05).sum())


def test_learning_curves_draw_one_line_per_run(tmp_path, saved_figures):
    out = plotting.plot_learning_curves({"a": ([1, 2], [0.1, 0.5]), "b": ([1], [0.2])}, tmp_path / "deep" / "c.png")
    (figure,) = saved_figures
    (ax,) = figure.axes
    drawn = [(list(line.get_xdata()), list(line.get_ydata()), line.get_label()) for line in ax.lines]
    assert drawn == [([1, 2], [0.1, 0.5], "a"), ([1], [0.2], "b")]
    image = imread(out)
    assert image.shape[:2] == (4 * 120, 7 * 120)  # figsize (7, 4) inches at 120 dpi
    # The data lines are in the PNG, not only in the legend: a long diagonal of run a's colour.
    assert colour_pixels(out, "#1f77b4") > 2 * colour_pixels(
        plotting.plot_learning_curves({"a": ([], []), "b": ([1], [0.2])}, tmp_path / "legend_only.png"), "#1f77b4"
    )


def test_panels_draw_a_median_line_per_method_on_each_panel(tmp_path, saved_figures):
    rows = [
        {"method": method, "seed": seed, "episode": episode, "eval_success": success, "attempts": 3 + seed}
        | {"cumulative_expert_cost": 5 * (episode + 1)}
        for method, offset in (("dagger", 0.0), ("noise", 0.2))
        for seed in (0, 1)
        for episode, success in enumerate((0.1 + offset, float("nan"), 0.5 + offset + 0.1 * seed))
    ]
    plotting.plot_panels(rows, ["dagger", "noise"], tmp_path / "panels.png", title="t")
    (figure,) = saved_figures
    assert [[line.get_label() for line in ax.lines] for ax in figure.axes] == [["dagger", "noise"]] * 3
    success_vs_episode = figure.axes[0].lines[1]
    np.testing.assert_allclose(success_vs_episode.get_xdata(), [1, 3])  # evaluated episodes only, from 1
    np.testing.assert_allclose(success_vs_episode.get_ydata(), [0.3, 0.75])  # median over the two seeds
    assert colour_pixels(tmp_path / "panels.png", "#ff7f0e") > 100


def test_a_curve_of_one_point_gets_a_marker_and_an_error_bar():
    ax = plotting.new_figure().add_subplot()
    single = plotting.draw_band(ax, np.array([1.0]), np.array([[0.5], [0.7]]), "one evaluation")
    several = plotting.draw_band(ax, np.array([1.0, 2.0]), np.array([[0.5, 0.6]]), "two evaluations")
    assert (single.get_marker(), several.get_marker()) == ("o", "None")
    (bar,) = ax.containers  # the min-max bar of the one-point curve; the longer curve has a band instead
    np.testing.assert_allclose(bar.lines[0].get_ydata(), [0.6])
    assert len(ax.collections) == 2  # the bar's segment and the longer curve's band


def test_importing_the_plotting_modules_keeps_the_users_backend():
    code = (
        "import matplotlib; matplotlib.use('svg'); import warnings; warnings.simplefilter('ignore');"
        "import antmaze_hirl.plotting, antmaze_hirl.study.figures;"
        "print(matplotlib.get_backend())"
    )
    result = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert result.stdout.split() == ["svg"]


def test_the_old_experiments_plots_module_is_removed():
    with pytest.raises(ModuleNotFoundError, match=r"antmaze_hirl\.experiments\.plots"):
        importlib.import_module("antmaze_hirl.experiments.plots")


def test_an_episode_plot_frames_the_maze_with_half_its_border_wall(tmp_path, monkeypatch):
    from antmaze_hirl import plotting
    from antmaze_hirl.envs.geometry import MazeGeometry

    figures = []
    monkeypatch.setattr(plotting, "save_figure", lambda figure, out_file, dpi: figures.append(figure) or out_file)
    geometry = MazeGeometry(5, 5, 4.0)  # a 3x3 ant maze with its border: +-10 m, the free cells +-6 m
    walls = np.ones((5, 5))
    walls[1:-1, 1:-1] = 0
    path = np.array([[-4.0, -4.0], [4.0, 4.0]])
    plotting.plot_episode(walls, geometry, path, [path[1]], path[1], tmp_path / "episode.png")
    axes = figures[0].axes[0]
    assert axes.get_xlim() == (-8.0, 8.0) and axes.get_ylim() == (-8.0, 8.0)
