#!/usr/bin/env bash
# The main job: the paper's manoeuvres through the model, a summary table, figures and CSV in out/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
build/bin/forklift-sim paper --out out/paper
echo
build/bin/forklift-bench-dynamics --repeat 3
