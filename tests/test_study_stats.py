import json

import numpy as np
import pandas as pd
import pingouin as pg
import pytest

from antmaze_hirl.study.stats import compare_methods, one_way_anova, paired_tests, rm_anova

# Field, "Discovering Statistics Using SPSS" (3rd ed., 2009), ch. 13, the Bushtucker Trial: 8 celebrities
# x 4 animals, seconds to retch. Published: sphericity-assumed F(3, 21) = 3.79, p = .026.
BUSHTUCKER = {
    "stick_insect": [8, 9, 6, 5, 8, 7, 10, 12],
    "kangaroo_testicle": [7, 5, 2, 3, 4, 5, 2, 6],
    "fish_eye": [1, 2, 3, 1, 5, 6, 7, 8],
    "witchetty_grub": [6, 5, 8, 9, 8, 7, 2, 1],
}
# Field (2009), ch. 10, the Viagra data: libido of 3 groups of 5. Published: F(2, 12) = 5.12, p = .025.
VIAGRA = {"placebo": [3, 2, 1, 1, 4], "low": [5, 2, 4, 2, 3], "high": [7, 4, 5, 3, 6]}


def _long(data):
    return pd.DataFrame(
        [
            {"participant": f"P{i}", "method": m, "value": float(v)}
            for m, values in data.items()
            for i, v in enumerate(values)
        ]
    )


def test_rm_anova_matches_the_published_bushtucker_result():
    result = rm_anova(_long(BUSHTUCKER))
    assert result["F"] == pytest.approx(3.79, abs=0.005)
    assert (result["df_num"], result["df_den"]) == (3, 21)
    assert result["p"] == pytest.approx(0.026, abs=0.0005)


def test_one_way_anova_matches_the_published_viagra_result():
    frame = pd.DataFrame([{"method": m, "value": float(v)} for m, values in VIAGRA.items() for v in values])
    result = one_way_anova(frame)
    assert result["F"] == pytest.approx(5.12, abs=0.005)
    assert (result["df_num"], result["df_den"]) == (2, 12)
    assert result["p"] == pytest.approx(0.025, abs=0.0005)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_compare_methods_agrees_with_pingouin(seed):
    rng = np.random.default_rng(seed)
    methods = ["dagger", "noise", "reward"]
    data = {m: rng.normal(3 + 0.5 * i, 1.0, size=7) + rng.normal(0, 1, 7) for i, m in enumerate(methods)}
    frame = _long(data)
    result = compare_methods(frame, methods)
    reference = pg.rm_anova(frame, dv="value", within="method", subject="participant", detailed=True)
    assert result["tests"]["rm_anova"]["F"] == pytest.approx(reference["F"].iloc[0], rel=1e-9)
    assert result["tests"]["rm_anova"]["p"] == pytest.approx(reference["p_unc"].iloc[0], rel=1e-9)
    pairs = pg.pairwise_tests(frame, dv="value", within="method", subject="participant", padjust="holm")
    posthoc = {(row["a"], row["b"]): row for row in result["tests"]["posthoc"]}
    assert len(posthoc) == 3
    for _, ref in pairs.iterrows():
        ours = posthoc[(ref["A"], ref["B"])]
        assert ours["t"] == pytest.approx(ref["T"], rel=1e-9)
        assert ours["p"] == pytest.approx(ref["p_unc"], rel=1e-9)
        assert ours["p_holm"] == pytest.approx(ref["p_corr"], rel=1e-9)
    for method in methods:
        assert result["methods"][method]["mean"] == pytest.approx(data[method].mean())
        assert result["methods"][method]["se"] == pytest.approx(data[method].std(ddof=1) / np.sqrt(7))
        assert result["methods"][method]["n"] == 7


def test_compare_methods_uses_only_complete_participants_for_tests():
    frame = _long(BUSHTUCKER)
    frame = pd.concat([frame, pd.DataFrame([{"participant": "P99", "method": "fish_eye", "value": 50.0}])])
    result = compare_methods(frame, list(BUSHTUCKER))
    assert result["methods"]["fish_eye"]["n"] == 9
    assert "P99" not in result["tests"]["participants"] and len(result["tests"]["participants"]) == 8
    assert result["tests"]["rm_anova"]["F"] == pytest.approx(3.7938, abs=1e-4)


def test_compare_methods_without_enough_data_skips_the_tests():
    one = _long({m: v[:1] for m, v in BUSHTUCKER.items()})
    result = compare_methods(one, list(BUSHTUCKER))
    assert result["tests"]["run"] is False and "need 2" in result["tests"]["reason"]
    assert result["methods"]["fish_eye"] == {"n": 1, "mean": 1.0, "se": None, "median": 1.0, "min": 1.0, "max": 1.0}
    single = compare_methods(_long({"fish_eye": BUSHTUCKER["fish_eye"]}), ["fish_eye"])
    assert single["tests"] == {"run": False, "reason": "only one method", "participants": [f"P{i}" for i in range(8)]}
    empty = compare_methods(pd.DataFrame(columns=["participant", "method", "value"]), ["a", "b"])
    assert empty["methods"]["a"]["n"] == 0 and empty["tests"]["run"] is False


def test_identical_values_give_none_not_nan():
    frame = _long({"a": [1, 1, 1], "b": [1, 1, 1]})
    tests = compare_methods(frame, ["a", "b"])["tests"]
    assert tests["run"] is True
    assert tests["posthoc"][0]["t"] is None and tests["posthoc"][0]["p_holm"] is None
    json.dumps(tests, allow_nan=False)  # no NaN anywhere: stats.json stays valid JSON


def test_a_pair_with_equal_differences_has_no_test_and_no_holm_share():
    wide = pd.DataFrame({"a": [1.0, 2.0, 3.0], "b": [0.5, 1.5, 2.5], "c": [1.0, 2.5, 2.0]})
    rows = {(row["a"], row["b"]): row for row in paired_tests(wide, ["a", "b", "c"])}
    assert rows[("a", "b")]["t"] is None and rows[("a", "b")]["p"] is None and rows[("a", "b")]["p_holm"] is None
    assert rows[("a", "c")]["p"] is not None and rows[("a", "c")]["p_holm"] is not None
