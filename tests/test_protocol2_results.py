"""The protocol-2 results page: its goals table quotes the committed folders, and it turns with the data."""

import json
from pathlib import Path
from types import SimpleNamespace

import pytest

from antmaze_lab import claims, protocol_tables, tables

pytestmark = pytest.mark.integration  # a lab check (antmaze_lab's protocol-2 tables and claims): the integration tier

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = ROOT / "results" / "protocol2"
PAGE = ROOT / "docs" / "results" / "protocol2.md"
SECTION = "protocol2-goals"


@pytest.mark.integration  # reads the committed results
def test_the_page_holds_the_generated_goals_and_claims_and_the_readme_links_them():
    # Their text is checked against the commands by tests/test_generated_docs.py.
    page, readme = PAGE.read_text(), (ROOT / "README.md").read_text()
    assert f"<!-- generated: python -m antmaze_lab.protocol_tables {SECTION} -->" in page
    brief = "python -m antmaze_lab.paper_claims --protocol2 results/protocol2/point results/protocol2/ant --brief"
    assert f"<!-- generated: {brief} -->" in page
    assert "(docs/paper-claims.md)" in readme and "(docs/preregistration.md)" in readme


@pytest.mark.integration  # reads the committed results
@pytest.mark.parametrize("body", ["point", "ant"])
def test_the_folders_are_complete_and_the_goals_quote_them(body):
    summary = json.loads((FOLDERS / body / "summary.json").read_text())
    assert {name: spec["seeds"] for name, spec in summary["methods"].items()} == dict.fromkeys(
        ("aggrevate", "dagger", "gated", "multi_policy", "noise", "reward_per_step", "reward"), 10
    )
    # The figures, computed here apart from the script's code: the untrained pooled rate and the best final median.
    untrained = summary["methods"]["dagger"]["untrained_success"]["pooled"]
    finals = {name: spec["final_success"]["median"] for name, spec in summary["methods"].items()}
    best = max(finals, key=finals.get)
    text = protocol_tables.SECTIONS[SECTION]()
    assert f"{100 * untrained['rate']:.1f}% [" in text
    oracle = summary["oracle_success"]["success_rate"]
    exact = [f"{100 * rate:.1f}".removesuffix(".0") for rate in (finals[best], oracle, oracle - finals[best])]
    assert f"`{best}` {exact[0]}% vs the oracle's {exact[1]}%: {exact[2]} points" in text


def _summary(untrained, best_final, oracle, ratio):
    """A body's summary as the goals read it: every method at ``best_final``, each active one at ``ratio``."""
    method = {
        "final_success": {"median": best_final},
        "untrained_success": {"pooled": {"rate": untrained, "cluster_bootstrap_95": [0.0, untrained + 0.02]}},
        claims.PAIRED: {"median_ratio": ratio, "seeds": 10, "seeds_reached": 10},
    }
    return {
        "methods": {name: method for name in (claims.BASELINE, *claims.ACTIVE)},
        "oracle_success": {"success_rate": oracle, "episodes": 100},
    }


@pytest.mark.parametrize(
    ("untrained", "best_final", "ratio", "saving", "met"),
    [
        (0.01, 0.95, 0.25, claims.SUPPORTS, ["met", "met", "met"]),
        (0.30, 0.90, 0.25, claims.CONTRADICTS, ["missed", "missed", "missed"]),
    ],
)
def test_each_goal_turns_with_the_data(tmp_path, monkeypatch, untrained, best_final, ratio, saving, met):
    for body in ("point", "ant"):
        (tmp_path / "protocol2" / body).mkdir(parents=True)
        summary = _summary(untrained, best_final, 0.97, ratio)
        (tmp_path / "protocol2" / body / "summary.json").write_text(json.dumps(summary))
    monkeypatch.setattr(tables, "RESULTS", tmp_path)
    monkeypatch.setattr(tables, "LOADED", [])
    outcomes = {name: {"point": saving, "ant": saving} for name in claims.ACTIVE}
    verdict = claims.HOLDS if saving == claims.SUPPORTS else claims.DOES_NOT_HOLD
    report = SimpleNamespace(verdicts=[None] * 5 + [SimpleNamespace(outcomes=outcomes, verdict=verdict)])
    monkeypatch.setattr(claims, "evaluate_folders", lambda *folders: report)
    rows = protocol_tables.protocol2_goals().splitlines()[2:]
    assert [row.rsplit("| **", 1)[1].removesuffix("** |") for row in rows] == met
    gap = round(100 * (0.97 - best_final))
    assert f"vs the oracle's 97%: {gap} points |" in rows[1]
