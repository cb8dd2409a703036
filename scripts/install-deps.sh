#!/usr/bin/env bash
# Installs every Debian 12 package the project needs. Idempotent; run as root.
# Packages already present are skipped by apt itself, so a second run is quick.
set -euo pipefail

packages=(
  build-essential cmake pkg-config git curl
  # dynamics
  libeigen3-dev libsundials-dev
  # scene, collision, rendering (later modules)
  libfcl-dev libassimp-dev libosmesa6-dev libturbojpeg0-dev libpng-dev
  # protocol
  cyclonedds-dev cyclonedds-tools
  # store, server, tools
  libsqlite3-dev nlohmann-json3-dev libcli11-dev libspdlog-dev libcpp-httplib-dev libsodium-dev
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev
)

if [ "$(id -u)" -ne 0 ]; then
  echo "install-deps.sh: run as root (apt-get needs it)" >&2
  exit 1
fi

missing=()
for p in "${packages[@]}"; do
  dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps.sh: all ${#packages[@]} packages present"
  exit 0
fi
echo "install-deps.sh: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -q
apt-get install -y -q --no-install-recommends "${missing[@]}"
