#!/usr/bin/env bash
# Folds the finished paper-protocol runs (issue #37, docs/paper-protocol.md) into
# reference/paper-protocol/<study>/: per run its result.json, summary.json and figures; per
# seed its case, velocity profiles, run record (native_run.json), rotation map and series
# (native.csv.gz: gzip -n, checked against the SHA-256 its native_run.json records before it is
# kept); and the study's report made again by the installed binary (`verify sweep report`,
# partial until every run is done). Never checkpoints or ParaView snapshots. A run folded
# before is checked again (its series' SHA-256), not copied twice.
#   bash tools/paper-protocol-fold.sh [DIR]     DIR default /work/paper-protocol
set -euo pipefail
dir=${1:-/work/paper-protocol}
repo=$(cd "$(dirname "$0")/.." && pwd)
bin=$(ls -d "$dir"/bin-*/bin/verify 2>/dev/null | head -1)
[ -x "$bin" ] || { echo "error: no installed binary under $dir (run tools/paper-protocol.sh)" >&2; exit 2; }
sha_of() { python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["sha256"])' "$1"; }
for study in "$dir"/runs/paper-protocol-*; do
  name=${study##*/paper-protocol-}
  out="$repo/reference/paper-protocol/$name"
  folded=0
  for run in "$study"/runs/*/; do
    run=${run%/}
    [ -f "$run/result.json" ] || continue
    id=${run##*/}
    dest="$out/runs/$id"
    mkdir -p "$dest"
    cp "$run"/result.json "$run"/summary.json "$dest"/
    cp "$run"/*.svg "$dest"/ 2>/dev/null || true
    for seed in "$run"/seed*/; do
      seed=${seed%/}
      s=${seed##*/}
      mkdir -p "$dest/$s"
      want=$(sha_of "$seed/native_run.json")
      if [ -f "$dest/$s/native.csv.gz" ]; then
        got=$(gzip -dc "$dest/$s/native.csv.gz" | sha256sum | cut -d' ' -f1)
      else
        got=$(sha256sum "$seed/native.csv" | cut -d' ' -f1)
        [ "$got" = "$want" ] && gzip -nc "$seed/native.csv" > "$dest/$s/native.csv.gz.tmp" \
          && mv "$dest/$s/native.csv.gz.tmp" "$dest/$s/native.csv.gz"
      fi
      if [ "$got" != "$want" ]; then
        echo "error: $seed: series SHA-256 $got, its native_run.json says $want: not folded" >&2
        exit 1
      fi
      for f in case.toml native_profile.csv native_profile.json native_run.json rotation_map.svg; do
        [ -f "$seed/$f" ] && cp "$seed/$f" "$dest/$s/"
      done
    done
    folded=$((folded + 1))
    echo "$name: $id folded (series SHA-256 checked)"
  done
  [ "$folded" -gt 0 ] || continue
  # the study's report, made by the installed binary in the run folder, copied with its inputs
  "$bin" sweep report "$study" > "$study/report.log" 2>&1 || true
  cp "$study"/manifest.json "$out"/
  for f in report.html report.json; do [ -f "$study/$f" ] && cp "$study/$f" "$out/"; done
  [ -d "$study/figures" ] && mkdir -p "$out/figures" && cp "$study"/figures/*.svg "$out/figures/"
  cp "$dir/studies/paper-protocol-$name.toml" "$out/study.toml"
  echo "$name: $folded run(s) in $out (report: $study/report.log)"
done
