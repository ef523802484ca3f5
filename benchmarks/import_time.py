"""Import time of ``antmaze_hirl`` against ``gymnasium_robotics``, each in fresh interpreters, same run.

Each measurement is a new ``python -c`` process (run in the repository root, so it imports this
checkout) that times its one import with ``perf_counter``, leaving out the interpreter's own start-up.
The two imports alternate, ``--repeats`` times each, and the medians are compared. Goal: ratio <= 1.5.
Importing ``antmaze_hirl`` registers the env ids; nothing heavier loads until it is used.

Usage: python benchmarks/import_time.py [--repeats 5]
Writes results/import_time/import_time.json.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import subprocess
import sys
from pathlib import Path

from antmaze_hirl.atomic_io import atomic_write_json

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results" / "import_time" / "import_time.json"
MODULES = ("antmaze_hirl", "gymnasium_robotics")
GOAL = 1.5

CHILD = """\
import json, sys, time
start = time.perf_counter()
import {module} as module
print(json.dumps({{"seconds": time.perf_counter() - start, "file": module.__file__,
                  "torch_loaded": "torch" in sys.modules}}))
"""


def time_import(module: str) -> dict:
    """One fresh interpreter's import of ``module``: seconds, where it came from, whether torch came with it."""
    child = subprocess.run(
        [sys.executable, "-c", CHILD.format(module=module)], cwd=ROOT, capture_output=True, text=True, check=True
    )
    return json.loads(child.stdout.splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=5, help="fresh imports of each module")
    args = parser.parse_args()
    runs: dict[str, list[dict]] = {module: [] for module in MODULES}
    for _ in range(args.repeats):
        for module in MODULES:  # alternating, so a slow spell of a shared machine hits both
            runs[module].append(time_import(module))
    medians = {module: statistics.median(run["seconds"] for run in runs[module]) for module in MODULES}
    ratio = medians["antmaze_hirl"] / medians["gymnasium_robotics"]
    result = {
        "median_seconds": {module: round(seconds, 4) for module, seconds in medians.items()},
        "seconds": {module: [round(run["seconds"], 4) for run in runs[module]] for module in MODULES},
        "ratio": round(ratio, 3),
        "goal_ratio_at_most": GOAL,
        "goal_met": ratio <= GOAL,
        "antmaze_hirl_loads_torch": any(run["torch_loaded"] for run in runs["antmaze_hirl"]),
        "antmaze_hirl_file": str(Path(runs["antmaze_hirl"][0]["file"]).relative_to(ROOT)),
        "repeats": args.repeats,
        "python": platform.python_version(),
    }
    for module, seconds in medians.items():
        print(f"import {module}: median {seconds * 1000:.0f} ms of {args.repeats}")
    print(f"ratio antmaze_hirl / gymnasium_robotics: {ratio:.2f} (goal <= {GOAL})")
    atomic_write_json(RESULTS, result)
    print(f"wrote {RESULTS}")


if __name__ == "__main__":
    main()
