# Sourced by scripts that drive the cab's window: a scratch folder ($work), the processes to stop
# on exit ($pids, add to it), and an X server of their own (Xvfb picks a free display; DISPLAY is
# exported, and SDL_AUDIODRIVER=dummy so that no sound card is needed).
work=$(mktemp -d)
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; rm -rf "$work"; }
trap cleanup EXIT
exec 3>"$work/display"
Xvfb -displayfd 3 -screen 0 1280x1024x24 -nolisten tcp 2>/dev/null &
pids+=($!)
for _ in $(seq 100); do [ -s "$work/display" ] && break; sleep 0.1; done
export DISPLAY=:$(cat "$work/display") SDL_AUDIODRIVER=dummy
