"""What code and machine wrote a results folder, and the check that a resume uses the same code."""

from __future__ import annotations

import hashlib
import platform
import subprocess
from importlib import metadata
from pathlib import Path
from typing import Any

import torch

PACKAGES = ("antmaze_hirl", "torch", "numpy", "gymnasium", "gymnasium-robotics", "mujoco", "stable-baselines3")
"""Distributions whose versions a results folder records and a resume must match."""

CODE_KEYS = ("git_commit", "source_sha256", "packages")
"""The provenance entries that identify the code; the machine's (CPU, threads) are recorded only."""

_PACKAGE_DIR = Path(__file__).resolve().parents[1]  # antmaze_hirl/, without importing the root


def _git(*args: str) -> str | None:
    try:
        done = subprocess.run(
            ["git", "-C", str(_PACKAGE_DIR), *args], capture_output=True, text=True, timeout=30, check=False
        )
    except (OSError, subprocess.SubprocessError):  # no git on this machine
        return None
    return done.stdout.strip() if done.returncode == 0 else None


def _version(package: str) -> str | None:
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return None


def source_sha256() -> str:
    """sha256 over the package's Python sources (relative path and content of each, in path order).

    It tells code apart where the commit cannot: uncommitted edits, or a copy installed without git.
    """
    digest = hashlib.sha256()
    for path in sorted(_PACKAGE_DIR.rglob("*.py")):
        digest.update(path.relative_to(_PACKAGE_DIR).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


def cpu_model() -> str:
    """The CPU's model name from ``/proc/cpuinfo``, else ``platform.processor()`` (may be empty)."""
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.exists():
        for line in cpuinfo.read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    return platform.processor()


def code_provenance() -> dict[str, Any]:
    """The code and machine of this process.

    Returns:
        ``git_commit`` (``None`` outside a git checkout), ``git_dirty`` (tracked files changed since
        that commit), ``source_sha256`` (:func:`source_sha256`), ``packages`` (versions of
        :data:`PACKAGES`, ``None`` if absent), ``python``, ``cpu_model`` and ``torch_threads``.
    """
    commit = _git("rev-parse", "HEAD")
    status = _git("status", "--porcelain", "--untracked-files=no") if commit else None
    return {
        "git_commit": commit,
        "git_dirty": None if status is None else bool(status),
        "source_sha256": source_sha256(),
        "packages": {package: _version(package) for package in PACKAGES},
        "python": platform.python_version(),
        "cpu_model": cpu_model(),
        "torch_threads": torch.get_num_threads(),
    }


def check_same_code(saved: dict[str, Any] | None, current: dict[str, Any], where: Path) -> None:
    """Raises unless ``saved`` (a folder's provenance, ``None`` if unrecorded) names the code of ``current``.

    Raises:
        ValueError: One line naming the two commits and what differs.
    """
    if saved is None:
        raise ValueError(
            f"{where} was written by code that recorded no provenance, this is commit {current['git_commit']}: "
            "use another --out, or pass --allow-code-change (allow_code_change=True) to resume it anyway"
        )
    differing = [key for key in CODE_KEYS if saved.get(key) != current[key]]
    if differing:
        raise ValueError(
            f"{where} was written by other code (commit {saved.get('git_commit')}), this is commit "
            f"{current['git_commit']} ({', '.join(differing)} differ): use another --out, or pass "
            "--allow-code-change (allow_code_change=True) to resume it anyway"
        )
