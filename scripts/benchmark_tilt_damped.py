"""``antmaze-hirl benchmark`` with an ant low level wrapped in the tilt-damping safety filter (a lab driver).

The benchmark command takes a low level as a zip or a name; the filter
(:class:`~antmaze_hirl.envs.controllers.TiltDampedController`, default off everywhere) is a wrapper around one, so this
script loads the low level as the command does (``load_low_level``), wraps it, and calls the same
:func:`~antmaze_hirl.experiments.benchmark.score_policy` with the command's arguments. The report is the command's
(every episode, flips, steps) with ``low_level`` naming the zip, its fingerprint and the filter's settings, and
``command`` this script's command line. The oracle only: the filter is a low-level candidate, measured under the
benchmark's reference high level.

Usage: python scripts/benchmark_tilt_damped.py SUITE --low-level ZIP --upper-uprightness U --lower-uprightness L
           --min-scale K [--episodes-per-task 20] [--seed 0] [--num-envs 8] --json OUT.json
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from antmaze_hirl.envs.suite_specs import SUITE_SPECS
from antmaze_hirl.experiments.benchmark import DEFAULT_NUM_ENVS


def build_parser() -> argparse.ArgumentParser:
    """The command line's parser."""
    parser = argparse.ArgumentParser(
        prog="python scripts/benchmark_tilt_damped.py",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("suite", help=f"an ant suite: one of {', '.join(SUITE_SPECS)} (required)")
    parser.add_argument("--low-level", required=True, help="the wrapped low level: a zip path or a name (required)")
    parser.add_argument("--upper-uprightness", type=float, required=True, help="actions pass at or above (required)")
    parser.add_argument("--lower-uprightness", type=float, required=True, help="min scale at or below (required)")
    parser.add_argument("--min-scale", type=float, required=True, help="the multiplier at the lower bound (required)")
    parser.add_argument("--episodes-per-task", type=int, default=None, help="K (default: the suite's)")
    parser.add_argument(
        "--seed",
        type=int,
        default=0,
        help="episode j of task k resets with seed + k*K + j (default: 0)",
    )
    parser.add_argument("--num-envs", type=int, default=DEFAULT_NUM_ENVS, help="lockstep mazes (default: %(default)s)")
    parser.add_argument("--json", type=Path, required=True, help="the report's path (required)")
    return parser


def main(argv: list[str] | None = None) -> int:
    """Scores the oracle with the damped low level; writes the report; exit 2 on bad input."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.suite not in SUITE_SPECS or SUITE_SPECS[args.suite].body != "ant":
        parser.error(f"suite must be an ant suite of {', '.join(SUITE_SPECS)}, got {args.suite!r}")
    import torch

    from antmaze_hirl.envs.controllers import TiltDampedController
    from antmaze_hirl.experiments.benchmark import save_report, score_policy
    from antmaze_hirl.experiments.benchmark_command import report_table
    from antmaze_hirl.sb3_ext.loading import load_low_level, policy_fingerprint

    torch.set_num_threads(1)
    settings = {
        "upper_uprightness": args.upper_uprightness,
        "lower_uprightness": args.lower_uprightness,
        "min_scale": args.min_scale,
    }
    try:
        TiltDampedController(print, **settings)  # the settings checked before the low level loads
        model = load_low_level("ant", args.low_level)
        damped = TiltDampedController(model, **settings)
        report = score_policy(
            args.suite,
            "oracle",
            episodes_per_task=args.episodes_per_task,
            seed=args.seed,
            num_envs=args.num_envs,
            low_level=damped,
        )
    except (ValueError, FileNotFoundError) as error:
        parser.error(str(error))
    report["low_level"] = (
        f"{args.low_level}: {type(model).__name__} {policy_fingerprint(model)}, TiltDampedController(upper_uprightness="
        f"{args.upper_uprightness:g}, lower_uprightness={args.lower_uprightness:g}, min_scale={args.min_scale:g})"
    )
    report["command"] = shlex.join(["python", "scripts/benchmark_tilt_damped.py", *(argv or sys.argv[1:])])
    print(report_table(report, per_task=False))
    save_report(report, args.json)
    print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
