#!/usr/bin/env bash
# One command: install LIGGGHTS (Debian package), build, and run the default case.
# Usage: bash tools/setup.sh        (as root, or with sudo available)
set -euo pipefail
cd "$(dirname "$0")/.."
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
if ! command -v liggghts >/dev/null 2>&1; then
  $SUDO apt-get update
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y liggghts libliggghts-dev
fi
cargo build --release
./target/release/verify contact --case rolling_plastic
