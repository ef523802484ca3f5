"""Compares the methods on one per-participant measure: descriptives, ANOVAs and paired post-hoc tests.

All statistics come from statsmodels and scipy: the one-way ANOVA the paper reports
(``ols`` + ``anova_lm``), the repeated-measures ANOVA the within-subject design calls for
(``AnovaRM``, subject = participant, within = method), and paired t-tests between every two methods
(``scipy.stats.ttest_rel``) with Holm's correction over the pairs (``multipletests``).
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd
import statsmodels.formula.api as smf
from scipy import stats
from statsmodels.stats.anova import AnovaRM, anova_lm
from statsmodels.stats.multitest import multipletests

MIN_PARTICIPANTS = 2
"""Tests need at least this many participants with a value for every method."""


def number(value: Any) -> float | None:
    """``value`` as a float, or ``None`` if it is not finite (JSON has no NaN; a zero-variance F has none)."""
    value = float(value)
    return value if math.isfinite(value) else None


def describe(values: pd.Series) -> dict[str, Any]:
    """Count, mean, standard error of the mean, median, min and max of ``values`` (NaN left out)."""
    values = values.dropna()
    if values.empty:
        return {"n": 0, "mean": None, "se": None, "median": None, "min": None, "max": None}
    sem = stats.sem(values) if len(values) > 1 else math.nan
    return {
        "n": len(values),
        "mean": number(values.mean()),
        "se": number(sem),
        "median": number(values.median()),
        "min": number(values.min()),
        "max": number(values.max()),
    }


def _f_test(f: Any, df_num: Any, df_den: Any, p: Any) -> dict[str, float | None]:
    return {"F": number(f), "df_num": number(df_num), "df_den": number(df_den), "p": number(p)}


def one_way_anova(frame: pd.DataFrame) -> dict[str, Any]:
    """One-way ANOVA of ``value`` across ``method`` (as the paper reports it), via statsmodels."""
    table = anova_lm(smf.ols("value ~ C(method)", data=frame).fit(), typ=2)
    row = table.loc["C(method)"]
    return _f_test(row["F"], row["df"], table.loc["Residual", "df"], row["PR(>F)"])


def rm_anova(frame: pd.DataFrame) -> dict[str, Any]:
    """Repeated-measures ANOVA of ``value``, subject ``participant``, within ``method`` (statsmodels AnovaRM)."""
    row = AnovaRM(frame, depvar="value", subject="participant", within=["method"]).fit().anova_table.loc["method"]
    return _f_test(row["F Value"], row["Num DF"], row["Den DF"], row["Pr > F"])


def paired_tests(wide: pd.DataFrame, methods: Sequence[str]) -> list[dict[str, Any]]:
    """Paired t-tests between every two methods (columns of ``wide``), Holm-corrected over the pairs.

    A pair whose differences are all equal has no t (``None``) and takes no part in the correction.
    """
    rows = []
    for a, b in itertools.combinations(methods, 2):
        result = stats.ttest_rel(wide[a], wide[b])
        # Equal differences give t = +-inf and p = 0 (scipy), or nan when they are all 0: no test either way.
        tested_pair = bool(np.isfinite(result.statistic))
        rows.append(
            {
                "a": a,
                "b": b,
                "mean_difference": number((wide[a] - wide[b]).mean()),
                "t": number(result.statistic),
                "df": len(wide) - 1,
                "p": number(result.pvalue) if tested_pair else None,
                "p_holm": None,
            }
        )
    tested = [row for row in rows if row["p"] is not None]
    if tested:
        holm = multipletests([row["p"] for row in tested], method="holm")[1]
        for row, p in zip(tested, holm, strict=True):
            row["p_holm"] = number(p)
    return rows


def compare_methods(frame: pd.DataFrame, methods: Sequence[str]) -> dict[str, Any]:
    """Descriptives per method and, where there are enough data, the tests.

    Args:
        frame: One row per participant and method: columns ``participant``, ``method``, ``value``
            (NaN or absent where a participant has no value).
        methods: The methods, in report order.

    Returns:
        ``{"methods": {method: describe(...)}, "tests": {...}}``. The tests use the participants with
        a value for every method (``tests["participants"]`` lists them); if there are fewer than
        :data:`MIN_PARTICIPANTS`, or only one method, ``tests["run"]`` is False with the reason.
    """
    frame = frame.dropna(subset=["value"])
    summary = {method: describe(frame.loc[frame["method"] == method, "value"]) for method in methods}
    wide = frame.pivot(index="participant", columns="method", values="value").reindex(columns=list(methods))
    wide = wide.dropna()
    participants = [str(p) for p in wide.index]
    if len(methods) < 2:
        return {"methods": summary, "tests": {"run": False, "reason": "only one method", "participants": participants}}
    if len(wide) < MIN_PARTICIPANTS:
        reason = f"{len(wide)} participant(s) with a value for every method; the tests need {MIN_PARTICIPANTS}"
        return {"methods": summary, "tests": {"run": False, "reason": reason, "participants": participants}}
    complete = wide.reset_index().melt(id_vars="participant", var_name="method", value_name="value")
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        # Identical values (e.g. every learner at 100% success) give 0/0: reported as None, not warned.
        warnings.simplefilter("ignore", RuntimeWarning)
        tests = {
            "run": True,
            "participants": participants,
            "anova": one_way_anova(complete),
            "rm_anova": rm_anova(complete),
            "posthoc": paired_tests(wide, methods),
        }
    return {"methods": summary, "tests": tests}
