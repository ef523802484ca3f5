"""``antmaze-hirl study``: plan a user study, serve its page, rehearse it with simulated participants, analyse it."""

from __future__ import annotations

import argparse
from pathlib import Path

from antmaze_hirl.study.settings import QUESTIONNAIRE_SECONDS, SECONDS_PER_MAZE_PRIOR, StudySettings

_DEFAULT_METHODS = "dagger,noise,multi_policy,reward"
_STUDY_DEFAULTS = StudySettings()

DEFAULT_PRACTICE = 10
"""Practice mazes by default: about 4 min at :data:`~antmaze_hirl.study.settings.SECONDS_PER_MAZE_PRIOR`."""

DEFAULT_EPISODES = 25
"""Mazes per compared method by default: with the practice, 4 methods and their questionnaires, about 47 min at
:data:`~antmaze_hirl.study.settings.SECONDS_PER_MAZE_PRIOR` (10 + 4 x 25 = 110 mazes x 22.4 s + 4 x 90 s)."""


def add_study_parser(subparsers: argparse._SubParsersAction, formatter_class: type = argparse.HelpFormatter) -> None:
    """Adds ``study`` with its subcommands ``init``, ``serve``, ``simulate``, ``analyze`` and ``export``."""
    parser = subparsers.add_parser(
        "study",
        help="run the paper's user study: people click subgoals on a web page",
        description="Plan a user study, serve the page participants use, rehearse it with simulated "
        "participants, analyse the answers, export the demonstrations.",
        formatter_class=formatter_class,
        epilog="example:\n  antmaze-hirl study init runs/study --body point --participants 4\n"
        "  antmaze-hirl study serve runs/study\n  antmaze-hirl study analyze runs/study",
    )
    commands = parser.add_subparsers(
        dest="study_command", required=True, metavar="COMMAND", help="study step (required)"
    )
    _add_init(commands, formatter_class)
    _add_serve(commands, formatter_class)
    _add_simulate(commands, formatter_class)
    _add_analyze(commands, formatter_class)
    _add_export(commands, formatter_class)


def _command(
    commands: argparse._SubParsersAction,
    formatter_class: type,
    name: str,
    *,
    help: str,  # argparse's own keyword
    description: str,
    example: str,
) -> argparse.ArgumentParser:
    """One ``study`` subcommand's parser, with its example in the epilog (as every command has)."""
    return commands.add_parser(
        name, help=help, description=description, formatter_class=formatter_class, epilog=f"example:\n  {example}"
    )


def _add_init(commands: argparse._SubParsersAction, formatter_class: type) -> None:
    parser = _command(
        commands,
        formatter_class,
        "init",
        help="write the study plan: counterbalanced method orders, anonymous participants",
        description="Writes DIR/plan.json (each participant's method order from a balanced Latin square, "
        "a practice trial first, neutral method labels) and DIR/settings.json (maze family and trial settings).",
        example="antmaze-hirl study init runs/study --body point --methods dagger,noise --participants 4 "
        "--episodes 30 --practice 5",
    )
    parser.add_argument("dir", type=Path, help="study folder to create")
    parser.add_argument("--body", choices=("point", "ant"), required=True, help="robot the participants guide")
    parser.add_argument("--methods", default=_DEFAULT_METHODS, help="comma-separated methods to compare")
    parser.add_argument("--participants", type=int, required=True, help="number of participants")
    parser.add_argument(
        "--episodes",
        type=int,
        default=DEFAULT_EPISODES,
        help="mazes per compared trial (default: sized so that practice and 4 methods fit one sitting of about "
        "an hour; see docs/guides/user-study.md)",
    )
    parser.add_argument("--practice", type=int, default=DEFAULT_PRACTICE, help="mazes of the practice trial (0: none)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the orders, labels and mazes")
    parser.add_argument("--maze-size", type=int, default=None, help="free cells per maze side (default: per body)")
    parser.add_argument(
        "--subgoal-reach-m",
        type=float,
        default=None,
        help="radius of the click circle, metres: the setting subgoal_reach_m "
        "(default: per body, ant 2, point one cell)",
    )
    parser.add_argument("--eval-every", type=int, default=_STUDY_DEFAULTS.eval_every, help="evaluate every M episodes")
    parser.add_argument("--eval-episodes", type=int, default=_STUDY_DEFAULTS.eval_episodes, help="mazes per evaluation")
    parser.add_argument(
        "--final-eval-episodes", type=int, default=_STUDY_DEFAULTS.final_eval_episodes, help="mazes after each trial"
    )
    parser.add_argument("--hide-learner", action="store_true", help="do not draw the learner's proposed subgoal")
    parser.add_argument(
        "--update-before-next-maze",
        action="store_true",
        help="run each learner update before the next maze, as the experiments do (participants wait for it); "
        "default: in the background, the learner lagging one maze",
    )
    parser.set_defaults(handler=_run_init)


def _run_init(args: argparse.Namespace) -> int:
    from antmaze_hirl.study.plan import make_plan, save_plan
    from antmaze_hirl.study.settings import save_settings

    started = [path.parent.name for path in sorted(Path(args.dir).glob("participants/*/*")) if path.is_file()]
    if started:
        raise FileExistsError(
            f"{args.dir} already holds participant data ({len(set(started))} participant(s), e.g. "
            f"{sorted(set(started))[0]}): its plan and settings are not rewritten; use a new folder"
        )
    methods = [method.strip() for method in args.methods.split(",")]
    plan = make_plan(
        args.body, methods, args.participants, episodes=args.episodes, practice=args.practice, seed=args.seed
    )
    overrides = {
        "eval_every": args.eval_every,
        "eval_episodes": args.eval_episodes,
        "final_eval_episodes": args.final_eval_episodes,
        "show_learner_subgoal": not args.hide_learner,
        "background_updates": not args.update_before_next_maze,
    }
    if args.maze_size is not None:
        overrides["maze_size"] = args.maze_size
    if args.subgoal_reach_m is not None:
        overrides["subgoal_reach_m"] = args.subgoal_reach_m
    settings = StudySettings.for_body(args.body, **overrides)
    save_plan(plan, args.dir)
    save_settings(settings, args.dir)
    orders = ", ".join(f"{p.id}: {' > '.join(plan.label_of(m) for m in p.order)}" for p in plan.participants)
    print(f"wrote {args.dir / 'plan.json'} and {args.dir / 'settings.json'}; orders {orders}")
    mazes = args.practice + args.episodes * len(methods)
    minutes = (mazes * SECONDS_PER_MAZE_PRIOR + len(methods) * QUESTIONNAIRE_SECONDS) / 60
    print(
        f"each participant: {mazes} mazes and {len(methods)} questionnaires, about {minutes:.0f} min at "
        f"{SECONDS_PER_MAZE_PRIOR:g} s per maze (measured clicks, walks and server times with an assumed 3 s to think "
        "of a click: no person was timed, so time a pilot)"
    )
    print(f"next: antmaze-hirl study serve {args.dir}")
    return 0


def _add_serve(commands: argparse._SubParsersAction, formatter_class: type) -> None:
    parser = _command(
        commands,
        formatter_class,
        "serve",
        help="serve the study page (loopback only by default; prints the URL with its token)",
        description="Serves the study page and its API on uvicorn until Ctrl-C. Everything a participant "
        "does is saved as it happens; a restarted server resumes each participant where they were.",
        example="MUJOCO_GL=egl antmaze-hirl study serve runs/study --port 8765",
    )
    parser.add_argument("dir", type=Path, help="study folder made by 'study init'")
    parser.add_argument("--host", default="127.0.0.1", help="interface to listen on; others than loopback warn")
    parser.add_argument("--port", type=int, default=8765, help="TCP port")
    parser.add_argument(
        "--token",
        default=None,
        help="access token, at least 16 characters (default: $ANTMAZE_HIRL_STUDY_TOKEN, else a random one, "
        "printed in the URL); prefer the environment variable: a --token value is visible in ps",
    )
    parser.add_argument(
        "--allow-host", action="append", default=[], help="extra Host header name to accept (repeatable)"
    )
    parser.set_defaults(handler=_run_serve)


def _run_serve(args: argparse.Namespace) -> int:
    from antmaze_hirl.study.server import serve

    serve(args.dir, host=args.host, port=args.port, token=args.token, extra_hosts=args.allow_host)
    return 0


def _add_simulate(commands: argparse._SubParsersAction, formatter_class: type) -> None:
    parser = _command(
        commands,
        formatter_class,
        "simulate",
        help="rehearse the study: the oracle plays participants through the page's HTTP API",
        description="Plays participants with the scripted oracle (plus click noise and reaction delays) "
        "through the same HTTP API the page uses, and answers the questionnaires from a seeded model.",
        example="antmaze-hirl study simulate runs/study --participants 3 --noise 0.1 --delay 0.5",
    )
    parser.add_argument("dir", type=Path, help="study folder made by 'study init'")
    parser.add_argument("--participants", type=int, default=None, help="play the first N participants (default: all)")
    parser.add_argument("--noise", type=float, default=0.0, help="std of the click noise, metres")
    parser.add_argument("--delay", type=float, default=0.0, help="mean reaction delay per click, seconds")
    parser.add_argument("--seed", type=int, default=0, help="seed of the noise, delays and answers")
    parser.add_argument(
        "--url", default=None, help="a running server's URL with its token (default: start one on a free loopback port)"
    )
    parser.set_defaults(handler=_run_simulate)


def _run_simulate(args: argparse.Namespace) -> int:
    from antmaze_hirl.study.plan import load_plan
    from antmaze_hirl.study.server import StudyServer
    from antmaze_hirl.study.simulate import SimulatedParticipant, simulate_study

    behaviour = SimulatedParticipant(noise=args.noise, delay=args.delay, seed=args.seed)
    ids = [participant.id for participant in load_plan(args.dir).participants]
    if args.participants is not None:
        if not 1 <= args.participants <= len(ids):
            raise ValueError(
                f"--participants must lie in 1..{len(ids)} (the plan's participants), got {args.participants}"
            )
        ids = ids[: args.participants]
    if args.url is not None:
        results = simulate_study(args.url, ids, behaviour, log=lambda line: print(line, flush=True))
    else:
        with StudyServer(args.dir).running() as server:
            results = simulate_study(server.url, ids, behaviour, log=lambda line: print(line, flush=True))
    for result in results:
        print(f"{result['participant']}: {result['trials']} rated trials, {result['clicks']} clicks")
    print(f"next: antmaze-hirl study analyze {args.dir}")
    return 0


def _add_analyze(commands: argparse._SubParsersAction, formatter_class: type) -> None:
    parser = _command(
        commands,
        formatter_class,
        "analyze",
        help="write DIR/report/: panels, questionnaire charts, ANOVAs and report.md",
        description="Analyses what the participants did and answered (practice trials left out): the "
        "experiment's panels across participants, NASA-TLX charts, one-way and repeated-measures ANOVAs "
        "with Holm-corrected paired post-hoc tests, seconds per label.",
        example="antmaze-hirl study analyze runs/study",
    )
    parser.add_argument("dir", type=Path, help="study folder")
    parser.set_defaults(handler=_run_analyze)


def _run_analyze(args: argparse.Namespace) -> int:
    from antmaze_hirl.study.analysis import analyze

    report = analyze(args.dir)
    print(f"wrote {report}")
    return 0


def _add_export(commands: argparse._SubParsersAction, formatter_class: type) -> None:
    parser = _command(
        commands,
        formatter_class,
        "export",
        help="write the collected demonstrations as a Minari dataset (needs the minari extra)",
        description="Writes every labelled high-level step (observations, executed subgoals, the expert's "
        "labels in the step infos, episode boundaries) as a Minari dataset, loadable with minari.load_dataset.",
        example="antmaze-hirl study export runs/study --minari antmaze_hirl/study-point-v0",
    )
    parser.add_argument("dir", type=Path, help="study folder")
    parser.add_argument("--minari", required=True, metavar="NAME", help="dataset id, namespace/name-v0")
    parser.add_argument("--include-practice", action="store_true", help="also export the practice trials")
    for option, what in (("--author", "author"), ("--author-email", "author's contact"), ("--code-permalink", "")):
        text = what or "link to the versioned code that collected it"
        parser.add_argument(option, default=None, help=f"the dataset's {text}, in its metadata (default: none)")
    parser.set_defaults(handler=_run_export)


def _run_export(args: argparse.Namespace) -> int:
    from antmaze_hirl.study.export import export_minari

    provenance = {"author": args.author, "author_email": args.author_email, "code_permalink": args.code_permalink}
    path = export_minari(args.dir, args.minari, include_practice=args.include_practice, **provenance)
    print(f"wrote Minari dataset {args.minari} at {path}")
    return 0
