#!/usr/bin/env bash
# The picture of the cab in docs/simulation.md (docs/cab-window.png): a real worker and forklift-cab in an Xvfb
# window, driven by keys typed with xdotool in rack_pick: drive off, lift the forks a little,
# see-through mast and rear-view mirror on, then a picture of the whole window (F12's, at exit).
# Needs the build (build/bin/) and xvfb and xdotool (scripts/install-deps.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-docs/cab-window.png}
source scripts/xvfb-session.sh
domain=${FORKLIFT_DDS_DOMAIN:-95}
build/bin/forklift-worker --cab shot --session s-shot --scenario data/scenarios/rack_pick.json --dds-domain "$domain" \
  --log "$work/shot.ctl" --start-timeout 30 >/dev/null 2>&1 &
pids+=($!)
build/bin/forklift-cab --cab shot --keyboard --no-sound --dds-domain "$domain" --wait-worker 30 --save-window "$out" \
  >/dev/null 2>"$work/cab.err" &
cab=$!
xdotool search --sync --name "Forklift cab shot" windowfocus --sync %1 sleep 2 keydown Up sleep 1.6 keyup Up \
  keydown w sleep 0.6 keyup w key m key b sleep 1.5 key Escape
wait "$cab"
echo "cab-screenshot.sh: wrote $out"
