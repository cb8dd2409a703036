#!/usr/bin/env bash
# Builds and runs every test. `ctest -L <module>` in build/ runs one module's tests.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
ctest --test-dir build --output-on-failure -j"$(nproc)"
