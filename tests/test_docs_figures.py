"""The headline figures of the README and the results page are those of the committed results files."""

import json
from pathlib import Path

import pytest

from antmaze_hirl.experiments.uncertainty import wilson_interval

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results"
PAGES = [ROOT / "README.md", ROOT / "docs" / "results" / "index.md"]


def load(name):
    return json.loads((RESULTS / name).read_text())


def percent(value):
    return f"{100 * value:.1f}"


def interval(successes, trials):
    low, high = wilson_interval(successes, trials)
    return f"[{percent(low)}, {percent(high)}]"


def headline_figures():
    low_level = load("low_level/low_level.json")["eval_low"]
    figures = []
    for body in ("point", "ant"):
        pooled = low_level[body]
        successes = round(pooled["pooled_success_rate"] * pooled["pooled_episodes"])
        rate = percent(pooled["pooled_success_rate"])  # 800 episodes: one decimal
        figures.append(
            f"{successes} of {pooled['pooled_episodes']}: {rate}% {interval(successes, pooled['pooled_episodes'])}"
        )
    families = load("in_maze/in_maze.json")["results"]["shipped"]["families"]
    for family in ("ant4", "large"):
        row = families[family]
        figures.append(f"{100 * row['success_rate']:g}% {interval(row['successes'], row['episodes'])}")
    for body in ("point", "ant"):
        summary = load(f"protocol2/{body}/summary.json")
        dagger = summary["methods"]["dagger"]
        untrained = dagger["untrained_success"]["pooled"]
        low, high = untrained["cluster_bootstrap_95"]
        final = dagger["final_success"]
        oracle = summary["oracle_success"]
        successes = round(oracle["success_rate"] * oracle["episodes"])
        figures.append(
            f"{percent(untrained['rate'])}% [{percent(low)}, {percent(high)}] → "
            f"{final['median']:.0%} ({final['min']:.0%}-{final['max']:.0%}), "
            f"{dagger['total_labels']['median']:.0f} labels per trial; "
            f"oracle {100 * oracle['success_rate']:g}% {interval(successes, oracle['episodes'])}"
        )
    figures.append(f"{load('study_latency/study_latency.json')['bodies']['ant']['all']['server']['p95_ms']} ms")
    return figures


@pytest.mark.integration  # reads the committed results
@pytest.mark.parametrize("page", PAGES, ids=lambda page: page.name)
def test_the_headline_table_quotes_the_results_files(page):
    text = page.read_text()
    missing = [figure for figure in headline_figures() if figure not in text]
    assert not missing, f"{page.relative_to(ROOT)} lacks {missing}"
