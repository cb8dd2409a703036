#!/usr/bin/env bash
# Installs every Debian 12 package the project needs. Idempotent; run as root.
# Packages already present are skipped by apt itself, so a second run is quick.
set -euo pipefail

packages=(
  build-essential cmake pkg-config git curl
  # dynamics
  libeigen3-dev libsundials-dev
  # scene, collision, rendering (later modules)
  libfcl-dev libassimp-dev libosmesa6-dev libturbojpeg0-dev libpng-dev libsdl2-dev libsdl2-ttf-dev
  # the cab's window in tests: a real X server and keys typed into it
  xvfb xdotool
  # protocol
  cyclonedds-dev cyclonedds-tools
  # store, server, tools
  libsqlite3-dev nlohmann-json3-dev libcli11-dev libspdlog-dev libcpp-httplib-dev libsodium-dev
  # the most read answers (a pupil's history) written as a stream
  rapidjson-dev
  # the store's PostgreSQL backend (libpq), and the server its tests start themselves (initdb, pg_ctl)
  libpq-dev postgresql
  # data files checked against their JSON Schemas (data/schema/)
  libvalijson-dev
  # the server's API description (server/openapi.yaml), read as the contract its requests are checked against
  libyaml-cpp-dev
  # secured exams: the school's certificate authority, exam-log signatures, the loopback capture test
  openssl libssl-dev tcpdump
  # several machines on one (label hosts): network namespaces, veth pairs and a bridge
  iproute2
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev
  # forklift-bench-dynamics compares the model with MuJoCo on a comparable truck (optional at build time)
  libmujoco-dev
  # the lists browser test writes a day of sessions straight into its server's SQLite file
  sqlite3
  # the web pages' end-to-end test: headless Chromium (driven by playwright-core from npm, below)
  chromium fonts-dejavu-core
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
else
  echo "install-deps.sh: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -q
  apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

# npm packages, exactly as each package-lock.json says: the chart library the build copies beside
# the web pages (menu/web) and the browser driver of their test (tests/web). Node comes with the
# machine; Debian's if it does not. Skipped when node_modules already matches the lock file.
if ! command -v npm >/dev/null 2>&1; then
  echo "install-deps.sh: installing Debian's nodejs and npm"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -q
  apt-get install -y -q --no-install-recommends nodejs npm
fi
root=$(cd "$(dirname "$0")/.." && pwd)
for dir in menu/web tests/web; do
  stamp="$root/$dir/node_modules/.installed-from-package-lock.json"
  if cmp -s "$root/$dir/package-lock.json" "$stamp"; then
    echo "install-deps.sh: $dir/node_modules is up to date"
  else
    echo "install-deps.sh: npm ci in $dir"
    (cd "$root/$dir" && npm ci --no-audit --no-fund --loglevel=error)
    cp "$root/$dir/package-lock.json" "$stamp"
  fi
done
