"""The protocol guide's interim reading of the protocol-2 rerun quotes the committed interim summaries."""

import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
INTERIM = ROOT / "results" / "protocol2" / "interim"
GUIDE = ROOT / "docs" / "guides" / "protocol.md"


def _final(method):
    final = method["final_success"]
    return f"{final['median']:.0%} ({final['min']:.0%}-{final['max']:.0%})"


def interim_figures(body):
    methods = json.loads((INTERIM / body / "summary.json").read_text())["methods"]
    dagger, gated = methods["dagger"], methods["gated"]
    seeds = [method["seeds"] for method in methods.values()]
    ratio = gated["total_labels"]["median"] / dagger["total_labels"]["median"]
    untrained = dagger["untrained_success"]
    return [
        f"{body}, {min(seeds)}-{max(seeds)} seeds",
        f"untrained {100 * untrained['pooled']['rate']:.1f}%",
        f"DAgger {_final(dagger)} with {dagger['total_labels']['median']:.0f} labels",
        f"gated {_final(gated)} with {gated['total_labels']['median']:.0f} labels ({ratio:.2f}x DAgger's)",
        f"({round(100 * min(untrained['per_seed']))}-{round(100 * max(untrained['per_seed']))} of 100 mazes per seed)",
    ]


@pytest.mark.parametrize("body", ["point", "ant"])
def test_the_guide_quotes_the_interim_summaries(body):
    text = " ".join(GUIDE.read_text().split())
    missing = [figure for figure in interim_figures(body) if figure not in text]
    assert not missing, f"docs/guides/protocol.md lacks {missing}"
