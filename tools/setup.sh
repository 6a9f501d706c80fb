#!/usr/bin/env bash
# One command: install LIGGGHTS (Debian package), python3-vtk9 (a test reads the ParaView files), Chromium (the tests render the nightly
# report in it), SLURM (the sweep's scheduler test) and python3-msgpack (the paper-protocol scripts' test), build, and run the default case.
# Usage: bash tools/setup.sh        (as root, or with sudo available)
set -euo pipefail
cd "$(dirname "$0")/.."
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
missing=()
command -v liggghts >/dev/null 2>&1 || missing+=(liggghts libliggghts-dev)
command -v chromium >/dev/null 2>&1 || missing+=(chromium)
# a local SLURM for the sweep's scheduler test (tools/slurm-local.sh starts it; needs root)
/usr/bin/python3 -c "import vtkmodules" >/dev/null 2>&1 || missing+=(python3-vtk9)  # tests read the ParaView files
command -v slurmctld >/dev/null 2>&1 || missing+=(slurmctld slurmd slurm-client munge)
# the paper-protocol carry reads checkpoints' steps (tests/paper_protocol_tools.rs)
/usr/bin/python3 -c "import msgpack" >/dev/null 2>&1 || missing+=(python3-msgpack)
if [ "${#missing[@]}" -gt 0 ]; then
  $SUDO apt-get update
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y "${missing[@]}"
fi
cargo build --release
./target/release/verify contact --case rolling_plastic
