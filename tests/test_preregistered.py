"""Protocol 3's preregistered readings (antmaze_lab): fixed targets, verdict rules, Holm, the symmetry re-check."""

import ast
import copy
import json
import math
from pathlib import Path

import numpy as np
import pytest
from setuptools import find_packages

from antmaze_lab import preregistered as pre
from antmaze_lab.folders import BodyEvaluations, MethodEvaluations, symmetry_check

pytestmark = pytest.mark.integration  # a lab check (antmaze_lab.preregistered and folders): the integration tier

ROOT = Path(__file__).resolve().parents[1]
EPISODES = np.arange(0, 101, 10)


@pytest.fixture(scope="module")
def spec():
    loaded = pre.load_preregistration()
    loaded["statistics"]["resamples"] = 150  # the YAML's 10,000 in the reports; enough here for clear-cut tables
    return loaded


def method(success, labels_per_episode=10.0, seeds=10, mazes=40, rng=None):
    """A method whose seeds succeed on each maze with probability ``success[evaluation]`` (a fixed draw)."""
    rng = rng or np.random.default_rng(0)
    success = np.broadcast_to(np.asarray(success, dtype=float), (seeds, len(EPISODES)))
    outcomes = rng.random((seeds, len(EPISODES), mazes)) < success[:, :, None]
    labels = np.tile(EPISODES * labels_per_episode, (seeds, 1)).astype(float)
    return MethodEvaluations(tuple(range(seeds)), EPISODES.copy(), labels, outcomes)


def body(name="point", mazes=40, oracle=1.0, **methods):
    return BodyEvaluations(
        folder=Path(f"/crafted/{name}"),
        body=name,
        mazes=tuple(f"maze{i}" for i in range(mazes)),
        task_classes=tuple(f"task{i}" for i in range(mazes)),
        oracle_success=oracle,
        methods=methods,
    )


RISING = np.array([0.0, 0.3, 0.5, 0.6, 0.7, 0.75, 0.8, 0.85, 0.88, 0.9, 0.92])


# ---------------------------------------------------------------- fixed targets


def test_first_reach_reads_the_first_evaluation_at_the_target_without_interpolation():
    success = np.array([[0.0, 0.4, 0.55, 0.7], [0.0, 0.2, 0.3, 0.45]])
    labels = np.array([[0, 90, 180, 270], [0, 100, 200, 300]])
    assert pre.first_reach(success, labels, 0.5).tolist() == [180.0, math.inf]
    assert pre.first_reach(success, np.arange(4) * 10, 0.0).tolist() == [0.0, 0.0]
    assert pre.first_reach(np.array([[0.59999999999], [0.6 + 1e-12]]), [[5], [5]], 0.6).tolist() == [5.0, 5.0]


def test_log_saving_counts_a_never_above_every_count():
    saving = pre.log_saving(np.array([50, math.inf, 100, math.inf, 0]), np.array([100, 100, math.inf, math.inf, 0]))
    assert saving.tolist() == [pytest.approx(math.log(2)), -math.inf, math.inf, 0.0, 0.0]
    assert pre.median_effect(np.array([-math.inf] * 5 + [math.inf] * 5)) == 0.0


def test_a_method_identical_to_dagger_reads_equal_at_every_fixed_target(spec):
    dagger = method(RISING)
    crafted = body(dagger=dagger, copy=dagger)
    table = pre.fixed_targets(crafted, spec)["methods"]
    for own, copied in zip(table["dagger"]["targets"], table["copy"]["targets"], strict=True):
        assert {k: own[k] for k in own} == {k: copied[k] for k in own}  # same seeds reaching, same medians
        assert copied["vs_dagger"]["median_ratio"] == 1.0 and copied["vs_dagger"]["ratio_interval_95"] == [1.0, 1.0]
        assert copied["vs_dagger"]["p_for"] == 1.0  # no saving, whatever the resample
    # Read as a claim of saving, it is ruled out: the 10% saving is excluded (one target: with 150 resamples the
    # bootstrap's smallest p, 1/151, leaves room for one cell under Holm's 0.025 / 2).
    readings = pre.label_readings(crafted, "copy", [0.7], spec)
    cells = {"copy": [(r.p_for, r.p_against) for r in readings]}
    assert pre.decide({2: pre.claim_p_values(cells)}, 0.025)[2]["verdict"] == pre.DOES_NOT_HOLD


def test_dagger_paired_with_another_dagger_seed_reaches_each_target_as_often(spec):
    # Protocol 2's "labels to DAgger's own final" favoured DAgger; a fixed target does not depend on the pairing.
    dagger = method(RISING, rng=np.random.default_rng(7))
    order = np.roll(np.arange(10), 3)
    shuffled = MethodEvaluations(dagger.seeds, dagger.episodes, dagger.labels[order], dagger.outcomes[order])
    table = pre.fixed_targets(body(dagger=dagger, other=shuffled), spec)["methods"]
    for own, other in zip(table["dagger"]["targets"], table["other"]["targets"], strict=True):
        assert other["seeds_reaching"] == own["seeds_reaching"] and other["median_labels"] == own["median_labels"]
        low, high = other["vs_dagger"]["ratio_interval_95"]
        assert low <= 1.0 <= high or own["seeds_reaching"] == 0


def test_the_fixed_targets_count_honest_costs_and_the_oracle_target(spec):
    crafted = body(oracle=0.98, dagger=method(RISING), aggrevate=method(RISING, rng=np.random.default_rng(1)))
    table = pre.fixed_targets(crafted, spec)
    assert table["targets"] == [0.5, 0.6, 0.7, 0.8, 0.9, pytest.approx(0.931)]
    assert table["methods"]["aggrevate"]["answers_per_label"] == 16
    dagger_row = table["methods"]["dagger"]["targets"][0]
    aggrevate_row = table["methods"]["aggrevate"]["targets"][0]
    assert dagger_row["median_episodes"] == aggrevate_row["median_episodes"] == 20  # 50% first at episode 20
    assert aggrevate_row["median_labels"] == 16 * dagger_row["median_labels"]


# ---------------------------------------------------------------- verdict rules


@pytest.mark.parametrize(
    ("for_rejected", "against_rejected", "expected"),
    [
        (True, False, pre.HOLDS),
        (False, True, pre.DOES_NOT_HOLD),
        (False, False, pre.INCONCLUSIVE),
        (True, True, pre.HOLDS),
    ],
)
def test_the_verdict_table(for_rejected, against_rejected, expected):
    assert pre.verdict(for_rejected, against_rejected) == expected


def test_claim_p_values_one_method_on_every_body_or_every_method_on_some_body():
    cells = {"a": [(0.001, 0.9), (0.004, 0.8)], "b": [(0.2, 0.001), (0.3, 0.5)]}
    p_for, p_against = pre.claim_p_values(cells)
    assert p_for == pytest.approx(2 * 0.004)  # a on both bodies, Bonferroni over 2 methods
    assert p_against == 1.0  # a fails on no body (2 x 0.8 caps at 1), so the claim is not ruled out
    with pytest.raises(ValueError, match="methods with cells"):
        pre.claim_p_values({"a": []})


def test_decide_adjusts_the_whole_family_and_every_outcome_is_reachable():
    family = {1: (0.001, 0.9), 2: (0.9, 0.001), 3: (0.2, 0.3), 4: (0.0005, 0.0004)}
    decided = pre.decide(family, 0.025)
    assert [decided[n]["verdict"] for n in (1, 2, 3, 4)] == [pre.HOLDS, pre.DOES_NOT_HOLD, pre.INCONCLUSIVE, pre.HOLDS]
    assert decided[4]["below_delta"] and not decided[1]["below_delta"]
    assert decided[1]["p_for_holm"] == pytest.approx(6 * 0.001)  # third smallest of eight
    # The same p-values with a larger family: Holm no longer rejects 0.004 (8 x 0.004 > 0.025).
    assert (
        pre.decide({1: (0.004, 0.9), 5: (0.5, 0.5), 6: (0.5, 0.5), 7: (0.5, 0.5)}, 0.025)[1]["verdict"]
        == pre.INCONCLUSIVE
    )


@pytest.fixture(scope="module")
def success_spec():
    """The preregistration cut to its claims that read success and episodes (label readings are tested above).

    1,100 resamples: with fewer, the bootstrap's smallest p (1 / (B + 1)) would sit above the Wilcoxon floor and
    no claim could pass Holm.
    """
    loaded = pre.load_preregistration()
    loaded["statistics"]["resamples"] = 1100
    loaded["claims"] = [c for c in loaded["claims"] if c["kind"] in ("success", "episodes_to_success", "people")]
    return loaded


def crafted_bodies(better, untrained=0.0):
    """Two bodies where the reward-based methods gain ``better`` success at every evaluation (0: DAgger's copy)."""
    bodies = []
    for index, name in enumerate(("point", "ant")):
        curve = np.clip(RISING + untrained, 0, 1)
        rng = np.random.default_rng(10 + index)
        methods = {m: method(curve, mazes=60, rng=rng) for m in ("dagger", "multi_policy", "aggrevate")}
        for m in ("reward", "reward_per_step"):
            gained = method(np.clip(curve + better, 0, 1), mazes=60, rng=rng)
            methods[m] = methods["dagger"] if better == 0 else gained
        bodies.append(body(name, mazes=60, **methods))
    return bodies


@pytest.mark.parametrize(("better", "expected"), [(0.3, pre.HOLDS), (0.0, pre.DOES_NOT_HOLD), (0.03, pre.INCONCLUSIVE)])
def test_claim_one_on_crafted_bodies_holds_does_not_hold_or_is_inconclusive(success_spec, better, expected):
    found = pre.read_claims(crafted_bodies(better), success_spec)
    claims = {c["number"]: c for c in found["claims"]}
    assert claims[1]["verdict"] == expected
    assert found["family_size"] == 6 and not found["interim"]  # claims 1, 3 and 4, each for and against
    assert claims[5]["verdict"] == claims[7]["verdict"] == pre.NOT_TESTABLE  # decided before the data
    assert "dense" in claims[5]["variant"]["what"]


def test_claims_are_not_testable_when_the_learner_starts_at_the_target_or_a_method_is_missing(success_spec):
    claims = {c["number"]: c for c in pre.read_claims(crafted_bodies(0.3, untrained=0.65), success_spec)["claims"]}
    assert claims[4]["verdict"] == pre.NOT_TESTABLE and "untrained" in claims[4]["reason"]
    bodies = crafted_bodies(0.3)
    for crafted in bodies:
        del crafted.methods["multi_policy"]
    claims = {c["number"]: c for c in pre.read_claims(bodies, success_spec)["claims"]}
    assert claims[3]["verdict"] == pre.NOT_TESTABLE and "multi_policy" in claims[3]["reason"]
    assert claims[1]["verdict"] == pre.HOLDS  # the others are still read, in a family of 4


def test_an_interim_folder_gets_no_verdict(success_spec):
    spec = copy.deepcopy(success_spec)
    spec["run"]["complete_seeds"] = 11  # the crafted bodies have 10 seeds per method
    claims = pre.read_claims(crafted_bodies(0.3), spec)["claims"]
    assert {c["verdict"] for c in claims if c["number"] not in (5, 7)} == {"interim: no verdict"}


# ---------------------------------------------------------------- the preregistration and the lab's place


def test_the_yaml_and_the_page_state_the_same_numbers():
    spec, page = pre.load_preregistration(), (ROOT / "docs" / "preregistration.md").read_text()
    assert spec["statistics"]["alpha_one_sided"] == 0.025 and "`alpha = 0.025`" in page
    assert spec["statistics"]["resamples"] == 10000 and "10,000 resamples" in page
    assert spec["targets"] == {"fixed_success": [0.5, 0.6, 0.7, 0.8, 0.9], "oracle_share": 0.95}
    assert "50, 60, 70, 80 and 90% success, and 95% of the oracle's success" in page
    assert spec["costs"]["answers_per_label"] == {"aggrevate": 16} and "16 answers per label" in page
    assert len(spec["run"]["seeds"]) == 10 and len(spec["run"]["methods"]) == 7 and "10 x 7 x 2 = 140" in page
    assert [c["number"] for c in spec["claims"]] == list(range(1, 8))


def test_every_quote_of_the_paper_is_on_the_page_word_for_word_and_every_missing_one_says_so():
    spec, page = pre.load_preregistration(), (ROOT / "docs" / "preregistration.md").read_text()
    flat = " ".join(page.split())  # the page wraps its lines; the YAML folds them
    for claim in spec["claims"]:
        quote = claim["quote"]
        assert set(quote) == {"text", "section", "note"}, claim["number"]
        if quote["text"] is None:
            assert quote["section"] is None and "not found in the stored text" in quote["note"]
        else:
            assert f'"{quote["text"]}" ({quote["section"]})' in flat, claim["number"]
    row = {int(line.split("|")[1]): line for line in page.splitlines() if line[:4] in {f"| {n} " for n in range(1, 8)}}
    assert all("not found in the stored text" in row[n] for n in (3, 4, 5))


def test_a_preregistration_of_another_format_is_refused_naming_the_file(tmp_path):
    path = tmp_path / "p.yaml"
    path.write_text("format: other\n")
    with pytest.raises(ValueError, match=r"p\.yaml is not a preregistration"):
        pre.load_preregistration(path)


def test_the_lab_is_not_in_the_wheel_and_the_package_never_imports_it():
    assert "antmaze_lab" not in find_packages(str(ROOT), include=["antmaze_hirl*"])
    for path in (ROOT / "antmaze_hirl").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else []
            names += [node.module] if isinstance(node, ast.ImportFrom) and node.module else []
            assert not any(name.split(".")[0] == "antmaze_lab" for name in names), path


# ---------------------------------------------------------------- the committed files


@pytest.mark.integration  # reads the committed results
@pytest.mark.parametrize(("name", "tasks", "grids"), [("point", 100, 98), ("ant", 93, 41)])
def test_training_and_evaluation_are_disjoint_under_symmetry_in_the_committed_files(name, tasks, grids):
    check = symmetry_check(ROOT / "results" / "protocol2" / name)
    assert check["disjoint"] and check["shared_wall_grids"] == check["shared_tasks"] == 0
    assert (check["evaluation_tasks_up_to_symmetry"], check["evaluation_wall_grids_up_to_symmetry"]) == (tasks, grids)


def test_the_symmetry_check_names_an_evaluation_maze_that_is_a_training_mirror(tmp_path):
    trained = "111111/1S0001/101101/1000G1/111111"
    mirrored = "111111/1000S1/101101/1G0001/111111"  # the same walls mirrored left to right, start and goal too
    (tmp_path / "episodes.csv").write_text(f"method,seed,layout\ndagger,0,{trained}\n")
    (tmp_path / "eval_layouts.csv").write_text(f"set,seed,layout\ncurve,1,{mirrored}\n")
    import gzip

    with gzip.open(tmp_path / "evaluations.csv.gz", "wt") as handle:
        handle.write(
            f"method,seed,episode,labels,maze_seed,layout,task_class,success\ndagger,0,0,0,1,{mirrored},x,False\n"
        )
    check = symmetry_check(tmp_path)
    assert not check["disjoint"] and check["shared_wall_grids"] == 1 and check["shared_tasks"] == 1


@pytest.mark.integration  # reads the committed results
def test_the_command_refuses_a_missing_report_and_a_folder_of_another_body(tmp_path, capsys):
    assert pre.main(["table", str(tmp_path / "none.json")]) == 2
    assert capsys.readouterr().err.strip() == f"error: no report at {tmp_path / 'none.json'}"
    folders = [str(ROOT / "results" / "protocol2" / b) for b in ("ant", "point")]  # swapped
    assert pre.main(["read", *folders, "--json", str(tmp_path / "r.json"), "--resamples", "100"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and "is of body 'ant'" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "r.json").exists()


@pytest.mark.integration  # reads the committed results
def test_the_committed_dry_run_is_labelled_and_its_table_is_what_the_page_shows():
    report = json.loads((ROOT / "results" / "protocol2" / "preregistered_readings.json").read_text())
    assert report["label"] == pre.DRY_RUN_LABEL
    assert all(check["disjoint"] for check in report["symmetry"].values())
    assert pre.format_report(report).startswith("**Protocol 2's data read with protocol 3's preregistered rules")


def test_success_by_path_length_groups_the_final_outcomes_by_the_shortest_path(spec):
    short, long = "11111/1S0G1/11111", "11111/1S001/11101/1G001/11111"  # 2 and 6 cells from start to goal
    outcomes = np.zeros((2, len(EPISODES), 3), dtype=bool)
    outcomes[:, -1] = [[True, True, False], [True, False, False]]
    dagger = MethodEvaluations((0, 1), EPISODES.copy(), np.zeros((2, len(EPISODES))), outcomes)
    crafted = BodyEvaluations(Path("/crafted"), "point", (short, short, long), ("a", "a", "b"), 1.0, {"dagger": dagger})
    rows = pre.success_by_path_length(crafted, spec)
    assert list(rows) == ["2", "6"]
    assert (rows["2"]["mazes"], rows["2"]["task_classes"], rows["2"]["dagger"]["rate"]) == (2, 1, 0.75)
    assert rows["6"]["dagger"] == {"rate": 0.0, "interval_95": [0.0, 0.0]}
