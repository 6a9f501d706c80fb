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

# sweep DIR [STAND-IN ...] [-- BESIDE [ITS STAND-IN ...]]
sweep() {
  local dir=$1; shift
  local args=() flag=--converged
  for c in "$@"; do
    case $c in
      --) flag=--beside ;;
      *) args+=("$flag" "$root/$c"); [ "$flag" = --beside ] && flag=--beside-converged ;;
    esac
  done
  local log
  # a study still running (the paper protocol's) makes a partial page: it shows what exists
  # and the command says so in its exit status; anything else is a failure
  if ! log=$("$verify" sweep report "$root/$dir" "${args[@]}" 2>&1); then
    grep -q "the report is partial" <<< "$log" || { echo "$log" >&2; exit 2; }
  fi
  echo "page: $root/$dir/report.html"
}

night nightly/20261202-e1
sweep sweep/fast-map-implicit-e1
sweep sweep/fast-map-dt4-e1
sweep sweep/fast-map-dt4-liggghts-e1
sweep sweep/fast-map-e1 sweep/fast-map-implicit-e1 sweep/fast-map-dt4-e1 sweep/fast-map-dt4-liggghts-e1
sweep sweep/speed-explicit-e1
sweep sweep/speed-implicit-e1
# the paper's protocol (issue #37), beside the fast preset's speed study: the same claims at 20x
# the paper's speeds (stand-ins: epsd_implicit at the paper's dt)
if [ -d "$root/paper-protocol/implicit" ]; then
  sweep paper-protocol/implicit -- sweep/speed-implicit-e1
  sweep paper-protocol/epsd paper-protocol/implicit -- sweep/speed-explicit-e1 sweep/speed-implicit-e1
else
  sweep paper-protocol/epsd -- sweep/speed-explicit-e1 sweep/speed-implicit-e1
fi
