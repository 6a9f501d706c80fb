#!/usr/bin/env bash
# Behaviour-preservation check for refactors (issue "One run layer"): the same commands run by two
# builds must give identical CSVs and identical summaries apart from timing, date and commit fields.
#
#   tools/same-outputs.sh run BIN DIR        # run the four reference commands with BIN into DIR
#   tools/same-outputs.sh compare DIR1 DIR2  # exit 0 when every output agrees, else list differences
#
# The commands: the ci preset of shear (both codes, 2 seeds), convergence (ci, both codes, dt
# factors 1 and 0.5, the implicit dashpot), the reduced 2 x 2 sweep (both codes, 2 seeds) and the
# quick nightly. Run time on 2 cores: about 25 minutes.
set -euo pipefail

run() {
  local bin=$1 dir=$2
  mkdir -p "$dir"
  "$bin" shear --mu-r 0.5 --eta-r 0.5 --preset ci --seeds 2 --threads 1 --out "$dir/shear" \
    >"$dir/shear.log" 2>&1 || [ $? -eq 1 ]
  "$bin" convergence --mu-r 1 --eta-r 0.5 --preset ci --seeds 1 --strain 0.1 \
    --dt-factors 1,0.5 --engine both --liggghts-dt-factors 1 --with-implicit --threads 1 \
    --out "$dir/convergence" >"$dir/convergence.log" 2>&1 || [ $? -eq 1 ]
  "$bin" sweep --preset ci --mu-r 0,1 --eta-r 0,0.5 --seeds 2 --strain 0.5 --engine both \
    --jobs 1 --threads 1 --out "$dir/sweep" >"$dir/sweep.log" 2>&1 || [ $? -eq 1 ]
  "$bin" nightly --quick --out "$dir/nightly/night" --history "$dir/nightly/history.jsonl" \
    >"$dir/nightly.log" 2>&1 || [ $? -eq 1 ]
}

# Fields that legitimately differ between two runs of the same case: wall times and throughputs,
# dates, commits, the machine; and `schema`, the version field the run layer added to every
# summary (its only intended addition). Absolute paths of the two output directories are
# replaced by ROOT.
VOLATILE='^(schema|commit|machine)$|wall|per_s$|per_core|date|created|_utc$|seconds|elapsed'

normalise() {
  jq -S --arg v "$VOLATILE" --arg root "$2" '
    walk(if type == "object" then with_entries(select(.key | test($v) | not))
         elif type == "string" then sub($root; "ROOT") else . end)' "$1"
}

compare() {
  local a=$1 b=$2 bad=0 n=0
  while IFS= read -r rel; do
    n=$((n + 1))
    if [ ! -f "$b/$rel" ]; then echo "missing in $b: $rel"; bad=1; continue; fi
    case "$rel" in
      *.csv)
        cmp -s "$a/$rel" "$b/$rel" || { echo "differs: $rel"; bad=1; } ;;
      *.json)
        diff -q <(normalise "$a/$rel" "$a") <(normalise "$b/$rel" "$b") >/dev/null ||
          { echo "differs: $rel"; diff <(normalise "$a/$rel" "$a") <(normalise "$b/$rel" "$b") | head -20; bad=1; } ;;
    esac
  done < <(cd "$a" && find . -type f \( -name '*.csv' -o -name 'summary.json' -o -name 'results.json' \
             -o -name 'outcome.json' \) | sort)
  [ "$n" -gt 0 ] || { echo "nothing compared under $a"; exit 1; }
  echo "compared $n files: $([ $bad -eq 0 ] && echo identical || echo DIFFERENT)"
  exit $bad
}

case "${1:-}" in
  run) run "$2" "$3" ;;
  compare) compare "$2" "$3" ;;
  *) echo "usage: $0 run BIN DIR | compare DIR1 DIR2" >&2; exit 2 ;;
esac
