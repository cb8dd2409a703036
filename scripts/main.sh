#!/usr/bin/env bash
# The main job: build, then one training session end to end on the embedded defaults (server,
# SQLite, a scripted cab, a real sim worker), then the paper's manoeuvres through the model.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
bash scripts/demo-session.sh
echo
echo "== the paper's manoeuvres (figures and CSV in out/paper/)"
build/bin/forklift-sim paper --out out/paper
