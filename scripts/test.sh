#!/usr/bin/env bash
# Builds and runs every test. `ctest -L <module>` in build/ runs one module's tests.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
# Two tests per core: most of them wait on real time (sessions, servers, browsers), and the
# scripted cabs' rows, sent a second ahead, hold at that load; at four per core frame and browser
# tests starve.
ctest --test-dir build --output-on-failure -j"$((2 * $(nproc)))"
