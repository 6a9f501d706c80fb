#!/usr/bin/env bash
# Makes every page stored under reference/ again with this version (issue #36): a stored night
# is judged again by today's rules from its summary.json's per-seed figures
# (`verify nightly --rerender`), a stored sweep's report is made from its runs' results
# (`verify sweep report`, with the stand-ins its README names as --converged). The pages then
# say what the current code concludes from the stored evidence; the evidence (summary.json,
# runs/*/result.json) is not changed. tests/reference_reports.rs runs this on a copy and fails
# when a page cannot be made or a page under reference/ is missing from the list below.
# Usage: bash tools/rerender-reference.sh [ROOT] [VERIFY]   (ROOT default: reference/)
# Prints one line "page: ROOT/..." per page made.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
root=${1:-$here/reference}
verify=${2:-$here/target/release/verify}

# a night's verdict (1 disagree, 3 inconclusive) is an outcome here, not a failure
night() {
  "$verify" nightly --rerender --out "$root/$1" > "$root/$1/rerender.log" 2>&1 || [ $? -ne 2 ] \
    || { cat "$root/$1/rerender.log" >&2; exit 2; }
  rm -f "$root/$1/rerender.log"
  echo "page: $root/$1/report.html"
}

sweep() {
  local dir=$1; shift
  local conv=()
  for c in "$@"; do conv+=(--converged "$root/$c"); done
  "$verify" sweep report "$root/$dir" "${conv[@]}" > /dev/null
  echo "page: $root/$dir/report.html"
}

night nightly/20261202-e1
sweep sweep/fast-map-implicit-e1
sweep sweep/fast-map-dt4-e1
sweep sweep/fast-map-dt4-liggghts-e1
sweep sweep/fast-map-e1 sweep/fast-map-implicit-e1 sweep/fast-map-dt4-e1 sweep/fast-map-dt4-liggghts-e1
sweep sweep/speed-explicit-e1
sweep sweep/speed-implicit-e1
