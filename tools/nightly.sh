#!/usr/bin/env bash
# Nightly agreement run: `verify nightly` into a dated folder under runs/nightly (or
# $NIGHTLY_ROOT), one shared history file, a `latest` link to the newest night. Extra arguments
# go to `verify nightly` (e.g. --quick). Exit status is verify's: 0 agree, 1 disagree, 2 error,
# so cron (MAILTO) or systemd (OnFailure=) can alert.
set -uo pipefail
cd "$(dirname "$0")/.."
# cron and systemd start with a minimal PATH: find cargo where rustup puts it
export PATH="$HOME/.cargo/bin:/usr/local/cargo/bin:$PATH"
root="${NIGHTLY_ROOT:-runs/nightly}"
stamp="$(date -u +%Y%m%d-%H%M)"
mkdir -p "$root"
cargo build --release --quiet || exit 2
status=0
target/release/verify nightly --out "$root/$stamp" --history "$root/history.jsonl" "$@" \
  >"$root/$stamp.log" 2>&1 || status=$?
ln -sfn "$stamp" "$root/latest"
echo "nightly $stamp: exit $status; report $root/$stamp/report.html; log $root/$stamp.log"
if [ "$status" -ne 0 ]; then tail -n 30 "$root/$stamp.log"; fi
exit "$status"
