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
cp -n "$repo"/studies/paper-protocol-*.toml studies/
# Both at normal priority since epsd's (1, 0.5) finished (2026-12-05): epsd_implicit's (1, 0.5)
# is the other half of the decisive pair (until then it ran at nice 19 on what was left)
for s in epsd implicit; do
  if [ -f "pid-$s" ] && kill -0 "$(cat "pid-$s")" 2>/dev/null; then
    echo "$s: running (pid $(cat "pid-$s"))"
    continue
  fi
  n=0
  echo "$(date -u +%FT%TZ) start $s (nice $n, $bin)" >> runs.log
  nohup nice -n "$n" "$bin" run "studies/paper-protocol-$s.toml" >> "log-$s.txt" 2>&1 &
  echo $! > "pid-$s"
  echo "$s: started (pid $!), log $dir/log-$s.txt"
done
