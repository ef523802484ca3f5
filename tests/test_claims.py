"""The paper's claims (``antmaze_lab.claims``): verdicts on crafted summaries, and its script."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from antmaze_hirl.experiments.uncertainty import paired_comparison
from antmaze_lab import claims as cl
from antmaze_lab import paper_claims as pc

pytestmark = pytest.mark.integration  # a lab check (antmaze_lab.claims and paper_claims): the integration tier

CLAIM = {claim.number: claim for claim in cl.CLAIMS}

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = ROOT / "results" / "protocol2"
JITTER = [0.0, 0.01, -0.01, 0.02, -0.02, 0.0, 0.01, -0.01, 0.02, -0.02]


def _median(values):
    return float(np.median([math.inf if v is None else v for v in values]))


def figures(rates, dagger_rates, labels, dagger_labels, untrained=0.01):
    """A method's summary.json figures, as ``summarise`` writes them, from per-seed rates and labels."""
    seeds = len(rates)
    target = float(np.median(dagger_rates))
    median = _median(labels)
    theirs = _median(dagger_labels)
    out = {
        "seeds": seeds,
        "final_success": {
            "median": float(np.median(rates)),
            "min": min(rates),
            "max": max(rates),
            "per_seed": [{"seed": seed, "rate": rate} for seed, rate in enumerate(rates)],
        },
        "labels_to_match_dagger": {
            "target": target,
            "median": median if math.isfinite(median) else None,
            "per_seed": labels,
            "seeds_reached": sum(v is not None for v in labels),
            "ratio_vs_dagger": median / theirs if math.isfinite(median) and math.isfinite(theirs) else None,
        },
        "total_labels": {"median": 1000.0, "min": 950.0, "max": 1050.0},
        "untrained_success": {
            "median": untrained,
            "min": untrained,
            "max": untrained,
            "per_seed": [untrained] * seeds,
            "pooled": {"rate": untrained},
        },
        "cost_to_60_percent": {"median": 150.0, "seeds_reached": seeds},
        "mean_expert_cost_per_episode": 10.0,
    }
    if rates is not dagger_rates:
        out["vs_dagger"] = {"final_success": paired_comparison(rates, dagger_rates[:seeds])}
    return out


def body(name, seeds=10, gain=None, labels=None, untrained=0.01, episodes=None):
    """A protocol-2 body: DAgger, every active method and ``aggrevate``.

    Each method is at DAgger's success (+-1 point) and labels, unless ``gain`` (a share of success over
    DAgger's) or ``labels`` (per-seed labels to DAgger's success) says otherwise.
    """
    gain, labels = gain or {}, labels or {}
    dagger_rates = [0.8 + JITTER[seed] for seed in range(seeds)]
    dagger_labels = [500.0 + 10 * seed for seed in range(seeds)]
    methods = {"dagger": figures(dagger_rates, dagger_rates, dagger_labels, dagger_labels, untrained)}
    for method in (*cl.ACTIVE, "aggrevate"):
        shift = gain.get(method, 0.0)
        rates = [round(rate + shift + JITTER[(seed + 3) % 10] / 2, 3) for seed, rate in enumerate(dagger_rates)]
        methods[method] = figures(rates, dagger_rates, labels.get(method, dagger_labels), dagger_labels, untrained)
    summary = {"config": {"body": name, "protocol": 2, "episodes": 100}, "methods": methods}
    return cl.Body(name, Path(name), summary, episodes)


def rows_of(bodies):
    return {row.number: row for row in cl.judge_claims(bodies)}


def test_a_clear_effect_on_ten_seeds_holds():
    fewer = [100.0 + 5 * seed for seed in range(10)]  # 0.2x DAgger's labels on every seed
    bodies = [body(name, gain={"reward": 0.15, "aggrevate": -0.2}, labels={"gated": fewer}) for name in cl.BODIES]
    rows = rows_of(bodies)
    assert rows[1].verdict == cl.HOLDS and rows[1].printed == "holds"
    assert rows[1].outcomes["reward"] == {"point": cl.SUPPORTS, "ant": cl.SUPPORTS}
    # reward_per_step is at DAgger's success (its CI excludes a 5-point gain), but one reading holding is enough.
    assert rows[1].outcomes["reward_per_step"]["point"] == cl.CONTRADICTS
    assert rows[5].verdict == cl.HOLDS and rows[5].printed.startswith("holds (bounded:")
    assert rows[6].verdict == cl.HOLDS and rows[6].outcomes["gated"]["ant"] == cl.SUPPORTS
    assert rows[7].verdict == cl.NOT_TESTABLE
    table = pc.markdown(cl.ClaimsReport(tuple(bodies), tuple(rows.values())))
    assert table.startswith("Protocol 2 claims:") and table.count("10 seeds per method (complete)") == 2


def test_the_opposite_effect_or_an_excluded_one_does_not_hold():
    more = [700.0 + 5 * seed for seed in range(10)]
    bodies = [
        body(name, gain={"multi_policy": 0.1, "aggrevate": 0.1}, labels={"reward": more, "reward_per_step": more})
        for name in cl.BODIES
    ]
    rows = rows_of(bodies)
    # reward at DAgger's success +-1 point: the CI excludes the claimed 5-point gain.
    assert rows[1].verdict == cl.DOES_NOT_HOLD
    assert rows[2].verdict == cl.DOES_NOT_HOLD  # more labels than DAgger, significantly
    assert rows[3].verdict == cl.DOES_NOT_HOLD  # multi_policy is better, significantly
    # aggrevate beating DAgger with a dense Q says nothing of a sparse-reward AggreVaTeD.
    assert rows[5].verdict == cl.NOT_TESTABLE
    # No method reaches DAgger's success at <= 0.3x its labels: every CI of labels - 0.3x DAgger's is above 0.
    assert rows[6].verdict == cl.DOES_NOT_HOLD
    assert "does not hold" in rows[6].printed


def test_five_seeds_are_inconclusive_and_interim_whatever_the_effect():
    bodies = [body(name, seeds=5, gain={"reward": 0.15, "reward_per_step": 0.15}) for name in cl.BODIES]
    row = rows_of(bodies)[1]
    # Every seed better by about 15 points, but 5 pairs cannot go below p = 0.0625.
    assert row.verdict == cl.INCONCLUSIVE
    assert "p = 0.0625 (n = 5, floor 0.0625), CI [-inf, +inf]: undecided" in row.measurement
    assert row.printed == "interim: leaning holds (direction only)"


def test_a_method_short_of_ten_seeds_makes_the_folder_interim():
    full = body("point", gain={"reward": 0.15})
    short = body("ant", gain={"reward": 0.15})
    short.summary["methods"]["gated"] = figures([0.8] * 9, [0.8] * 9, [500.0] * 9, [500.0] * 9)
    assert not full.interim and short.interim and short.seeds == (9, 10)
    rows = rows_of([full, short])
    # The tests decide it, but on an interim folder the row only leans; claim 7 needs people, not seeds.
    assert rows[1].verdict == cl.HOLDS and rows[1].printed == "interim: leaning holds"
    assert all(row.printed.startswith("interim: leaning ") for n, row in rows.items() if n != 7)
    table = pc.markdown(cl.ClaimsReport((full, short), tuple(rows.values())))
    assert "Protocol 2 claims (INTERIM: not a result)" in table
    assert "- ant: `ant`, 9-10 seeds per method (INTERIM" in table
    assert "- point: `point`, 10 seeds per method (complete)" in table


def test_sixty_percent_counts_episodes_from_the_untrained_success():
    fast = {method: dict.fromkeys(range(10), 30.0) for method in (*cl.ACTIVE, "dagger", "aggrevate")}
    rows = rows_of([body(name, episodes=fast) for name in cl.BODIES])
    assert rows[4].verdict == cl.HOLDS and "10 of 10 seeds under 100 episodes" in rows[4].measurement
    slow = {method: dict.fromkeys(range(10), None) for method in fast}
    assert rows_of([body(name, episodes=slow) for name in cl.BODIES])[4].verdict == cl.DOES_NOT_HOLD
    # An untrained learner at 60% already: the claim is about learning, so it cannot be tested.
    assert rows_of([body(name, untrained=0.7, episodes=fast) for name in cl.BODIES])[4].verdict == cl.NOT_TESTABLE
    # Without episodes.csv there are no episode counts: it cannot hold, only lean.
    row = rows_of([body(name) for name in cl.BODIES])[4]
    assert row.verdict == cl.INCONCLUSIVE and row.leaning == "holds (direction only)"
    assert "untrained 1.0% pooled" in row.measurement


@pytest.mark.integration  # reads the committed results
def test_the_committed_folders_print_a_complete_table_with_a_verdict_per_claim(tmp_path, capsys):
    out = tmp_path / "claims.json"
    pc.main(["--protocol2", str(FOLDERS / "point"), str(FOLDERS / "ant"), "--json", str(out)])
    table = capsys.readouterr().out
    assert table.startswith("Protocol 2 claims:")
    assert table.count("10 seeds per method (complete)") == 2
    written = json.loads(out.read_text())
    assert not written["interim"] and [row["number"] for row in written["claims"]] == list(range(1, 8))
    verdicts = (cl.HOLDS, cl.DOES_NOT_HOLD, cl.INCONCLUSIVE, cl.NOT_TESTABLE)
    for row in written["claims"]:
        assert row["verdict"] in verdicts and row["printed"].startswith(row["verdict"]), row
        assert f"**{row['printed']}** |" in table


@pytest.mark.integration  # reads the committed results
def test_bad_folders_are_one_line_errors(tmp_path, capsys):
    with pytest.raises(SystemExit):
        pc.main(["--protocol2", str(FOLDERS / "ant"), str(FOLDERS / "point")])
    assert "is of body 'ant', but it was passed as the point folder" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        pc.main(["--protocol2", str(ROOT / "results" / "paper_experiment" / "point"), str(FOLDERS / "ant")])
    assert "has config.protocol 1, not 2: read it without --protocol2" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        pc.main(["--protocol2", str(tmp_path), str(FOLDERS / "ant")])
    assert f"no summary.json in {tmp_path}" in capsys.readouterr().err


@pytest.mark.integration  # reads the committed results
def test_protocol_1_still_prints_the_figures_the_old_table_quotes():
    figures = cl.protocol1_figures(ROOT / "results" / "paper_experiment" / "ant")["methods"]["reward"]
    # docs/paper-claims.md: "Pruning removed 137 of `reward`'s 4,903 labels (2.8%)".
    assert (figures["labels_removed_by_pruning"], figures["labels_spent"]) == (137, 4903)
    assert figures["episodes_to_60_percent"]["median"] == 30.0


def test_the_threshold_is_split_over_the_readings_a_claim_tries():
    differences = [0.05, 0.04, 0.06, 0.03, 0.07, -0.03, 0.05, 0.02, -0.04, 0.08]  # p = 0.035 with 10 pairs
    assert cl.compare(differences, 1, cl.SUCCESS_EFFECT, 0.05).outcome == cl.SUPPORTS
    assert cl.compare(differences, 1, cl.SUCCESS_EFFECT, 0.025).outcome == cl.UNDECIDED
    rows = rows_of([body(name) for name in cl.BODIES])
    assert rows[1].measurement.startswith("threshold p < 0.025<br>")  # reward and reward_per_step
    assert rows[3].measurement.startswith("threshold p < 0.05<br>")  # multi_policy alone
    assert rows[6].measurement.startswith("threshold p < 0.01;")  # five active methods


def test_passing_sixty_percent_at_the_hundredth_episode_is_not_under_a_hundred():
    last = {method: dict.fromkeys(range(10), 100.0) for method in (*cl.ACTIVE, "dagger", "aggrevate")}
    row = rows_of([body(name, episodes=last) for name in cl.BODIES])[4]
    assert row.verdict == cl.DOES_NOT_HOLD and "0 of 10 seeds under 100 episodes" in row.measurement


def test_saving_expert_cost_needs_the_ratio_not_only_fewer_labels():
    # noise needs 0.6x DAgger's labels on every seed: significantly fewer, but not <= 0.3x.
    fewer = [0.6 * (500.0 + 10 * seed) for seed in range(10)]
    rows = rows_of([body(name, labels={"noise": fewer}) for name in cl.BODIES])
    assert rows[6].outcomes["noise"] == {"point": cl.CONTRADICTS, "ant": cl.CONTRADICTS}
    assert rows[6].verdict == cl.DOES_NOT_HOLD
    assert "`noise` 327 (10 of 10 reach it), 0.60x, p = 0.00195: contradicts" in rows[6].measurement


def test_episodes_to_sixty_percent_are_read_from_the_episode_rows():
    def row(seed, episode, success):
        labels = 10.0 * (episode + 1)
        return {
            "method": "dagger",
            "seed": seed,
            "episode": episode,
            "eval_success": success,
            "cumulative_expert_cost": labels,
        }

    rows = [row(0, 9, 0.4), row(0, 19, 0.65), row(1, 9, 0.5), row(1, 99, 0.55), row(2, 9, math.nan)]
    summary = {"methods": {"dagger": figures([0.8, 0.8, 0.8], [0.8] * 3, [500.0] * 3, [500.0] * 3)}}
    # Seed 0 passes after 20 episodes, seed 1 never; seed 2's untrained learner is at 70% already.
    summary["methods"]["dagger"]["untrained_success"]["per_seed"] = [0.0, 0.0, 0.7]
    assert cl.episodes_to_target(rows, summary) == {"dagger": {0: 20.0, 1: None, 2: 0.0}}


def test_claim_6_reads_the_labels_paired_by_seed_where_dagger_misses_its_own_median():
    # DAgger's median-target figure is "never" (under half its seeds reach its median), so no ratio is read;
    # paired by seed, gated needs 0.25x DAgger's labels on every seed and the claim holds on 10 seeds.
    bodies = []
    for name in ("point", "ant"):
        one = body(name, labels={"dagger": [None] * 10})
        one.summary["methods"]["dagger"]["labels_to_match_dagger"]["median"] = None
        for method in cl.ACTIVE:
            mine = 0.25 if method == "gated" else 1.0
            one.summary["methods"][method][cl.PAIRED] = {
                "median_ratio": mine,
                "seeds": 10,
                "seeds_reached": 10,
                "per_seed": [
                    {"seed": s, "target": 0.8, "labels": mine * (400 + 10 * s), "baseline_labels": 400.0 + 10 * s}
                    for s in range(10)
                ],
            }
        bodies.append(one)
    saving = CLAIM[6].judge(bodies)
    assert saving.verdict == cl.HOLDS
    assert "paired by seed: median 0.25x DAgger's (10 of 10 seeds reach it)" in saving.measurement
    # Without the paired figure the same bodies cannot decide: DAgger's own median is never reached.
    for one in bodies:
        for method in cl.ACTIVE:
            del one.summary["methods"][method][cl.PAIRED]
    assert CLAIM[6].judge(bodies).verdict != cl.HOLDS


def _write_folder(folder, one_body):
    folder.mkdir(parents=True)
    (folder / "summary.json").write_text(json.dumps(one_body.summary))
    return folder


def test_a_verdict_read_from_folders_on_disk_turns_with_the_data(tmp_path):
    # The same folders but for reward's success: 15 points above DAgger's on every seed, or 15 below.
    def report(gain):
        folders = [_write_folder(tmp_path / f"{gain}" / name, body(name, gain={"reward": gain})) for name in cl.BODIES]
        return cl.evaluate_folders(*folders)

    better, worse = report(0.15), report(-0.15)
    assert not better.interim and [verdict.number for verdict in better.verdicts] == list(range(1, 8))
    assert better.verdicts[0].verdict == cl.HOLDS and better.verdicts[0].printed == "holds"
    assert better.verdicts[0].outcomes["reward"] == {"point": cl.SUPPORTS, "ant": cl.SUPPORTS}
    assert worse.verdicts[0].verdict == cl.DOES_NOT_HOLD
    assert worse.verdicts[0].outcomes["reward"] == {"point": cl.CONTRADICTS, "ant": cl.CONTRADICTS}
    # No episodes.csv in these folders: claim 4 reads summary.json's labels only.
    assert better.bodies[0].episodes_to_target is None


def test_bad_folders_are_one_line_errors_naming_them(tmp_path):
    ant = _write_folder(tmp_path / "ant", body("ant"))
    missing = tmp_path / "nowhere"
    with pytest.raises(ValueError, match=f"^no summary.json in {missing} "):
        cl.evaluate_folders(missing, ant)
    with pytest.raises(ValueError, match=f"^no summary.json in {tmp_path} "):
        cl.evaluate_folders(tmp_path, ant)
    with pytest.raises(ValueError, match=r"ant/summary.json is of body 'ant', but it was passed as the point folder"):
        cl.evaluate_folders(ant, ant)
    without_dagger = body("point")
    del without_dagger.summary["methods"]["dagger"]
    point = _write_folder(tmp_path / "point", without_dagger)
    with pytest.raises(ValueError, match=r"point/summary.json has no dagger trials to compare with"):
        cl.evaluate_folders(point, ant)


def test_protocol_1_bad_folders_are_one_line_errors_naming_them(tmp_path, capsys):
    with pytest.raises(ValueError, match=f"^no summary.json in {tmp_path} "):
        cl.protocol1_figures(tmp_path)
    # A summary without episodes.csv beside it.
    bare = _write_folder(tmp_path / "bare", body("point"))
    with pytest.raises(ValueError, match=f"^no episodes.csv in {bare} "):
        cl.protocol1_figures(bare)
    # A summary from before total_labels (as the stage-1 ant's was), with its episodes.csv.
    older = body("ant")
    del older.summary["methods"]["dagger"]["total_labels"]
    old = _write_folder(tmp_path / "ant_stage1", older)
    (old / "episodes.csv").write_text("method,seed\n")
    with pytest.raises(ValueError, match=r"ant_stage1/summary.json: 'dagger' has no 'total_labels'"):
        cl.protocol1_figures(old)
    with pytest.raises(SystemExit):
        pc.main(["--folders", str(tmp_path / "nowhere")])
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines[-1].endswith(f": error: no summary.json in {tmp_path / 'nowhere'} (a paper-experiment results folder)")


def test_the_readmes_brief_table_carries_each_bodys_figures_and_the_same_verdicts(tmp_path, capsys):
    bodies = [body(name, gain={"reward": 0.15}) for name in cl.BODIES]
    report = cl.ClaimsReport(tuple(bodies), tuple(cl.judge_claims(bodies)))
    brief = pc.brief_markdown(report).splitlines()
    rows = [line for line in brief if line.startswith("| ") and line[2].isdigit()]
    assert len(rows) == 7
    # One verdict per claim, the full table's; the figures are per body, the medians the full table quotes.
    for line, verdict in zip(rows, report.verdicts, strict=True):
        assert line.endswith(f"| **{verdict.printed}** |")
    reward = bodies[0].method("reward")["final_success"]["median"]
    dagger = bodies[0].method("dagger")["final_success"]["median"]
    shown = [f"{100 * rate:.1f}".removesuffix(".0") for rate in (reward, dagger)]
    assert f"point: `reward` {shown[0]}% vs {shown[1]}%, p = " in rows[0]
    assert "<br>ant: `reward` " in rows[0] and reward > dagger
    assert "Protocol 2, seeds per method: point 10, ant 10." in brief[-1] and "INTERIM" not in brief[-1]
    assert "no people took part" in rows[6]


@pytest.mark.integration  # reads the committed results
def test_brief_needs_the_protocol_2_folders(capsys):
    pc.main(["--protocol2", str(FOLDERS / "point"), str(FOLDERS / "ant"), "--brief"])
    out = capsys.readouterr().out
    assert out.startswith("| # | the paper's claim |") and "Protocol 2, seeds per method: point 10, ant 10." in out
    assert "INTERIM" not in out
    with pytest.raises(SystemExit):
        pc.main(["--brief"])
    assert "--brief is the protocol-2 table's short form" in capsys.readouterr().err


def test_exact_percent_keeps_the_half_point_that_a_rounded_percent_loses():
    assert [cl.exact_percent(rate) for rate in (0.905, 0.9, 0.015, None)] == ["90.5%", "90%", "1.5%", "n/a"]
