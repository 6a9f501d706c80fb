#!/usr/bin/env bash
# Carries the paper-protocol runs still part way (issue #37, docs/paper-protocol.md) across a
# replaced machine: the checkpoint of each (the whole solver state and the rows so far, written
# by the run every 300 s) goes into carried/paper-protocol/<its path under runs/>.gz (gzip -n) with <path>.sha256 ("SHA-256-of-the-checkpoint step"); committed, it is
# what tools/paper-protocol.sh puts back (checked) on a new machine, so a run resumes from the
# carried step instead of step 0 (runs take 7-18 h, sessions 3; two machine replacements
# restarted four runs from step 0 before this existed). Carried checkpoints of runs that have
# finished since (their run record) are removed. Run it at the end of a session and commit
# carried/ (outside reference/: results there, never checkpoints; each commit adds 1-5 MB per
# run to the history, against 7-18 h of a core lost per run). ParaView snapshots are not
# carried (159 MB per run).
#   bash tools/paper-protocol-carry.sh [DIR]    DIR default /work/paper-protocol
set -euo pipefail
dir=${1:-/work/paper-protocol}
repo=$(cd "$(dirname "$0")/.." && pwd)
out="$repo/carried/paper-protocol"
[ -d "$dir/runs" ] || { echo "error: no runs under $dir (run tools/paper-protocol.sh)" >&2; exit 2; }
# the step a checkpoint holds: its last row's (MessagePack: version, case, stage, wall time,
# solver state, rows, ...; a row's first field is its step)
# (a Python with msgpack: Debian's python3-msgpack for /usr/bin/python3, or pip's)
py=
for p in python3 /usr/bin/python3; do
  if "$p" -c 'import msgpack' 2>/dev/null; then py=$p; break; fi
done
[ "$py" ] || { echo "error: no python3 with msgpack (apt-get install python3-msgpack)" >&2; exit 2; }
step_of() {
  "$py" - "$1" <<'EOF'
import sys, msgpack
u = msgpack.Unpacker(strict_map_key=False, raw=False)
u.feed(open(sys.argv[1], "rb").read())
print(next(u)[5][-1][0])
EOF
}
# carried runs finished since, or no longer part way here with nothing newer: their copies go
while IFS= read -r -d '' gz; do
  rel=${gz#"$out/"}
  here="$dir/runs/${rel%.gz}"
  if [ -f "$(dirname "$here")/native_run.json" ]; then
    rm "$gz" "${gz%.gz}.sha256"
    echo "finished since: ${rel%.gz} no longer carried"
  fi
done < <(find "$out" -name '*.bin.gz' -print0 2>/dev/null)
[ -d "$out" ] && find "$out" -mindepth 1 -type d -empty -delete
carried=0
while IFS= read -r -d '' cp; do
  rel=${cp#"$dir/runs/"}
  dest="$out/$rel"
  mkdir -p "$(dirname "$dest")"
  # a copy first: the run replaces its checkpoint (by renaming) every 300 s
  if ! cp "$cp" "$dest.tmp" 2>/dev/null; then
    echo "finished while carried: $rel (its checkpoint is gone)"
    continue
  fi
  sum=$(sha256sum "$dest.tmp" | cut -d' ' -f1)
  step=$(step_of "$dest.tmp")
  gzip -nc "$dest.tmp" > "$dest.gz.tmp"
  rm "$dest.tmp"
  mv "$dest.gz.tmp" "$dest.gz"
  echo "$sum $step" > "$dest.sha256.tmp" && mv "$dest.sha256.tmp" "$dest.sha256"
  echo "carried $rel at step $step ($(du -h "$dest.gz" | cut -f1))"
  carried=$((carried + 1))
done < <(find "$dir/runs" -name native_checkpoint.bin -print0)
echo "$carried checkpoint(s) carried in $out"
