#!/usr/bin/env bash
# Installs the Debian packages (through sudo when not root) and builds into build/: the targets
# named (scripts/main.sh names the programs it runs), or everything, tests and benchmarks too.
#   scripts/build.sh [TARGET ...]
set -euo pipefail
cd "$(dirname "$0")/.."
if [ "$(id -u)" -eq 0 ]; then
  bash scripts/install-deps.sh
else
  sudo bash scripts/install-deps.sh
fi
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
if [ "$#" -gt 0 ]; then
  cmake --build build -j"$(nproc)" --target "$@"
else
  cmake --build build -j"$(nproc)"
fi
