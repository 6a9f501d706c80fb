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
# carried (159 MB per run). A LIGGGHTS run part way is carried too (below): its logs, profile
# dumps and restart files, which it continues from.
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
# carried runs finished since (the run record beside the seed's checkpoint or liggghts/
# folder: native_run.json, liggghts_run.json; a native checkpoint's folder here without it):
# their copies go
while IFS= read -r -d '' gz; do
  case $gz in
    *.bin.gz) base=${gz%.gz} code=native ;;
    *) base=${gz%.tar.gz} code=liggghts ;;
  esac
  rel=${base#"$out/"}
  here=$dir/runs/$rel
  # finished: its run record (a sweep's run), or, for a native checkpoint, its folder here
  # without it once tools/paper-protocol.sh has put back everything the clone carried here
  # (`restored`): a finished run removes its checkpoint, a run part way always has one; a
  # convergence study's runs write no run record
  if [ -f "$(dirname "$here")/${code}_run.json" ] \
    || { [ "$code" = native ] && [ -f "$dir/restored" ] && [ -d "$(dirname "$here")" ] \
      && [ ! -f "$here" ]; }; then
    rm "$gz" "$base.sha256"
    echo "finished since: $rel no longer carried"
  fi
done < <(find "$out" \( -name '*.bin.gz' -o -name liggghts.tar.gz \) -print0 2>/dev/null)
[ -d "$out" ] && find "$out" -mindepth 1 -type d -empty -delete
carried=0
while IFS= read -r -d '' cp; do
  # a finished run removes its checkpoint; one left beside its run record is not carried
  [ -f "$(dirname "$cp")/native_run.json" ] && continue
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
# LIGGGHTS runs part way (a liggghts/ folder with resume.json and no liggghts_run.json beside
# it): what `verify` continues such a run from (src/shear.rs `run_liggghts`): resume.json, the
# logs of every part (their thermo rows make the series), the profile dumps written so far
# (read at the end) and the restart files, in one tar (gzip -n) at
# carried/paper-protocol/<path under runs/ of liggghts/>.tar.gz with <path>.sha256 ("SHA-256
# of the tar, the newest restart step"). The logs are copied before the restart files: a
# restart file is complete once a thermo line of its step is in the log (the deck writes the
# restart file, then thermo), so the copied log names only restart files complete before it
# was copied, and `verify` continues from the newest of those (the copy of a newer one that
# was being written is passed over). Snapshots are not carried (ParaView; 100+ MB).
lig=0
while IFS= read -r -d '' state; do
  src=$(dirname "$state")
  [ -f "$(dirname "$src")/liggghts_run.json" ] && continue
  rel=${src#"$dir/runs/"}
  dest="$out/$rel"
  stage=$(mktemp -d)
  chmod 755 "$stage"
  cp "$state" "$stage/"
  for f in "$src"/log*.liggghts "$src"/prof_*.dump; do
    [ -f "$f" ] && cp "$f" "$stage/"
  done
  steps=()
  for f in "$src"/restart.*; do
    [ -f "$f" ] || continue
    # pruned by the run since it was listed: passed over
    cp "$f" "$stage/" 2>/dev/null && steps+=("${f##*/restart.}")
  done
  if [ "${#steps[@]}" -eq 0 ]; then
    echo "not carried: $rel has no restart file yet (a carried copy, if any, stays)"
    rm -rf "$stage"
    continue
  fi
  mkdir -p "$(dirname "$dest")"
  tar -C "$stage" -cf "$dest.tar.tmp" .
  rm -rf "$stage"
  sum=$(sha256sum "$dest.tar.tmp" | cut -d' ' -f1)
  newest=$(printf '%s\n' "${steps[@]}" | sort -n | tail -1)
  gzip -nc "$dest.tar.tmp" > "$dest.tar.gz.tmp"
  rm "$dest.tar.tmp"
  mv "$dest.tar.gz.tmp" "$dest.tar.gz"
  echo "$sum $newest" > "$dest.sha256.tmp" && mv "$dest.sha256.tmp" "$dest.sha256"
  echo "carried LIGGGHTS $rel, restart files at ${steps[*]} ($(du -h "$dest.tar.gz" | cut -f1))"
  lig=$((lig + 1))
done < <(find "$dir/runs" -path '*/liggghts/resume.json' -print0)
echo "$carried checkpoint(s) and $lig LIGGGHTS run(s) carried in $out"
