#!/usr/bin/env bash
# The cab on this machine, as a pupil drives it: input to photon (a key pressed in the cab's window
# to the first frame presented that was rendered from a truck state which had applied it) and the
# worker's and the cab's CPU, with the worker's frames (a cab with a window), with the picture
# drawn in the cab (--render local, a cab with a graphics card; here Mesa's llvmpipe as the
# worker's) and with none (a scripted cab, no window).
# Real processes: Xvfb, forklift-worker, forklift-cab, keys typed by xdotool. Prints a table.
#   bench/cab_latency.sh [--presses N] [--fps F] [--domain D]
set -euo pipefail
presses=60 fps=30 domain=${FORKLIFT_BENCH_DOMAIN:-90}
while [ $# -gt 0 ]; do
  case "$1" in
    --presses) presses=$2; shift 2 ;;
    --fps) fps=$2; shift 2 ;;
    --domain) domain=$2; shift 2 ;;
    -h|--help) sed -n '2,8p' "$0"; echo "  defaults: --presses 60 --fps 30 --domain 90 (or FORKLIFT_BENCH_DOMAIN)"; exit 0 ;;
    *) echo "cab_latency.sh: unknown option $1 (see --help)" >&2; exit 2 ;;
  esac
done
root=$(cd "$(dirname "$0")/.." && pwd)
bin=$root/build/bin data=$root/data
source "$root/scripts/xvfb-session.sh"

cpu_ticks() { awk '{print $14 + $15}' "/proc/$1/stat"; }
hz=$(getconf CLK_TCK)

# One cab session: worker and cab, the cab's own key presses or script; prints "latency line|cpu %".
run() {
  local kind=$1 cab=bench$1
  "$bin/forklift-worker" --cab "$cab" --session "s-$cab" --scenario "$data/scenarios/rack_pick.json" --fps "$fps" \
    --dds-domain "$domain" --log "$work/$cab.ctl" --start-timeout 30 >"$work/$cab.worker.out" 2>"$work/$cab.worker.err" &
  local worker=$!
  pids+=($worker)
  if [ "$kind" = window ] || [ "$kind" = local ]; then
    local drawn=()
    [ "$kind" = local ] && drawn=(--render local --scenario "$data/scenarios/rack_pick.json")
    "$bin/forklift-cab" --cab "$cab" --keyboard --no-sound --dds-domain "$domain" --wait-worker 30 --latency-report \
      "${drawn[@]}" >"$work/$cab.out" 2>"$work/$cab.err" &
  else
    { echo "t,steer,accelerator,brake,lift,tilt,shift"; for i in $(seq 0 $((presses / 2 + 4))); do echo "$i,0,0,0,0,0,0"; done; } >"$work/idle.csv"
    "$bin/forklift-cab" --cab "$cab" --script "$work/idle.csv" --no-window --dds-domain "$domain" --wait-worker 30 \
      >"$work/$cab.out" 2>"$work/$cab.err" &
  fi
  local cabpid=$!
  pids+=($cabpid)
  sleep 3  # start-up: the renderer's context, discovery
  local t0 c0 t1 c1 k0 k1
  t0=$(date +%s.%N) c0=$(cpu_ticks "$worker") k0=$(cpu_ticks "$cabpid")
  if [ "$kind" != script ]; then
    local steps=()
    for _ in $(seq "$presses"); do steps+=(keydown Left sleep 0.2 keyup Left sleep 0.3); done
    xdotool search --sync --name "Forklift cab $cab" windowfocus --sync %1 "${steps[@]}"
  else
    sleep $(awk "BEGIN{print $presses * 0.5}")
  fi
  t1=$(date +%s.%N) c1=$(cpu_ticks "$worker") k1=$(cpu_ticks "$cabpid")
  if [ "$kind" != script ]; then xdotool search --name "Forklift cab $cab" windowfocus --sync %1 key Escape; fi
  wait "$cabpid" || true
  kill "$worker" 2>/dev/null || true
  wait "$worker" 2>/dev/null || true
  local cpu cab_cpu
  cpu=$(awk "BEGIN{printf \"%.0f\", 100 * ($c1 - $c0) / $hz / ($t1 - $t0)}")
  cab_cpu=$(awk "BEGIN{printf \"%.0f\", 100 * ($k1 - $k0) / $hz / ($t1 - $t0)}")
  echo "$(grep 'input to photon' "$work/$cab.out" || echo '-')|$cpu|$cab_cpu"
  domain=$((domain + 1))
}

echo "cab on $(nproc) cores, worker at --fps $fps, rack_pick, $presses key presses (each a key-down and a key-up)"
printf '%-30s %-12s %-10s %s\n' "cab" "worker CPU" "cab CPU" "input to photon"
IFS='|' read -r lat cpu cab_cpu < <(run window)
printf '%-30s %-12s %-10s %s\n' "window, the worker's frames" "$cpu %" "$cab_cpu %" "${lat#input to photon: }"
IFS='|' read -r lat cpu cab_cpu < <(run local)
printf '%-30s %-12s %-10s %s\n' "window, drawn in the cab" "$cpu %" "$cab_cpu %" "${lat#input to photon: }"
IFS='|' read -r lat cpu cab_cpu < <(run script)
printf '%-30s %-12s %-10s %s\n' "script, no window (no frames)" "$cpu %" "$cab_cpu %" "-"
