"""The README's tour runs as it appears: each of its ```python blocks, in a fresh interpreter, as a user pastes it.

The blocks are read from README.md itself, so a snippet that drifts from the API fails here. Each prints its
CPU seconds (user + system of the child), the load-robust measure of "a five-minute tour on 2 cores".
"""

import os
import re
import resource
import subprocess
import sys
from pathlib import Path

import pytest

# End to end (see pyproject.toml's markers): left out of the default unit tier, run by .ci/run.
pytestmark = pytest.mark.integration

ROOT = Path(__file__).resolve().parents[1]
BLOCK = re.compile(r"^```python\n(?P<code>.*?)^```$", re.MULTILINE | re.DOTALL)


def readme_blocks():
    """The README's python blocks, each with the heading it sits under (its test id)."""
    text = (ROOT / "README.md").read_text()
    blocks = []
    for match in BLOCK.finditer(text):
        headings = re.findall(r"^#+ (.+)$", text[: match.start()], re.MULTILINE)
        blocks.append(pytest.param(match["code"], id=headings[-1] if headings else "top"))
    return blocks


def test_the_readme_has_its_tour_blocks():
    assert len(readme_blocks()) >= 4


@pytest.mark.parametrize("code", readme_blocks())
def test_a_readme_block_runs_as_written(code, tmp_path):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    # One OpenMP thread: on a shared CI machine two threads spin against the other jobs (SAC's 6,000 steps took
    # 20x the CPU time at load 12 on 2 cores); a user's idle machine runs the snippets as they are.
    env["OMP_NUM_THREADS"] = "1"
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    result = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900
    )
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu_s = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    print(f"CPU {cpu_s:.1f} s; output: {result.stdout.strip()[-300:]}")
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-4000:]
