#!/usr/bin/env bash
# The platform end to end on the embedded defaults: a server on a fresh SQLite file, a demo pupil,
# one training session on cab "cab1" driven by a shipped script through a real sim worker, then the
# pupil's history. Everything stays on 127.0.0.1; the run leaves its files in out/demo/.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/bin
out=out/demo
port=${FORKLIFT_DEMO_PORT:-18080}
export FORKLIFT_DDS_DOMAIN=${FORKLIFT_DDS_DOMAIN:-77}
rm -rf "$out" && mkdir -p "$out"
export FORKLIFT_ADMIN_PASSWORD=demo-admin-password
menu() { "$bin/forklift-menu" --server "http://127.0.0.1:$port" --token-file "$out/token" "$@"; }

"$bin/forklift-server" --db "$out/forklift.db" --listen "127.0.0.1:$port" 2> "$out/server.log" &
server=$!
trap 'kill $server 2>/dev/null; wait $server 2>/dev/null || true' EXIT
for _ in $(seq 50); do curl -sf "http://127.0.0.1:$port/api/health" > /dev/null && break; sleep 0.1; done

FORKLIFT_PASSWORD=$FORKLIFT_ADMIN_PASSWORD menu login --user admin
pupil=$(menu pupil-add --name "Demo Pupil" --email demo@example.org | sed -E 's/^pupil ([0-9]+):.*/\1/')
echo "== training session: the first-drive yard on cab1, driven by a shipped script with faults in it"
menu start --pupil "$pupil" --cab cab1 --scenario first_drive_yard --time-limit 26 \
  --drive data/evaluation/scripts/first_drive_yard_faults.csv --save-frame "$out/cab1-last-frame.png"
session=$(menu history --pupil "$pupil" | awk '/^s-/ {print $1}' | tail -1)
menu session "$session"
echo "== the pupil's history"
menu history --pupil "$pupil"
menu export --pupil "$pupil" --out "$out/history.csv"
echo "server log, control log, history.csv and the cab's last frame (cab1-last-frame.png) are in $out/"
