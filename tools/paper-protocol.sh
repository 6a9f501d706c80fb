#!/usr/bin/env bash
# Starts or resumes the paper-protocol studies (issue #37, docs/paper-protocol.md) in a folder
# outside the clone, from a binary installed from a recorded commit, so that later changes to
# the clone never touch a running study. Rerun it in every session: it installs what is
# missing (a replaced machine), leaves running studies alone, and resumes the others from
# their checkpoints (finished runs are reused).
#   bash tools/paper-protocol.sh [DIR]          DIR default /work/paper-protocol
#   COMMIT=<sha> changes the recorded commit (a new binary: say so on the issue)
set -euo pipefail
commit=${COMMIT:-cd821d51e8b0adb2a52b6f72dcced8182d4e9a99}
dir=${1:-/work/paper-protocol}
repo=$(cd "$(dirname "$0")/.." && pwd)
short=${commit:0:7}
bin="$dir/bin-$short/bin/verify"
mkdir -p "$dir/studies"
cd "$dir"
if [ ! -x "$bin" ]; then
  [ -d src ] || git clone -q "$repo" src
  git -C src fetch -q "$repo" 2>/dev/null || true
  git -C src checkout -q "$commit"
  CARGO_TARGET_DIR="$dir/target" cargo install --locked --path src --root "bin-$short" > install.log 2>&1
  printf 'binary: %s\ncommit: %s\nbuilt: %s on %s (%s)\n' "$bin" "$commit" "$(date -u +%FT%TZ)" \
    "$(hostname)" "$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)" >> PROVENANCE
fi
# Two slots, one core each; each runs its queue of studies in order. A finished study is passed
# over in seconds (its results are reused), so rerunning the queue resumes where it stopped:
# epsd: the five seed-1 points, then their seed 2 (the eta_r = 0.5 points first, the manifest's
# order); implicit: its two seed-1 points, their seed 2, then the 1 mm/s convergence checks at
# (1, 0.5) and (0.5, 0.5), then LIGGGHTS on the paper's protocol at (1, 0.5) (resumed from its
# restart files). A study that fails stops its queue (said in runs.log).
queue_epsd=("paper-protocol-epsd.toml" "paper-protocol-epsd.toml --seeds 2")
queue_implicit=("paper-protocol-implicit.toml" "paper-protocol-implicit.toml --seeds 2"
  "paper-protocol-convergence-mur1.toml" "paper-protocol-convergence-mur0.5.toml"
  "paper-protocol-liggghts.toml")
if [ "${QUEUE:-}" ]; then
  # the queue itself, started below in a session of its own (pause it and the runs it started
  # with `kill -STOP -- -$(cat pid-NAME)`, resume with -CONT)
  declare -n queue="queue_$QUEUE"
  for study in "${queue[@]}"; do
    echo "$(date -u +%FT%TZ) $QUEUE: verify run studies/$study ($bin)" >> runs.log
    # shellcheck disable=SC2086 # a study and its extra flags, split on purpose
    if ! "$bin" run studies/$study; then
      echo "$(date -u +%FT%TZ) $QUEUE: studies/$study failed: queue stopped" >> runs.log
      exit 1
    fi
  done
  echo "$(date -u +%FT%TZ) $QUEUE: queue done" >> runs.log
  exit 0
fi
cp -n "$repo"/studies/paper-protocol-*.toml studies/
# alive: the queue (or a run it started) exists and is not a zombie (an exited queue nobody
# reaped yet); a pid of a session gone may belong to another process by now: its command
# must be the queue's or a study's
alive() {
  ps -o stat=,args= -p "$1" 2>/dev/null | grep -v '^Z' | grep -q 'queue\.sh\|verify run studies/'
}
for s in epsd implicit; do
  if [ -f "pid-$s" ] && alive "$(cat "pid-$s")"; then
    echo "$s: running (pid $(cat "pid-$s"))"
    continue
  fi
  echo "$(date -u +%FT%TZ) start queue $s ($bin)" >> runs.log
  # the queue runs a copy of this script (a new file each time, so a queue still running keeps
  # reading the one it started with)
  cp "$repo/tools/paper-protocol.sh" queue.sh.tmp && mv queue.sh.tmp queue.sh
  QUEUE=$s setsid nohup bash queue.sh "$dir" >> "log-$s.txt" 2>&1 &
  echo $! > "pid-$s"
  echo "$s: queue started (pid $!, its own process group), log $dir/log-$s.txt"
done
