#!/usr/bin/env bash
# Mutation testing of the contact kernels, the integrator and the verdict rules (issue #35,
# docs/mutants.md) with cargo-mutants, in a clone of this repository's HEAD outside it
# (DIR/tree, mutated in place there, so its build cache survives between sessions). Resumable:
# a rerun skips the mutants already tested (--iterate) and goes on with the others, in a
# shuffled order, so that the mutants tested so far are a random sample of all.
#   bash tools/mutants.sh [DIR] [-- extra cargo-mutants args]     DIR default /work/mutants
#   MUTANTS_NICE=0 bash tools/mutants.sh     # at the priority of other work (default nice 10)
#   bash tools/mutants.sh save [DIR]          # merge DIR's outcomes into reference/mutants/
# The outcomes so far are kept in the repository (reference/mutants/{caught,missed,timeout,
# unviable}.txt, merged by `save`), so that a run resumes on a new machine: a DIR without
# outcomes starts from the stored lists (the mutants stored as caught or unviable are skipped).
# The tests run per mutant are those that judge these files quickly: the library's unit tests
# of the solver, compare and calibration modules, the stored two-body references
# (tests/contact_reference.rs), the closed-form physics (tests/analytic.rs), the calibration
# tables (tests/calibration.rs) and the Chung & Ooi judge on native runs (every case, and
# spoilt ones); the whole suite (20 min) per mutant would take weeks.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
stored=$repo/reference/mutants
if [ "${1:-}" = save ]; then
  out=${2:-/work/mutants}/mutants.out
  [ -d "$out" ] || { echo "no outcomes in $out" >&2; exit 1; }
  mkdir -p "$stored"
  # a mutant's latest outcome wins: caught or unviable now takes it off missed and timeout
  for f in caught unviable missed timeout; do
    cat "$stored/$f.txt" "$out/$f.txt" 2>/dev/null | sort -u > "$stored/$f.new" || true
  done
  cat "$out/previously_caught.txt" 2>/dev/null >> "$stored/caught.new" || true
  sort -u -o "$stored/caught.new" "$stored/caught.new"
  # previously_caught.txt holds the unviable ones too (cargo-mutants skips both): keep them
  # off caught
  comm -23 "$stored/caught.new" "$stored/unviable.new" > "$stored/caught.only"
  mv "$stored/caught.only" "$stored/caught.new"
  for f in missed timeout; do
    now=$(cat "$out/caught.txt" "$out/unviable.txt" "$out/missed.txt" "$out/timeout.txt" 2>/dev/null | sort -u)
    # drop from the stored list what this run judged otherwise, keep this run's own
    comm -23 <(cat "$stored/$f.txt" 2>/dev/null | sort -u) <(printf '%s\n' "$now" | sort -u) \
      | cat - "$out/$f.txt" 2>/dev/null | sort -u > "$stored/$f.new" || true
  done
  for f in caught unviable missed timeout; do mv "$stored/$f.new" "$stored/$f.txt"; done
  wc -l "$stored"/*.txt
  exit 0
fi
dir=${1:-/work/mutants}; shift || true
[ "${1:-}" = "--" ] && shift
command -v cargo-mutants > /dev/null || cargo install --locked cargo-mutants
mkdir -p "$dir"
files=(
  -f 'src/solver/contact/surface/*.rs' -f 'src/solver/contact/normal/*.rs'
  -f 'src/solver/contact/tangential/*.rs' -f 'src/solver/contact/rolling/*.rs'
  -f 'src/solver/contact/mod.rs' -f 'src/solver/integrate.rs'
  -f 'src/compare.rs' -f 'src/calibration.rs' -f 'src/chung_ooi.rs'
)
[ -d "$dir/tree/.git" ] || git clone -q "$repo" "$dir/tree"
# an interrupted run may leave a mutant in the tree: back to the commit first
git -C "$dir/tree" reset -q --hard
git -C "$dir/tree" fetch -q "$repo" HEAD && git -C "$dir/tree" checkout -q --detach FETCH_HEAD
# --iterate skips the mutants named in mutants.out/{caught,previously_caught,unviable}.txt;
# an interrupted run writes those lists but no outcomes.json, so test for the lists
iterate=()
for f in caught previously_caught unviable; do
  [ -s "$dir/mutants.out/$f.txt" ] && iterate=(--iterate)
done
# a new machine or folder: resume from the outcomes stored in the repository
if [ ${#iterate[@]} -eq 0 ] && [ -s "$stored/caught.txt" ]; then
  mkdir -p "$dir/mutants.out"
  cat "$stored/caught.txt" "$stored/unviable.txt" > "$dir/mutants.out/previously_caught.txt"
  iterate=(--iterate)
  echo "resuming from reference/mutants: $(wc -l < "$dir/mutants.out/previously_caught.txt") caught or unviable skipped"
fi
cd "$dir/tree"
# only the test targets named below are built and run per mutant (-C applies to the build too)
nice -n "${MUTANTS_NICE:-10}" cargo mutants "${files[@]}" "${iterate[@]}" --in-place --profile mutants \
  --shuffle --output "$dir" --timeout-multiplier 3 \
  -C --lib -C --test=contact_reference -C --test=analytic -C --test=chung_ooi \
  -C --test=calibration \
  "$@" -- -- solver::contact:: solver::integrate solver::material compare:: calibration \
  chung_ooi::tests the_duration_is_read a_ten_per_cent every_case_passes_natively native_matches committed_decks a_wrong_friction rolling_ \
  tangential_ normal_ wall_ verdict equivalence the_docs_table equal_codes
