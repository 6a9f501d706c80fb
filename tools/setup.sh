#!/usr/bin/env bash
# One command: install LIGGGHTS (Debian package) and Chromium (the tests render the nightly
# report in it), build, and run the default case.
# Usage: bash tools/setup.sh        (as root, or with sudo available)
set -euo pipefail
cd "$(dirname "$0")/.."
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
missing=()
command -v liggghts >/dev/null 2>&1 || missing+=(liggghts libliggghts-dev)
command -v chromium >/dev/null 2>&1 || missing+=(chromium)
if [ "${#missing[@]}" -gt 0 ]; then
  $SUDO apt-get update
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y "${missing[@]}"
fi
cargo build --release
./target/release/verify contact --case rolling_plastic
