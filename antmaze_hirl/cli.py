"""The antmaze-hirl command line: demo, train-low, eval-low, ensemble-low, experiment, study, benchmark, submit.

Each subcommand's handler imports what it needs when it runs, so that ``antmaze-hirl --help`` loads
neither torch nor Stable-Baselines3.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
from collections.abc import Callable, Sequence
from pathlib import Path

from antmaze_hirl.atomic_io import atomic_write_json
from antmaze_hirl.cli_validation import (
    INIT_FROM_VALUE,
    LOW_LEVEL_VALUE,
    SB3_PICKLE_WARNING,
    SB3_ZIP_WARNING,
    apply_bounds,
)
from antmaze_hirl.envs.bodies import BODY_SPECS
from antmaze_hirl.experiments.backends import add_backend_arguments, backend_settings
from antmaze_hirl.experiments.config import (
    BODY_DEFAULTS,
    CURRENT_PROTOCOL,
    DEFAULT_METHODS,
    HELD_OUT_MAZE_SIZE,
    LEARNERS,
    PROTOCOLS,
    ExperimentConfig,
    body_settings,
    protocol_evaluation_envs,
)
from antmaze_hirl.sb3_ext.config import ALGOS

DESCRIPTION = "Active hierarchical imitation learning on the MuJoCo Ant maze."
EPILOG = """\
Run 'antmaze-hirl COMMAND --help' for a command's options and an example.

example:
  antmaze-hirl demo --body ant"""

_Subparsers = argparse._SubParsersAction
STUDY_EXTRA_MODULES = ("fastapi", "starlette", "uvicorn", "statsmodels", "pandas")
"""What ``pip install 'antmaze_hirl[study]'`` adds: the study page's ASGI stack and its report's statistics."""
STUDY_EXTRA_HINT = (
    "from the project's checkout: pip install '.[study]' (an installed package: pip install 'antmaze_hirl[study]')"
)
"""How to add the study extra: the project is installed from its checkout, so the path form comes first."""
_BODIES = sorted(BODY_SPECS)
EVAL_LOW_ENVS = {"ant": 25, "point": 1}
"""eval-low's default ``--num-envs``: building a point reach env (MuJoCo compiles its XML) costs more than
batching its small policy saves over 200 subgoals; the ant's policy forward dominates its run."""


class _HelpFormatter(argparse.ArgumentDefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """Shows defaults, and keeps the line breaks of descriptions and examples.

    An option whose default is ``None`` or that is required says what it means in its own help
    instead of a bare "(default: None)".
    """

    def _get_help_string(self, action: argparse.Action) -> str:
        help_text = action.help or ""
        if action.default is None or action.required or "(default:" in help_text:
            return help_text
        return super()._get_help_string(action)


def _add_parser(
    subparsers: _Subparsers, name: str, help_text: str, example: str, description: str | None = None
) -> argparse.ArgumentParser:
    # Every subcommand's parser: its help line, a description (default: the help line as a sentence), an example.
    return subparsers.add_parser(
        name,
        help=help_text,
        description=description or help_text[0].upper() + help_text[1:] + ".",
        epilog=f"example:\n  {example}",
        formatter_class=_HelpFormatter,
    )


_DEFAULT_SIZES = {body: settings["maze_size"] for body, settings in BODY_DEFAULTS.items()}


def _per_body(values: dict[str, int]) -> str:
    # "ant 3, point 5": a default that depends on --body, for help texts.
    return ", ".join(f"{body} {value}" for body, value in sorted(values.items()))


def _add_demo(subparsers: _Subparsers) -> None:
    parser = _add_parser(
        subparsers,
        "demo",
        "let the scripted oracle drive the hierarchy through a random maze and draw the path",
        "antmaze-hirl demo --body ant --seed 3 --out runs/demo_ant",
    )
    parser.add_argument("--body", choices=_BODIES, default="point", help="body to walk")
    parser.add_argument("--seed", type=int, default=0, help="seed of the maze, start, goal and simulation")
    parser.add_argument("--out", type=Path, default=Path("runs/demo"), help="folder for demo.png")
    parser.add_argument(
        "--maze-size",
        type=int,
        default=None,
        help=f"free cells per side (default: per body, {_per_body(_DEFAULT_SIZES)})",
    )
    parser.add_argument(
        "--subgoal-reach-m",
        type=float,
        default=None,
        help="the oracle's farthest subgoal, metres (default: per body, ant 2 m, point one cell)",
    )
    parser.set_defaults(handler=_run_demo)


def _run_demo(args: argparse.Namespace) -> int:
    from antmaze_hirl.demo import run_demo

    result = run_demo(
        body=args.body,
        seed=args.seed,
        out_dir=args.out,
        maze_size=args.maze_size,
        subgoal_reach_m=args.subgoal_reach_m,
    )
    print(
        f"{result.outcome}: {result.subgoals} subgoals, {result.low_level_steps} low-level steps; "
        f"picture: {result.picture}"
    )
    return 0 if result.success else 1


def _add_train_low(subparsers: _Subparsers) -> None:
    parser = _add_parser(
        subparsers,
        "train-low",
        "train a low-level reach policy with SB3 TD3/DDPG/SAC (or TQC) + HER",
        "antmaze-hirl train-low --body point --timesteps 20000 --out runs/point_td3",
    )
    parser.add_argument("--body", choices=_BODIES, required=True, help="body to train (required)")
    parser.add_argument(
        "--algo", choices=list(ALGOS), default="td3", help="SB3 algorithm (tqc: sb3-contrib's, pip install '.[tqc]')"
    )
    parser.add_argument(
        "--timesteps", type=int, required=True, help="total env steps, counting resumed ones (required)"
    )
    parser.add_argument(
        "--out", type=Path, required=True, help="run folder: checkpoints, learning curve, policy.zip (required)"
    )
    parser.add_argument("--resume", action="store_true", help="continue from the latest checkpoint in --out")
    parser.add_argument("--seed", type=int, default=0, help="seed of the model and envs")
    parser.add_argument(
        "--init-from",
        type=Path,
        default=None,
        help=f"warm start from this policy's weights: {INIT_FROM_VALUE}; {SB3_ZIP_WARNING} (default: none)",
    )
    parser.add_argument(
        "--init-buffer",
        type=Path,
        default=None,
        help="warm start's replay buffer: another run's checkpoints/ckpt-<n>/replay_buffer.pkl, relabelled with "
        f"this run's reward; {SB3_PICKLE_WARNING} (default: an empty buffer)",
    )
    parser.add_argument(
        "--hyperparams",
        type=Path,
        default=None,
        help="YAML whose body section overrides the shipped hyperparams.yml (default: the shipped values)",
    )
    parser.add_argument("--checkpoint-freq", type=int, default=50_000, help="env steps between checkpoints")
    parser.add_argument("--eval-freq", type=int, default=25_000, help="env steps between success-rate evaluations")
    parser.add_argument("--eval-episodes", type=int, default=50, help="held-out subgoals per evaluation")
    parser.add_argument("--no-snapshots", action="store_true", help="do not keep the policy of every evaluation")
    parser.add_argument("--threads", type=int, default=1, help="torch CPU threads")
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    parser.set_defaults(handler=_run_train_low)


def _run_train_low(args: argparse.Namespace) -> int:
    from antmaze_hirl.sb3_ext.config import load_config
    from antmaze_hirl.sb3_ext.training import set_torch_threads, train_low_level

    set_torch_threads(args.threads)
    model = train_low_level(
        args.body,
        args.algo,
        args.timesteps,
        args.out,
        seed=args.seed,
        resume=args.resume,
        config=load_config(args.body, args.hyperparams, algo=args.algo),
        init_from=args.init_from,
        init_buffer=args.init_buffer,
        checkpoint_freq=args.checkpoint_freq,
        eval_freq=args.eval_freq,
        eval_episodes=args.eval_episodes,
        snapshots=not args.no_snapshots,
        progress_bar=not args.no_progress,
    )
    print(f"trained {model.num_timesteps} steps; policy: {args.out / 'policy.zip'}")
    return 0


def _add_eval_low(subparsers: _Subparsers) -> None:
    parser = _add_parser(
        subparsers,
        "eval-low",
        "success rate of a low-level policy on seeded random subgoals",
        "antmaze-hirl eval-low --body point --policy runs/point_sac/policy.zip --episodes 100",
    )
    parser.add_argument("--body", choices=_BODIES, required=True, help="body the policy walks (required)")
    parser.add_argument(
        "--policy", type=Path, default=None, help=f"{LOW_LEVEL_VALUE}; {SB3_ZIP_WARNING} (default: the shipped one)"
    )
    parser.add_argument("--episodes", type=int, default=200, help="subgoals to try")
    parser.add_argument(
        "--seed", type=int, default=0, help="subgoal i uses seed SEED+i, so disjoint sets need seeds --episodes apart"
    )
    parser.add_argument(
        "--sample-radius-m",
        type=float,
        default=None,
        help="largest distance of the subgoals drawn, metres: ReachEnv's sample_radius_m (default: one cell)",
    )
    parser.add_argument(
        "--num-envs",
        type=int,
        default=None,
        help="subgoals tried at once, one batched forward pass per step (default: ant 25; point 1, whose copies "
        "cost more to build than batching saves); 1: one after another, for exact replays of earlier results",
    )
    parser.add_argument(
        "--json", type=Path, default=None, help="also write the figures to this JSON file (default: print only)"
    )
    parser.set_defaults(handler=_run_eval_low)


def _run_eval_low(args: argparse.Namespace) -> int:
    from antmaze_hirl.envs.reach import ReachEnv
    from antmaze_hirl.experiments.runner import low_level_identity
    from antmaze_hirl.sb3_ext.evaluation import evaluate_reach
    from antmaze_hirl.sb3_ext.loading import load_low_level

    try:
        env = ReachEnv(args.body, sample_radius_m=args.sample_radius_m)
    except ValueError as error:
        raise ValueError(f"--sample-radius-m {args.sample_radius_m}: {error}") from error
    policy = load_low_level(args.body, path=args.policy)
    num_envs = args.num_envs or EVAL_LOW_ENVS[args.body]
    result = {
        **evaluate_reach(policy, env, episodes=args.episodes, seed=args.seed, num_envs=num_envs),
        "num_envs": num_envs,
        "low_level_id": low_level_identity(args.body, policy),  # which weights these figures belong to
        # The set of subgoals played: a reader pairing or pooling files checks these, not a name or its own notes.
        "seed": args.seed,
        "sample_radius_m": env.sample_radius_m,
    }
    print(json.dumps(result))
    if args.json is not None:
        atomic_write_json(args.json, result)
    return 0


def _add_ensemble_low(subparsers: _Subparsers) -> None:
    parser = _add_parser(
        subparsers,
        "ensemble-low",
        "one low-level policy acting with the mean action of several TD3 policies",
        "antmaze-hirl ensemble-low --body ant runs/a/snapshots/step_750000.zip runs/b/policy.zip --out ens.zip",
    )
    parser.add_argument("--body", choices=_BODIES, required=True, help="body the members walk (required)")
    parser.add_argument(
        "members",
        nargs="+",
        type=Path,
        help="TD3/DDPG .zip files of that body, two or more heads in all; an ensemble's heads join in order; "
        f"{SB3_ZIP_WARNING} (required)",
    )
    parser.add_argument("--out", type=Path, required=True, help="the ensemble's .zip (required)")
    parser.add_argument("--force", action="store_true", help="replace an existing file at --out")
    parser.add_argument(
        "--sequential-heads",
        action="store_true",
        help="compute the heads one after another, as stage 5 does (slower; batched heads round differently)",
    )
    parser.set_defaults(handler=_run_ensemble_low)


def _run_ensemble_low(args: argparse.Namespace) -> int:
    from antmaze_hirl.experiments.runner import low_level_identity
    from antmaze_hirl.sb3_ext.ensemble import build_ensemble
    from antmaze_hirl.sb3_ext.loading import save_policy

    if args.out.exists() and not args.force:
        raise FileExistsError(f"--out {args.out} exists; pass --force to replace it")
    ensemble = build_ensemble(args.members, args.body, batched_heads=not args.sequential_heads)
    path = save_policy(ensemble, args.out)
    identity = low_level_identity(args.body, ensemble)  # the saved weights: no need to read the zip back
    print(json.dumps({"out": str(path), "members": [str(member) for member in args.members], "low_level_id": identity}))
    return 0


def _add_experiment(subparsers: _Subparsers) -> None:
    defaults = ExperimentConfig()
    parser = _add_parser(
        subparsers,
        "experiment",
        "DAgger with active learning over methods and seeds, by default in the current protocol "
        f"(protocol {CURRENT_PROTOCOL}: held-out layouts, one fixed evaluation set scored from episode 0; "
        "docs/guides/protocol.md)",
        "antmaze-hirl experiment --body ant --out runs/ant --jobs 2\n"
        "  antmaze-hirl experiment --body point --out runs/point --backend ray --address head-node:6379",
    )
    parser.add_argument("--body", choices=_BODIES, default=defaults.body, help="body of the hierarchy")
    parser.add_argument(
        "--methods",
        default=",".join(DEFAULT_METHODS),
        help="comma-separated query strategies: any of the default's, gated, or gated+noise, gated+multi_policy, "
        "gated+reward, gated+aggrevate (uncertainty-gated queries)",
    )
    parser.add_argument("--seeds", type=int, default=5, help="trials per method, seeds 0..N-1")
    parser.add_argument("--episodes", type=int, default=defaults.episodes, help="training episodes per trial")
    parser.add_argument(
        "--out", type=Path, required=True, help="results folder; resumes trials already there (required)"
    )
    parser.add_argument("--eval-every", type=int, default=defaults.eval_every, help="M: evaluate every M episodes")
    parser.add_argument(
        "--eval-episodes",
        type=int,
        default=defaults.eval_episodes,
        help="protocol 1 only: held-out mazes per intermediate evaluation",
    )
    parser.add_argument(
        "--final-eval-episodes",
        type=int,
        default=defaults.final_eval_episodes,
        help="held-out mazes at the end (protocol 2: the one set every evaluation plays)",
    )
    parser.add_argument(
        "--maze-size",
        type=int,
        default=None,
        help=f"free cells per side (default: per body, {_per_body(HELD_OUT_MAZE_SIZE)}, the held-out families; "
        f"in protocol 1 without --held-out-layouts {_per_body(_DEFAULT_SIZES)})",
    )
    parser.add_argument(
        "--gradient-steps", type=int, default=defaults.gradient_steps, help="N: gradient steps per update"
    )
    parser.add_argument("--decay", type=float, default=defaults.decay, help="d in beta <- beta / d")
    parser.add_argument(
        "--subgoal-reach-m",
        type=float,
        default=None,
        help="the oracle's farthest subgoal, metres: ExperimentConfig.subgoal_reach_m "
        "(default: per body, point one cell, ant 2 m)",
    )
    parser.add_argument(
        "--held-out-layouts",
        action="store_true",
        help="with --protocol 1: draw the training mazes and both evaluation sets from disjoint sets of wall grids "
        "(see antmaze_hirl.envs.layout_splits), as the committed protocol-1 folders; without it protocol 1 holds "
        "mazes out by seed only (protocol 2 always holds layouts out)",
    )
    parser.add_argument(
        "--protocol",
        choices=[str(protocol) for protocol in PROTOCOLS],
        default=str(defaults.protocol),
        help=f"how mazes are held out and curves read: {CURRENT_PROTOCOL}, the current protocol of "
        "docs/guides/protocol.md (held-out layouts, symmetry-closed; one fixed evaluation set scored from "
        "episode 0; a learner without a planning prior); 1, the superseded protocol of the committed "
        "results/paper_experiment folders",
    )
    parser.add_argument(
        "--learner",
        choices=sorted(LEARNERS),
        default=None,
        help="the high-level learner (default: protocol 2's generic learner, or in protocol 1 the body's default)",
    )
    parser.add_argument(
        "--evaluation-envs",
        type=int,
        default=None,
        help=f"mazes each evaluation plays at once, in lockstep (default: {defaults.evaluation_envs} in protocol "
        f"{CURRENT_PROTOCOL}; in protocol 1, {protocol_evaluation_envs(1)}: one after another, as "
        "its committed folders were made; ant outcomes differ between the two, see docs/guides/vector-envs.md)",
    )
    add_backend_arguments(parser)
    parser.add_argument(
        "--allow-code-change",
        action="store_true",
        help="resume a results folder written by other code (another commit or package versions)",
    )
    parser.add_argument(
        "--tensorboard",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="log each trial's episodes to OUT/tb/<method>_seed<k>/ (view: tensorboard --logdir OUT/tb)",
    )
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    parser.set_defaults(handler=_run_experiment)


def _rounded(value: float | None, digits: int = 3, missing: str = "n/a") -> str:
    """A summary figure for the terminal: rounded, and ``missing`` where there is none (``None``, NaN)."""
    if value is None or value != value:  # None, or NaN (a median over no seed)
        return missing
    return f"{value:.{digits}f}"


def _run_experiment(args: argparse.Namespace) -> int:
    import torch

    from antmaze_hirl.experiments.runner import run_experiment

    methods = [method.strip() for method in args.methods.split(",") if method.strip()]
    if not methods:
        raise ValueError(f"--methods names no method, got {args.methods!r}; give a comma-separated list")
    if args.seeds < 1:
        raise ValueError(f"--seeds must be >= 1 (trials per method), got {args.seeds}")
    torch.set_num_threads(args.cpus_per_trial)
    held_out = args.held_out_layouts or int(args.protocol) >= 2  # protocol 2 evaluates on the held-out part
    evaluation_envs = args.evaluation_envs
    if evaluation_envs is None:  # each protocol's own: protocol 1's folders were evaluated one maze at a time
        evaluation_envs = protocol_evaluation_envs(int(args.protocol))
    config = ExperimentConfig(
        body=args.body,
        episodes=args.episodes,
        eval_every=args.eval_every,
        eval_episodes=args.eval_episodes,
        final_eval_episodes=args.final_eval_episodes,
        gradient_steps=args.gradient_steps,
        decay=args.decay,
        held_out_layouts=held_out,
        protocol=int(args.protocol),
        learner=args.learner,
        evaluation_envs=evaluation_envs,
        **body_settings(
            args.body,
            held_out_layouts=held_out,
            maze_size=args.maze_size,
            subgoal_reach_m=args.subgoal_reach_m,
        ),
    )
    summary = run_experiment(
        methods,
        args.seeds,
        config,
        args.out,
        progress_bar=not args.no_progress,
        allow_code_change=args.allow_code_change,
        tensorboard=args.tensorboard,
        **backend_settings(args),
    )
    for method, figures in summary["methods"].items():
        final = figures["final_success"]
        pooled = final["pooled"]
        # Protocol 2 pools with a cluster bootstrap over seeds and mazes; protocol 1 with a Wilson interval.
        low, high = pooled.get("cluster_bootstrap_95") or pooled["wilson_95"]
        print(
            f"{method}: final success median {_rounded(final['median'])} (min {_rounded(final['min'])}, max "
            f"{_rounded(final['max'])}; pooled {pooled['rate']:.3f}, 95% CI {low:.3f}-{high:.3f}), "
            f"normalised AUC median {_rounded(figures['normalised_auc']['median'])}, "
            f"expert cost/episode {figures['mean_expert_cost_per_episode']:.1f}, "
            f"attempts/episode {figures['mean_attempts_per_episode']:.1f}, "
            f"labels to 60% success {_rounded(figures['cost_to_60_percent']['median'], 0, 'not reached')}"
        )
    print(f"wrote {args.out / 'summary.json'}, {args.out / 'episodes.csv'}, {args.out / 'panels.png'}")
    return 0


def _add_study(subparsers: _Subparsers) -> None:
    from antmaze_hirl.study.cli import add_study_parser  # light: its handlers import the server lazily

    add_study_parser(subparsers, _HelpFormatter)


def _add_benchmark(subparsers: _Subparsers) -> None:
    from antmaze_hirl.experiments import benchmark_command as command  # light: the handler imports the envs

    command.add_benchmark_arguments(
        _add_parser(subparsers, "benchmark", command.HELP, command.EXAMPLE, command.DESCRIPTION)
    )


def _add_submit(subparsers: _Subparsers) -> None:
    from antmaze_hirl.experiments import submission  # light: no envs, no torch

    submission.add_submit_arguments(
        _add_parser(subparsers, "submit", submission.HELP, submission.EXAMPLE, submission.DESCRIPTION)
    )


SUBCOMMANDS: tuple[Callable[[_Subparsers], None], ...] = (
    _add_demo,
    _add_train_low,
    _add_eval_low,
    _add_ensemble_low,
    _add_experiment,
    _add_study,
    _add_benchmark,
    _add_submit,
)
"""The ``_add_*`` functions that each add one subcommand, in the order ``--help`` lists them."""


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``antmaze-hirl`` with all subcommands."""
    parser = argparse.ArgumentParser(
        prog="antmaze-hirl", description=DESCRIPTION, epilog=EPILOG, formatter_class=_HelpFormatter
    )
    parser.add_argument("--traceback", action="store_true", help="show the full traceback of an error")
    subparsers = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in SUBCOMMANDS:
        add(subparsers)
    return apply_bounds(parser)  # every numeric option bounded, usage errors on one line


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``antmaze-hirl`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command == "study":
        # The core install has no web or statistics stack: name the extra rather than fail deep in an import.
        missing = [name for name in STUDY_EXTRA_MODULES if importlib.util.find_spec(name) is None]
        if missing:
            parser.exit(
                2,
                f"antmaze-hirl study: error: needs {', '.join(missing)}: {STUDY_EXTRA_HINT}\n",
            )
    # After parsing, so that --help and a usage error never load SB3 (which the checkpoint module imports).
    from antmaze_hirl.sb3_ext.checkpoint import CheckpointError

    try:
        return args.handler(args)
    except (CheckpointError, FileExistsError, FileNotFoundError, ValueError, OSError) as error:
        # What bad input raises (a value, a file, a checkpoint): one line naming it, not a traceback.
        if args.traceback:
            raise
        parser.exit(2, f"antmaze-hirl {args.command}: error: {error} (--traceback shows where)\n")


if __name__ == "__main__":
    raise SystemExit(main())
