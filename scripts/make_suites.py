"""Regenerates ``antmaze_hirl/envs/benchmark_suites.json``, the benchmark suites' task lists, byte for byte.

The tasks are drawn by :func:`antmaze_hirl.envs.suites.draw_suite_tasks` (seeded, pure); the checksums
they must match live in :data:`antmaze_hirl.envs.suite_specs.SUITE_SPECS`. ``--check`` only compares
(exit 1 on a difference), so CI or a reviewer can confirm the committed file is what the code draws.

Usage: python scripts/make_suites.py [--check]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from antmaze_hirl.atomic_io import atomic_write_bytes
from antmaze_hirl.envs.suite_specs import SUITE_SPECS
from antmaze_hirl.envs.suites import SUITES_FILE, draw_suite_tasks, suites_file_text, tasks_checksum

TARGET = Path(__file__).resolve().parents[1] / "antmaze_hirl" / "envs" / SUITES_FILE


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--check", action="store_true", help="compare with the committed file; write nothing")
    args = parser.parse_args()
    for name, spec in SUITE_SPECS.items():
        checksum = tasks_checksum(draw_suite_tasks(name))
        status = "ok" if checksum == spec.checksum else f"MISMATCH (spec says {spec.checksum})"
        print(f"{name:<7} {spec.env_id:<32} {spec.n_tasks:>4} tasks  sha256 {checksum}  {status}")
    text = suites_file_text()
    if args.check:
        same = TARGET.is_file() and TARGET.read_text() == text
        print(f"{TARGET}: {'identical' if same else 'DIFFERS'}")
        return 0 if same else 1
    atomic_write_bytes(TARGET, text.encode())
    print(f"wrote {TARGET}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
