"""Runs a test script in a child process under MuJoCo's EGL backend (the backend is chosen at import)."""

import os
import subprocess
import sys

import pytest


def run_under_egl(script: str) -> str:
    """The child's stdout; skips the test when the script printed ``UNAVAILABLE`` (no EGL on this machine).

    Raises:
        AssertionError: If the child exits with an error (the tail of its stderr is the message).
    """
    env = {**os.environ, "MUJOCO_GL": "egl"}
    result = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-2000:]
    if "UNAVAILABLE" in result.stdout:
        pytest.skip(f"no EGL here: {result.stdout.strip()}")
    return result.stdout
