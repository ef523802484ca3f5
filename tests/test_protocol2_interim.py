"""The protocol guide's interim reading of the protocol-2 rerun quotes the committed interim summaries."""

import json
from pathlib import Path

import pytest
from script_helpers import load_script

ROOT = Path(__file__).resolve().parents[1]
INTERIM = ROOT / "results" / "protocol2" / "interim"
GUIDE = ROOT / "docs" / "guides" / "protocol.md"
SECTION = "protocol2-interim"
results_tables = load_script("scripts/results_tables.py")


def _final(method):
    final = method["final_success"]
    return f"{final['median']:.0%} ({final['min']:.0%}-{final['max']:.0%})"


def interim_figures(body):
    """The figures of ``body``'s row, computed here from its summary apart from the script's own code."""
    methods = json.loads((INTERIM / body / "summary.json").read_text())["methods"]
    dagger, gated = methods["dagger"], methods["gated"]
    seeds = [method["seeds"] for method in methods.values()]
    ratio = gated["total_labels"]["median"] / dagger["total_labels"]["median"]
    untrained = dagger["untrained_success"]
    return [
        f"| {body} | {min(seeds)}-{max(seeds)} |",
        f"{100 * untrained['pooled']['rate']:.1f}% "
        f"({round(100 * min(untrained['per_seed']))}-{round(100 * max(untrained['per_seed']))} of 100 mazes per seed)",
        f"{_final(dagger)}, {dagger['total_labels']['median']:.0f} labels",
        f"{_final(gated)}, {gated['total_labels']['median']:.0f} labels ({ratio:.2f}x DAgger's)",
    ]


def test_the_guide_holds_the_generated_interim_table():
    # Its text is checked against the command by tests/test_generated_docs.py.
    assert f"<!-- generated: python scripts/results_tables.py {SECTION} -->" in GUIDE.read_text()


@pytest.mark.parametrize("body", ["point", "ant"])
def test_the_interim_table_quotes_the_interim_summaries(body):
    text = results_tables.SECTIONS[SECTION]()
    missing = [figure for figure in interim_figures(body) if figure not in text]
    assert not missing, f"results_tables.py {SECTION} lacks {missing}"
