#!/usr/bin/env bash
# Builds and runs every test. `ctest -L <module>` in build/ runs one module's tests.
# Most tests wait on real time (a worker's 1 kHz tick, a scripted cab, a server's timeouts) and
# use a fraction of a core, so ctest runs twice as many at once as the machine has cores.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
ctest --test-dir build --output-on-failure -j"$(( $(nproc) * 2 ))"
