#!/usr/bin/env bash
# The plates' influence on steady friction and grip (fidelity issue, item 3): fast preset,
# e = 1 (the presets' restitution), 3 seeds, at (mu_r, eta_r) = (0, 0) and (0.5, 0), for flat
# plates and teeth of 0.1 and 0.2 mm (wavelength 0.5 mm). The default plates (0.2 mm teeth)
# run in both codes, the others natively. Every run resumes per seed, so the script can be
# rerun after an interruption; at the end it prints the table (Markdown) from the summaries.
#
#   tools/plate-sensitivity.sh OUT_DIR [VERIFY_BINARY]
set -euo pipefail
out=${1:?usage: tools/plate-sensitivity.sh OUT_DIR [VERIFY_BINARY]}
bin=${2:-target/release/verify}
mkdir -p "$out"

run() { # name engine-flag plate-flags... ; mu_r eta_r taken from $mr $er
  local name=$1 engine=$2
  shift 2
  local dir="$out/$name-mur$mr-etar$er"
  echo "== $dir"
  # exit 1 (the codes disagree) is a result, recorded in the summary; 2 is an error
  "$bin" shear --preset fast --mu-r "$mr" --eta-r "$er" --seeds 3 $engine "$@" \
    --out "$dir" >"$dir.log" 2>&1 || [ $? -eq 1 ]
}

for p in "0 0" "0.5 0"; do
  read -r mr er <<<"$p"
  run flat "--native-only --threads 1" --flat-plates &
  run teeth0.1 "--native-only --threads 1" --tooth-height 1e-4
  wait
  run teeth0.2 ""
done

echo
echo "| plates | (mu_r, eta_r) | code | steady mu (95 % CI) | per seed | slip bottom / top per seed [%] | slip bottom, top: seed mean (95 % CI) [%] | band / gap [mm] |"
echo "|---|---|---|---|---|---|---|---|"
for s in "$out"/*/summary.json; do
  name=$(basename "$(dirname "$s")")
  jq -r --arg name "${name%%-mur*}" '
    def f(x; d): (x * pow(10; d) | round) / pow(10; d);
    . as $s | ["liggghts", "native"][] as $c
    | select($s[$c] != null)
    | ($s.profiles[$c] | last) as $p
    | "| \($name) | (\($s.mu_r), \($s.eta_r)) | \($c) | \(f($s[$c].mu; 3)) +- \(f($s[$c].mu_ci95; 3)) | \($s[$c].per_seed_mu | map(f(.; 3)) | join(", ")) | \($s.seeds | map(.[$c + "_profiles"] | last | "\(f(100 * .slip_bottom; 0)) / \(f(100 * .slip_top; 0))") | join(", ")) | \(f(100 * $p.slip_bottom; 1)) +- \(f(100 * $p.slip_bottom_ci95; 1)), \(f(100 * $p.slip_top; 1)) +- \(f(100 * $p.slip_top_ci95; 1)) | \(f(1000 * $p.band_width; 2)) / \(f(1000 * $p.gap; 2)) |"
  ' "$s"
done
