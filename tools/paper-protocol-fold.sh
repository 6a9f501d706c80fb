#!/usr/bin/env bash
# Folds the finished paper-protocol runs (issue #37, docs/paper-protocol.md) into
# reference/paper-protocol/<study>/: per sweep run its result.json with its record
# (result.json.sha256: the manifest entry's input hash and the file's SHA-256, written here
# because the installed binary (cd821d5) writes none; with it this version reads the stored
# results), summary.json and figures; per seed its case, velocity profiles, run records
# (<code>_run.json), rotation map and series (<code>.csv.gz: gzip -n, checked against the
# SHA-256 its run record holds before it is kept), its steady profiles from the grains'
# displacements between snapshots and its stages' rotation maps (`verify profile`, where
# snapshots are there); per
# convergence study each finished run's series and input hash (as each finishes: run the fold
# before the end-of-session carry when one has), and its summary and figures. Never
# checkpoints, restart files or ParaView snapshots. A run folded before is checked again (its
# series' SHA-256), not copied twice. Then every page under reference/ is
# made again by this clone's binary (tools/rerender-reference.sh: the paper protocol's pages
# with the implicit runs as stand-ins and the fast preset's speed study beside them).
#   bash tools/paper-protocol-fold.sh [DIR]     DIR default /work/paper-protocol
#   VERIFY=path/to/verify changes the binary that makes the pages (default: target/release,
#   built if missing)
set -euo pipefail
dir=${1:-/work/paper-protocol}
repo=$(cd "$(dirname "$0")/.." && pwd)
verify=${VERIFY:-$repo/target/release/verify}
[ -x "$verify" ] || (cd "$repo" && cargo build --release --quiet)
[ -d "$dir/runs" ] || { echo "error: no runs under $dir (run tools/paper-protocol.sh)" >&2; exit 2; }
sha_of() { python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["sha256"])' "$1"; }
# the record of a folded result.json: the input hash its manifest entry names, its SHA-256
record() {
  python3 - "$1" "$2" <<'EOF'
import hashlib, json, sys
manifest, result = sys.argv[1], sys.argv[2]
res = json.load(open(result))
# a result carries its manifest entry's fields (index, id, point, seed, input hash) flattened
entry = [r for r in json.load(open(manifest))["runs"] if r["id"] == res.get("id")]
if len(entry) != 1 or any(res.get(k) != v for k, v in entry[0].items()):
    sys.exit(f"error: {result} is not the result of its manifest's entry {res.get('id')}")
digest = hashlib.sha256(open(result, "rb").read()).hexdigest()
with open(result + ".sha256.tmp", "w") as f:
    f.write(f"{entry[0]['input_hash']} {digest}\n")
EOF
  mv "$2.sha256.tmp" "$2.sha256"
}
fold_seed() { # SEED-DIR DEST
  local seed=$1 dest=$2 code want got
  mkdir -p "$dest"
  for code in native liggghts; do
    [ -f "$seed/${code}_run.json" ] || continue
    want=$(sha_of "$seed/${code}_run.json")
    if [ -f "$dest/$code.csv.gz" ]; then
      got=$(gzip -dc "$dest/$code.csv.gz" | sha256sum | cut -d' ' -f1)
    else
      got=$(sha256sum "$seed/$code.csv" | cut -d' ' -f1)
      [ "$got" = "$want" ] && gzip -nc "$seed/$code.csv" > "$dest/$code.csv.gz.tmp" \
        && mv "$dest/$code.csv.gz.tmp" "$dest/$code.csv.gz"
    fi
    if [ "$got" != "$want" ]; then
      echo "error: $seed: $code series SHA-256 $got, its ${code}_run.json says $want: not folded" >&2
      exit 1
    fi
    cp "$seed/${code}_run.json" "$dest/"
    for f in "${code}_profile.csv" "${code}_profile.json"; do
      [ -f "$seed/$f" ] && cp "$seed/$f" "$dest/"
    done
  done
  # the steady profiles from the grains' displacements between snapshots (`verify profile`:
  # slip and band width resolved at the paper's speeds, where velocity samples are not)
  if [ -d "$seed/vtk" ] && [ -f "$seed/native.csv" ]; then
    "$verify" profile "$seed" > "$seed/profile.log" 2>&1 \
      || { cat "$seed/profile.log" >&2; exit 1; }
  fi
  for f in case.toml rotation_map.svg native_displacement_profile.csv \
    native_displacement_profile.json displacement_profile.svg; do
    [ -f "$seed/$f" ] && cp "$seed/$f" "$dest/"
  done
  # the stages' rotation maps `verify profile` drew from the snapshots (the rotation over
  # each stage's steady window)
  for f in "$seed"/rotation_map_stage*.svg; do
    [ -f "$f" ] && cp "$f" "$dest/"
  done
  return 0
}
for study in "$dir"/runs/paper-protocol-*; do
  name=${study##*/paper-protocol-}
  out="$repo/reference/paper-protocol/$name"
  if [ ! -f "$study/manifest.json" ]; then
    # a convergence study (`verify convergence`: dt<f>/seed<s>/<code>.csv, then <code>.hash,
    # the input hash that makes the run current, written when the run ends): each finished
    # run as it finishes, so that a replaced machine gets it back (tools/paper-protocol.sh)
    # instead of running it again (up to 13 million steps a run): its series gzipped with
    # its SHA-256 in <code>.sha256, and its .hash; one folded before is checked, not copied
    # twice. The summary and figures once the study has written them.
    runs=0
    for hash in "$study"/dt*/seed*/*.hash; do
      [ -f "$hash" ] || continue
      code=$(basename "$hash" .hash)
      src=$(dirname "$hash")
      dest="$out/${src#"$study/"}"
      got=$(sha256sum "$src/$code.csv" | cut -d' ' -f1)
      if [ -f "$dest/$code.sha256" ]; then
        read -r want < "$dest/$code.sha256"
        if [ "$got" != "$want" ]; then
          echo "error: $src/$code.csv differs from the series folded before ($dest): not folded" >&2
          exit 1
        fi
      else
        mkdir -p "$dest"
        gzip -nc "$src/$code.csv" > "$dest/$code.csv.gz.tmp"
        mv "$dest/$code.csv.gz.tmp" "$dest/$code.csv.gz"
        cp "$hash" "$dest/$code.hash"
        echo "$got" > "$dest/$code.sha256.tmp" && mv "$dest/$code.sha256.tmp" "$dest/$code.sha256"
      fi
      runs=$((runs + 1))
    done
    [ "$runs" -gt 0 ] && echo "$name: $runs finished convergence run(s) in $out"
    [ -f "$study/summary.json" ] || continue
    mkdir -p "$out"
    for f in summary.json report.html; do
      [ -f "$study/$f" ] && cp "$study/$f" "$out/"
    done
    cp "$dir/studies/paper-protocol-$name.toml" "$out/study.toml"
    cp "$study"/*.svg "$out"/ 2>/dev/null || true
    echo "$name: convergence summary folded"
    continue
  fi
  folded=0
  for run in "$study"/runs/*/; do
    run=${run%/}
    [ -f "$run/result.json" ] || continue
    id=${run##*/}
    dest="$out/runs/$id"
    mkdir -p "$dest"
    cp "$run"/result.json "$run"/summary.json "$dest"/
    record "$study/manifest.json" "$dest/result.json"
    cp "$run"/*.svg "$dest"/ 2>/dev/null || true
    for seed in "$run"/seed*/; do
      seed=${seed%/}
      fold_seed "$seed" "$dest/${seed##*/}"
    done
    folded=$((folded + 1))
    echo "$name: $id folded (series SHA-256 checked, result recorded)"
  done
  [ "$folded" -gt 0 ] || continue
  cp "$study"/manifest.json "$out"/
  cp "$dir/studies/paper-protocol-$name.toml" "$out/study.toml"
  echo "$name: $folded run(s) in $out"
done
# every page under reference/, the paper protocol's included, made by this clone's binary
bash "$repo/tools/rerender-reference.sh" "$repo/reference" "$verify"
