import os
import sys
import warnings

import numpy as np
import pytest

from antmaze_hirl.study.data import participant_dir
from antmaze_hirl.study.export import MinariMissingError, check_dataset_id, export_minari, load_demonstrations
from antmaze_hirl.study.plan import make_plan, save_plan

minari = pytest.importorskip("minari")

# Minari recommends metadata (author, code link, env spec) that a study export has no value for.
pytestmark = pytest.mark.filterwarnings("ignore:.*(is set to None|env_spec is None).*:UserWarning")


def _demonstrations(rng, episode_lengths, successes, image=(3, 32, 32), state=5):
    n = sum(episode_lengths)
    episode = np.repeat(np.arange(len(episode_lengths)), episode_lengths)
    high_level_step = np.concatenate([np.arange(k) for k in episode_lengths])
    labelled = rng.random(n) < 0.5
    labels = rng.normal(size=(n, 2)).astype(np.float32)
    labels[~labelled] = np.nan
    terminal = np.zeros(n, dtype=bool)
    ends = np.cumsum(episode_lengths) - 1
    terminal[ends[np.asarray(successes)]] = True
    order = rng.permutation(n)  # the server may save steps in any order: export sorts them
    arrays = {
        "images": rng.integers(0, 256, size=(n, *image), dtype=np.uint8),
        "states": rng.normal(size=(n, state)).astype(np.float32),
        "executed": rng.normal(size=(n, 2)).astype(np.float32),
        "labels": labels,
        "labelled": labelled,
        "episode": episode,
        "high_level_step": high_level_step,
        "terminal_success": terminal,
    }
    arrays = {k: v[order] for k, v in arrays.items()}
    arrays["success"] = np.asarray(successes, dtype=bool)
    return arrays


@pytest.fixture
def study(tmp_path, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "minari"))
    plan = make_plan("point", ["noise", "reward"], participants=1, episodes=2, practice=1, seed=0)
    study_dir = tmp_path / "study"
    save_plan(plan, study_dir)
    rng = np.random.default_rng(0)
    saved = {}
    for trial, lengths, successes in [(0, [2], [False]), (1, [3, 2], [True, False]), (2, [1, 4], [False, True])]:
        arrays = _demonstrations(rng, lengths, successes)
        folder = participant_dir(study_dir, "P01") / f"trial{trial}"
        folder.mkdir(parents=True)
        np.savez(folder / "demonstrations.npz", **arrays)
        saved[trial] = arrays
    return study_dir, saved


def _sorted_steps(arrays, episode):
    rows = np.flatnonzero(arrays["episode"] == episode)
    return rows[np.argsort(arrays["high_level_step"][rows])]


def test_export_round_trips_through_minari(study, tmp_path):
    study_dir, saved = study
    path = export_minari(study_dir, "antmaze-hirl/study-v0")
    assert path == tmp_path / "minari" / "antmaze-hirl" / "study-v0"
    dataset = minari.load_dataset("antmaze-hirl/study-v0")
    assert dataset.spec.dataset_id == "antmaze-hirl/study-v0"
    assert dataset.total_episodes == 4  # the practice trial's episode is left out
    episodes = list(dataset.iterate_episodes())
    expected = [(trial, e) for trial in (1, 2) for e in range(2)]
    for minari_episode, (trial, e) in zip(episodes, expected, strict=True):
        arrays = saved[trial]
        rows = _sorted_steps(arrays, e)
        np.testing.assert_array_equal(minari_episode.actions, arrays["executed"][rows])
        np.testing.assert_array_equal(minari_episode.observations["image"][:-1], arrays["images"][rows])
        np.testing.assert_array_equal(minari_episode.observations["image"][-1], arrays["images"][rows[-1]])
        np.testing.assert_array_equal(minari_episode.observations["state"][:-1], arrays["states"][rows])
        np.testing.assert_array_equal(minari_episode.infos["label"][:-1], arrays["labels"][rows])
        assert np.isnan(minari_episode.infos["label"][-1]).all()
        np.testing.assert_array_equal(minari_episode.infos["labelled"][:-1], arrays["labelled"][rows])
        assert set(minari_episode.infos["trial"]) == {trial} and set(minari_episode.infos["episode"]) == {e}
        assert set(minari_episode.infos["participant"]) == {1}
        np.testing.assert_array_equal(minari_episode.rewards, arrays["terminal_success"][rows])
        assert minari_episode.terminations[-1] == arrays["success"][e]
        assert minari_episode.truncations[-1] == (not arrays["success"][e])
        assert not minari_episode.terminations[:-1].any() and not minari_episode.truncations[:-1].any()


def test_export_with_practice_and_a_data_path(study, tmp_path, monkeypatch):
    study_dir, _ = study
    elsewhere = tmp_path / "elsewhere"
    path = export_minari(study_dir, "antmaze-hirl/with-practice-v1", include_practice=True, data_path=elsewhere)
    assert path == elsewhere / "antmaze-hirl" / "with-practice-v1"
    assert os.environ["MINARI_DATASETS_PATH"] == str(tmp_path / "minari")  # restored after the export
    assert not (tmp_path / "minari" / "antmaze-hirl" / "with-practice-v1").exists()
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(elsewhere))
    dataset = minari.load_dataset("antmaze-hirl/with-practice-v1")
    assert dataset.total_episodes == 5
    assert [e.infos["trial"][0] for e in dataset.iterate_episodes()] == [0, 1, 1, 2, 2]


def test_export_refuses_an_existing_id(study):
    study_dir, _ = study
    export_minari(study_dir, "antmaze-hirl/study-v0")
    with pytest.raises(ValueError, match="'antmaze-hirl/study-v0' already exists"):
        export_minari(study_dir, "antmaze-hirl/study-v0")


@pytest.mark.parametrize(
    "bad", ["study-v0", "antmaze-hirl/study", "antmaze-hirl/study-v", "a b/c-v0", "ns/name-v01", ""]
)
def test_malformed_ids_are_rejected(bad):
    with pytest.raises(ValueError, match="must have the form 'namespace/name-v0'"):
        check_dataset_id(bad)


def test_valid_ids():
    for good in ("antmaze-hirl/study-v0", "ns/sub/name_2-v12", "lab/point.study-v3"):
        assert check_dataset_id(good) == good


def test_bad_demonstrations_are_named(study):
    study_dir, saved = study
    path = participant_dir(study_dir, "P01") / "trial1" / "demonstrations.npz"
    arrays = dict(saved[1])
    arrays["labels"] = arrays["labels"][:, :1]
    np.savez(path, **arrays)
    with pytest.raises(ValueError, match=r"trial1/demonstrations\.npz: labels has shape \(5, 1\)"):
        export_minari(study_dir, "antmaze-hirl/study-v0")
    arrays = dict(saved[1])
    arrays["labels"] = np.where(arrays["labelled"][:, None], np.nan, np.zeros((5, 2))).astype(np.float32)
    np.savez(path, **arrays)
    with pytest.raises(ValueError, match=r"is marked labelled but its label is \[nan, nan\]"):
        export_minari(study_dir, "antmaze-hirl/study-v0")
    arrays = dict(saved[1])
    arrays["images"] = arrays["images"].astype(np.float32)
    np.savez(path, **arrays)
    with pytest.raises(ValueError, match="images has dtype float32, expected uint8"):
        export_minari(study_dir, "antmaze-hirl/study-v0")
    arrays = dict(saved[1])
    arrays["episode"] = np.int64(0)
    np.savez(path, **arrays)
    with pytest.raises(ValueError, match=r"episode has shape \(\)"):
        export_minari(study_dir, "antmaze-hirl/study-v0")
    arrays = dict(saved[1])
    arrays["episode"] = arrays["episode"] + 1  # episode 2 of a trial with 2 episodes
    np.savez(path, **arrays)
    with pytest.raises(ValueError, match="episode index 2 outside success's 2 episodes"):
        export_minari(study_dir, "antmaze-hirl/study-v0")
    del arrays["labels"]
    np.savez(path, **arrays)
    with pytest.raises(ValueError, match=r"lacks the arrays \['labels'\]"):
        export_minari(study_dir, "antmaze-hirl/study-v0")


def _episodes(dataset_id):
    return [
        (e.actions, e.observations["state"], e.infos["label"], e.rewards, e.terminations)
        for e in minari.load_dataset(dataset_id).iterate_episodes()
    ]


def test_an_old_file_with_step_loads_and_exports_as_before(study):
    study_dir, saved = study
    export_minari(study_dir, "antmaze-hirl/new-v0")
    for trial, arrays in saved.items():  # rewrite every trial as 0.2.0 did: the high-level step under "step"
        old = {("step" if name == "high_level_step" else name): value for name, value in arrays.items()}
        path = participant_dir(study_dir, "P01") / f"trial{trial}" / "demonstrations.npz"
        np.savez(path, **old)
        loaded = load_demonstrations(path)
        assert "step" not in loaded and sorted(loaded) == sorted(arrays)
        np.testing.assert_array_equal(loaded["high_level_step"], arrays["high_level_step"])
    export_minari(study_dir, "antmaze-hirl/old-v0")
    for new, old in zip(_episodes("antmaze-hirl/new-v0"), _episodes("antmaze-hirl/old-v0"), strict=True):
        for new_array, old_array in zip(new, old, strict=True):
            np.testing.assert_array_equal(new_array, old_array)


def test_a_file_with_both_step_names_loads_if_they_agree_and_is_refused_naming_it_if_not(study):
    study_dir, saved = study
    path = participant_dir(study_dir, "P01") / "trial1" / "demonstrations.npz"
    np.savez(path, **saved[1], step=saved[1]["high_level_step"])
    assert "step" not in load_demonstrations(path)
    np.savez(path, **saved[1], step=saved[1]["high_level_step"] + 1)
    with pytest.raises(
        ValueError,
        match=r"trial1/demonstrations\.npz: 'high_level_step' and its old name 'step' hold different values \(at ",
    ):
        export_minari(study_dir, "antmaze-hirl/study-v0")
    np.savez(path, **{name: value for name, value in saved[1].items() if name != "high_level_step"})
    with pytest.raises(ValueError, match=r"trial1/demonstrations\.npz: no 'high_level_step' \(nor its old name"):
        export_minari(study_dir, "antmaze-hirl/study-v0")


def test_a_study_without_demonstrations(tmp_path, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "minari"))
    save_plan(make_plan("point", ["noise"], participants=1), tmp_path)
    with pytest.raises(ValueError, match="no demonstrations to export"):
        export_minari(tmp_path, "antmaze-hirl/empty-v0")


def test_missing_minari_gives_the_install_hint(study, monkeypatch):
    study_dir, _ = study
    monkeypatch.setitem(sys.modules, "minari", None)  # makes `import minari` raise ImportError
    with pytest.raises(MinariMissingError, match=r"Minari export needs the extra: pip install -e \.\[minari\]"):
        export_minari(study_dir, "antmaze-hirl/study-v0")
    assert issubclass(MinariMissingError, ImportError)


def test_the_dataset_records_the_env_spec_so_recover_environment_works(study, tmp_path):
    from study_helpers import TINY_SETTINGS

    from antmaze_hirl.study.settings import StudySettings, save_settings

    study_dir, _ = study
    save_settings(StudySettings.for_body("point", **TINY_SETTINGS), study_dir)
    export_minari(study_dir, "antmaze_hirl/spec-test-v0")
    dataset = minari.load_dataset("antmaze_hirl/spec-test-v0")
    assert dataset.spec.env_spec is not None and dataset.spec.env_spec.id == "antmaze_hirl/PointMaze-v0"
    env = dataset.recover_environment()
    try:
        assert env.unwrapped.maze_size == (TINY_SETTINGS["maze_size"],) * 2  # the study's maze family
        observation, _ = env.reset(seed=0)
        assert set(observation) == {"image", "state"}
    finally:
        env.close()


def test_export_names_the_missing_provenance_in_one_warning_and_records_what_is_given(study):
    study_dir, _ = study
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        export_minari(study_dir, "antmaze-hirl/bare-v0")
    messages = [str(warning.message) for warning in caught]
    assert messages == [
        "Minari dataset antmaze-hirl/bare-v0 records no author, author_email, code_permalink "
        "(give --author, --author-email, --code-permalink)"
    ]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        export_minari(study_dir, "antmaze-hirl/full-v0", author="A. Person", author_email="a@b.c", code_permalink="x")
    assert [str(warning.message) for warning in caught] == []
    metadata = minari.load_dataset("antmaze-hirl/full-v0").storage.metadata
    assert metadata["author"] == {"A. Person"} and metadata["code_permalink"] == "x"
