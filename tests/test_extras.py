"""The core install works without the ``study`` extra (web and statistics stack), and says when it is needed."""

import subprocess
import sys

import pytest

from antmaze_hirl.cli import STUDY_EXTRA_MODULES

# Run in a fresh interpreter whose sys.modules maps each study module to None, so importing one raises
# ImportError exactly as in a venv without the extra (and find_spec reports it missing).
BLOCK = f"import sys\nSTUDY = {STUDY_EXTRA_MODULES!r}\nfor name in STUDY:\n    sys.modules[name] = None\n"

CORE = """
import importlib, pkgutil
import gymnasium as gym
import antmaze_hirl
for module in pkgutil.walk_packages(antmaze_hirl.__path__, "antmaze_hirl."):
    if not module.name.startswith("antmaze_hirl.study"):
        try:
            importlib.import_module(module.name)
        except ModuleNotFoundError as error:
            if error.name.split(".")[0] in STUDY:
                raise
            print("skipped", module.name, "(needs", error.name + ")")  # another extra's interop: imitation, ray
# Every registered id, the benchmark suites' included (ENV_IDS lists only the four base ids).
ids = [env_id for env_id in gym.registry if env_id.startswith("antmaze_hirl/")]
assert len(ids) > len(antmaze_hirl.ENV_IDS), ids
for env_id in ids:
    env = gym.make(env_id)
    env.reset(seed=0)
    env.step(env.action_space.sample())
    env.close()
print("core ok")
"""


def run_blocked(code: str, tmp_path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", BLOCK + code], capture_output=True, text=True, timeout=300, cwd=tmp_path
    )


def test_the_block_makes_a_study_module_unimportable(tmp_path):
    # The check below would pass vacuously if the block let pandas through.
    result = run_blocked("import pandas", tmp_path)
    assert result.returncode != 0 and "ModuleNotFoundError: import of pandas halted" in result.stderr


@pytest.mark.integration
def test_core_modules_and_every_id_need_no_study_extra(tmp_path):
    result = run_blocked(CORE, tmp_path)
    assert result.returncode == 0, result.stderr[-2000:]
    assert result.stdout.strip().endswith("core ok")


def test_the_missing_extra_hint_says_how_to_install_it_from_a_checkout(tmp_path):
    code = "from antmaze_hirl.cli import main\nmain(['study', 'analyze', 'runs/study'])\n"
    result = run_blocked(code, tmp_path)
    assert result.returncode == 2
    # The last line, not the only one: older gymnasium-robotics warn on stderr as they register their ids.
    assert result.stderr.strip().splitlines()[-1] == (
        "antmaze-hirl study: error: needs fastapi, starlette, uvicorn, statsmodels, pandas: "
        "from the project's checkout: pip install '.[study]' (an installed package: pip install 'antmaze_hirl[study]')"
    )
    assert "Traceback" not in result.stderr
    assert not (tmp_path / "runs").exists()


def test_the_wilson_interval_equals_statsmodels():
    proportion = pytest.importorskip("statsmodels.stats.proportion")
    from antmaze_hirl.experiments.uncertainty import wilson_interval

    for trials in (1, 2, 5, 10, 37, 100, 300):
        for successes in range(trials + 1):
            low, high = proportion.proportion_confint(successes, trials, alpha=0.05, method="wilson")
            assert wilson_interval(successes, trials) == pytest.approx((max(0.0, low), min(1.0, high)), abs=1e-12)
