#!/usr/bin/env bash
# The 10-seed protocol-2 rerun (docs/guides/protocol.md), run in the background across sessions from a frozen clone.
#
#   [PROTOCOL2_JOBS=2] scripts/protocol2_rerun.sh start BODY   # restore the committed checkpoint if need be, then resume
#   scripts/protocol2_rerun.sh checkpoint BODY   # pack the finished trials into the committed checkpoint
#   scripts/protocol2_rerun.sh restore BODY      # unpack the checkpoint where no trials are (start does this)
#   scripts/protocol2_rerun.sh status            # trials done per body
#
# Why a frozen clone: a results folder only resumes under the code that began it (run_experiment compares
# provenance.json), so the trials run from a checkout of COMMIT while main moves on. Why a checkpoint in git:
# a session's machine can be a fresh one, and a trial (5-15 min) is the unit of resumption; the packed
# trials (config.json, provenance.json, trials/*.csv and .json) are ~10 KB per trial compressed.
# Run from the main checkout's root, with its .venv set up (.ci/setup).
set -euo pipefail
COMMIT=36dafd8a03dc0a9cd5a6de794f67b44a7536914e
METHODS=dagger,noise,multi_policy,reward,reward_per_step,aggrevate,gated
SEEDS=10
# Trials at once: the backend changes no number (each trial is seeded by its own rng), only the wall time.
JOBS="${PROTOCOL2_JOBS:-1}"
MAIN="$(cd "$(dirname "$0")/.." && pwd)"
WORK="${PROTOCOL2_WORK:-/work/p2runs}"
CLONE="${PROTOCOL2_CLONE:-/work/frozen-p2}"
CHECKPOINTS="${PROTOCOL2_CHECKPOINTS:-$MAIN/results/protocol2/runs}"

folder() { echo "$WORK/${1}_p2_${COMMIT:0:7}"; }

check_body() {
  case "${1:-}" in
    point | ant) ;;
    *) echo "BODY must be point or ant, got '${1:-}'" >&2; exit 2 ;;
  esac
}

restore() {
  local out
  out="$(folder "$1")"
  mkdir -p "$WORK"
  if [ ! -d "$out/trials" ] && [ -f "$CHECKPOINTS/$1.tar.gz" ]; then
    mkdir -p "$out"
    tar -xzf "$CHECKPOINTS/$1.tar.gz" -C "$out"
    echo "restored $(ls "$out/trials" | grep -c '\.json$') trials of $1 from $CHECKPOINTS/$1.tar.gz"
  fi
}

case "${1:-}" in
  restore)
    check_body "${2:-}"
    restore "$2"
    ;;
  start)
    check_body "${2:-}"
    body=$2
    case "$JOBS" in
      1) backend="--backend serial" ;;
      [2-9] | [1-9][0-9]) backend="--backend processes --jobs $JOBS" ;;
      *) echo "PROTOCOL2_JOBS must be an integer from 1 to 99, got '$JOBS'" >&2; exit 2 ;;
    esac
    out="$(folder "$body")"
    # One writer per folder: a second start (another session, say) would run the same trials beside it.
    if [ -f "$WORK/$body.pid" ] && kill -0 "$(cat "$WORK/$body.pid")" 2>/dev/null; then
      echo "the $body rerun is already running (pid $(cat "$WORK/$body.pid")): not starting another" >&2
      exit 1
    fi
    mkdir -p "$WORK"
    # Both bodies start from one clone: the lock keeps two starts at once from racing on its index.lock.
    (
      flock 9
      if [ ! -d "$CLONE/.git" ]; then
        git clone -q "$MAIN" "$CLONE"
      fi
      if [ "$(git -C "$CLONE" rev-parse HEAD)" != "$COMMIT" ]; then
        git -C "$CLONE" checkout -q "$COMMIT"
      fi
    ) 9> "$WORK/.clone.lock"
    restore "$body"
    # PYTHONPATH first: the venv's editable install points at main, the trials must run the clone's code.
    # setsid and no inherited stdin: the caller (a shell tool, a CI step) must not wait on the trials.
    # The pid file must hold the experiment's own pid, not setsid's (which can fork and exit at once, and
    # then the "already running" check above sees nothing): the inner shell writes its pid, then execs.
    # The redirections are on the whole subshell: the shell forked for "cd && ... &" would otherwise keep
    # the caller's stdout open, and a caller reading that pipe would wait on the trials.
    rm -f "$WORK/$body.pid"
    # shellcheck disable=SC2016  # $$, $0 and $@ are the inner shell's
    (cd "$CLONE" && PYTHONPATH="$CLONE" setsid nohup bash -c 'echo $$ > "$0.tmp" && mv "$0.tmp" "$0" && exec "$@"' \
      "$WORK/$body.pid" "$MAIN/.venv/bin/python" benchmarks/paper_experiment.py \
      --body "$body" --seeds "$SEEDS" --methods "$METHODS" --out "$out" $backend --cpus-per-trial 1 &) \
      < /dev/null >> "$WORK/$body.log" 2>&1
    for _ in $(seq 50); do [ -f "$WORK/$body.pid" ] && break; sleep 0.1; done
    echo "started $body (pid $(cat "$WORK/$body.pid" 2>/dev/null || echo unknown)): log $WORK/$body.log, folder $out"
    ;;
  checkpoint)
    check_body "${2:-}"
    body=$2
    out="$(folder "$body")"
    [ -d "$out/trials" ] || { echo "no trials in $out" >&2; exit 1; }
    mkdir -p "$CHECKPOINTS"
    # Trials are written atomically, so a running experiment leaves no torn file to pack.
    tar -czf "$CHECKPOINTS/$body.tar.gz.tmp" -C "$out" config.json provenance.json trials
    mv "$CHECKPOINTS/$body.tar.gz.tmp" "$CHECKPOINTS/$body.tar.gz"
    echo "packed $(ls "$out/trials" | grep -c '\.json$') trials of $body into $CHECKPOINTS/$body.tar.gz"
    ;;
  status)
    for body in point ant; do
      out="$(folder "$body")"
      done_trials=$( (ls "$out/trials" 2>/dev/null || true) | grep -c '\.json$' || true)
      echo "$body: $done_trials of $((SEEDS * 7)) trials in $out"
    done
    ;;
  *)
    echo "usage: scripts/protocol2_rerun.sh start|checkpoint|restore BODY | status, got '${1:-}'" >&2
    exit 2
    ;;
esac
