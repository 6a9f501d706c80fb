#!/usr/bin/env bash
# Measures the per-seed paired sets behind the verdict's calibration (issue #35,
# docs/verdicts.md) and stores them as reference/calibration/<preset>.json:
#   equal codes: LIGGGHTS and native on the same seeds (both codes, one invocation);
#   equal codes, native against native: mu_p nudged by 1 ulp (0.5 -> 0.5000000000000001), a
#   round-off difference that chaos grows into another realisation of the same law;
#   known errors: native against native with mu_p x1.1, mu_p x0.9, restitution 0.9, and the
#   rolling stiffness x1.1 (epsd3 with its factor 2.475 against epsd, whose fixed factor is
#   2.25: epsd3 at 2.25 is epsd bit for bit, tests/shear_offline.rs).
# Usage: bash tools/calibrate.sh PRESET SEEDS WORKDIR [VERIFY]   e.g. ci 40 /tmp/cal
#   MU_R, ETA_R (default 0.5, 0.5): the point; ERRORS (default "ulp mup1.1 mup0.9 e0.9 kr1.1"): the errors;
#   EQUAL_FROM="DIR ...": take the equal-codes sets from stored summaries of both codes (e.g.
#   reference/paired-20261202/epsd-e1-mur0.5-etar0) instead of running LIGGGHTS.
# Resumable: rerun the same command (each verify shear reuses its finished seeds).
set -euo pipefail
preset=$1; seeds=$2; work=$3; verify=${4:-$(dirname "$0")/../target/release/verify}
mu_r=${MU_R:-0.5}; eta_r=${ETA_R:-0.5}; errors=${ERRORS:-ulp mup1.1 mup0.9 e0.9 kr1.1}
point=(--mu-r "$mu_r" --eta-r "$eta_r" --preset "$preset" --seeds "$seeds" --threads 1 --checkpoint-every -1)
mkdir -p "$work"
equal=()
if [ -z "${EQUAL_FROM:-}" ]; then
  # equal codes (exit 3 inconclusive and 1 disagree are outcomes here, not failures)
  "$verify" shear "${point[@]}" --out "$work/equal" > "$work/equal.log" 2>&1 || [ $? -le 3 ]
  equal=("$work/equal")
else
  read -r -a equal <<< "$EQUAL_FROM"
fi
# BASE_FROM=DIR: the base runs from a stored native-only invocation of the same point and
# seeds (e.g. an earlier calibration's base/) instead of running them again
base=${BASE_FROM:-$work/base}
[ -n "${BASE_FROM:-}" ] || "$verify" shear "${point[@]}" --native-only --out "$base" > "$work/base.log" 2>&1
for e in $errors; do
  case $e in
    ulp) flag=(--friction 0.5000000000000001) ;;
    mup1.1) flag=(--friction 0.55) ;;
    mup0.9) flag=(--friction 0.45) ;;
    e0.9) flag=(--restitution 0.9) ;;
    kr1.1) flag=(--rolling epsd3 --rolling-stiffness 2.475) ;;
    *) echo "unknown error $e (valid: ulp mup1.1 mup0.9 e0.9 kr1.1)" >&2; exit 2 ;;
  esac
  "$verify" shear "${point[@]}" --native-only "${flag[@]}" --out "$work/$e" > "$work/$e.log" 2>&1
done
commit=${COMMIT:-$(git -C "$(dirname "$0")/.." rev-parse --short HEAD 2>/dev/null || echo unknown)}
python3 - "$preset" "$work" "$commit" "$seeds" "$mu_r" "$eta_r" "$errors" "$base" "${equal[@]}" <<'PY'
import json, sys, datetime
preset, work, commit, seeds, mu_r, eta_r, errors, base_dir, *equal = sys.argv[1:]
def steady(d, code):
    s = json.load(open(f"{d}/summary.json"))
    return [x["seed"] for x in s["seeds"]], s[code]["per_seed_mu"]
sets = []
for d in equal:
    seeds_e, lig = steady(d, "liggghts")
    _, nat = steady(d, "native")
    sets.append(dict(label=f"liggghts vs native ({d.rstrip('/').split('/')[-1]})", equal=True,
                     seeds=seeds_e, a=lig, b=nat))
seeds_b, base = steady(base_dir, "native")
names = {"ulp": "native vs native, mu_p + 1 ulp", "mup1.1": "mu_p x1.1", "mup0.9": "mu_p x0.9", "e0.9": "restitution 0.9",
         "kr1.1": "rolling stiffness x1.1"}
for e in errors.split():
    s, v = steady(f"{work}/{e}", "native")
    assert s == seeds_b
    sets.append(dict(label=names[e], equal=(e == "ulp"), seeds=s, a=base, b=v))
out = dict(preset=preset,
           provenance=f"tools/calibrate.sh {preset} {seeds}: errors at (mu_r, eta_r) = ({mu_r}, "
                      f"{eta_r}), epsd, seeds 1-{seeds}; equal codes from {equal}; commit "
                      f"{commit}, {datetime.date.today()}",
           sets=sets)
json.dump(out, open(f"{work}/{preset}.json", "w"), indent=1)
print(f"{work}/{preset}.json")
PY
