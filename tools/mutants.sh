#!/usr/bin/env bash
# Mutation testing of the contact kernels, the integrator and the verdict rules (issue #35,
# docs/mutants.md) with cargo-mutants, in a folder outside the clone. Resumable: a rerun skips
# the mutants already caught or found unviable (--iterate) and goes on with the others.
#   bash tools/mutants.sh [DIR] [-- extra cargo-mutants args]     DIR default /work/mutants
# The tests run per mutant are those that judge these files quickly: the library's unit tests
# of the solver, compare and calibration modules, the stored two-body references
# (tests/contact_reference.rs), the closed-form physics (tests/analytic.rs), the calibration
# tables (tests/calibration.rs) and the Chung & Ooi judge's negative control; the whole suite (20 min) per mutant would take weeks.
set -euo pipefail
dir=${1:-/work/mutants}; shift || true
[ "${1:-}" = "--" ] && shift
repo=$(cd "$(dirname "$0")/.." && pwd)
command -v cargo-mutants > /dev/null || cargo install --locked cargo-mutants
mkdir -p "$dir"
files=(
  -f 'src/solver/contact/surface.rs' -f 'src/solver/contact/normal/*.rs'
  -f 'src/solver/contact/tangential/*.rs' -f 'src/solver/contact/rolling/*.rs'
  -f 'src/solver/contact/mod.rs' -f 'src/solver/integrate.rs'
  -f 'src/compare.rs' -f 'src/calibration.rs' -f 'src/chung_ooi.rs'
)
iterate=()
[ -f "$dir/mutants.out/outcomes.json" ] && iterate=(--iterate)
cd "$repo"
nice -n 10 cargo mutants "${files[@]}" "${iterate[@]}" --profile mutants -j 1 \
  --output "$dir" --timeout-multiplier 3 \
  --cargo-test-arg=--lib --cargo-test-arg=--test=contact_reference \
  --cargo-test-arg=--test=analytic --cargo-test-arg=--test=chung_ooi \
  --cargo-test-arg=--test=calibration \
  "$@" -- -- solver::contact:: solver::integrate solver::material compare:: calibration \
  chung_ooi::tests a_ten_per_cent native_matches committed_decks a_wrong_friction rolling_ \
  tangential_ normal_ wall_ verdict equivalence the_docs_table equal_codes
