#!/usr/bin/env bash
# The main job: build, then one training session end to end on the embedded defaults (server,
# SQLite, a scripted cab, a real sim worker), then the paper's manoeuvres through the model.
set -euo pipefail
cd "$(dirname "$0")/.."
# Only what the main job runs: the programs, the modules they load, the web pages. The test suites
# and benchmarks, most of the build, come with scripts/test.sh.
bash scripts/build.sh forklift-server forklift-menu forklift-worker forklift-cab forklift-sim forklift-host forklift-render \
  forklift-web forklift_collision_module forklift_mesh_module forklift_render_module
bash scripts/demo-session.sh
echo
echo "== the paper's manoeuvres (figures and CSV in out/paper/)"
build/bin/forklift-sim paper --out out/paper
