#!/usr/bin/env bash
# The referee's verdict runs (hours on two cores; resumable: every finished solve is kept, the FDTD
# beams in results/referee/beams/). Run from the repository's top: bash results/referee/run.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
.venv/bin/groundplane study referee --design results/robust_front_0.5m/answer-600.json \
    --freqs 55:97:2 --cell 0.075 -o results/referee
