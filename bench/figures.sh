#!/usr/bin/env bash
# The table of figures in docs/figures.md (the speed goals): runs each benchmark behind it, collects the
# lines they print as "FIGURE<tab>figure<tab>goal<tab>measured<tab>met", and prints the table
# with the command that measured each row and the machine it ran on. With --readme it also writes
# the table into docs/figures.md between its "bench-table" markers.
#
#   bench/figures.sh [--readme] [--quick]     # --quick: shorter runs (a smoke test of the table)
set -euo pipefail
cd "$(dirname "$0")/.."
readme=0 quick=0
for a in "$@"; do
  case "$a" in
    --readme) readme=1 ;;
    --quick) quick=1 ;;
    -h|--help) sed -n '2,7p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "figures.sh: unknown option '$a' (--readme, --quick)" >&2; exit 2 ;;
  esac
done
bin=build/bin
for b in forklift-bench-dynamics forklift-bench-evaluation forklift-bench-dds forklift-bench-render forklift-bench-server forklift-bench-ingest forklift-bench-store forklift-sim; do
  [ -x "$bin/$b" ] || { echo "figures.sh: $bin/$b is missing: build first (scripts/build.sh)" >&2; exit 2; }
done
work=$(mktemp -d "${TMPDIR:-/tmp}/forklift-figures.XXXXXX")
trap 'rm -rf "$work"' EXIT
rows="$work/rows"
: > "$rows"
# Ports and DDS domains from the tests' allocator, as every program that listens takes them.
alloc=build/tests/forklift-test-alloc

# Runs a benchmark; its FIGURE lines become rows, with the command that printed them (and
# $suffix after each figure's name, where one figure is measured at several settings).
suffix=""
measure() {
  local shown="$1"; shift
  echo "figures.sh: $shown" >&2
  # A benchmark whose goals are not met says so in its exit status; its figures are what count.
  "$@" > "$work/out" 2> "$work/err" || true
  grep -qP '^FIGURE\t' "$work/out" || { cat "$work/err" >&2; echo "figures.sh: '$shown' printed no figures" >&2; exit 1; }
  grep -P '^FIGURE\t' "$work/out" | while IFS=$'\t' read -r _ figure goal measured met; do
    printf '| %s | %s | %s | %s | `%s` |\n' "$figure$suffix" "$goal" "$measured" "$met" "$shown" >> "$rows"
  done
}

repeat=9 seconds=10
[ "$quick" = 1 ] && repeat=3 seconds=3
measure "forklift-bench-dynamics --repeat $repeat" "$bin/forklift-bench-dynamics" --repeat "$repeat"
measure "forklift-bench-evaluation --benchmark_filter=pipeline" "$bin/forklift-bench-evaluation" --benchmark_filter=pipeline

# forklift-sim manoeuvre 4 as a user runs it, one run per process: the whole process (start-up
# included) and the real-time factor the program itself reports, each the median of 11 runs.
times=() factors=()
for _ in $(seq 11); do
  t0=$(date +%s%N); out=$("$bin/forklift-sim" manoeuvre 4 --json); t1=$(date +%s%N)
  times+=($(( (t1 - t0) / 1000 )))
  factors+=("$(printf '%s\n' "$out" | sed -n 's/^ *"real_time_factor": *\([0-9.]*\).*/\1/p')")
done
median_us=$(printf '%s\n' "${times[@]}" | sort -n | sed -n 6p)
met=$([ "$median_us" -lt 40000 ] && echo yes || echo NO)
printf '| `forklift-sim manoeuvre 4`, the whole process | < 40 ms | %s ms | %s | `bench/figures.sh` (median of 11) |\n' \
  "$(awk "BEGIN{printf \"%.1f\", $median_us/1000}")" "$met" >> "$rows"
median_factor=$(printf '%s\n' "${factors[@]}" | sort -g | sed -n 6p)
met=$(awk "BEGIN{print ($median_factor >= 10000) ? \"yes\" : \"NO\"}")
printf '| `forklift-sim manoeuvre 4`, a single run: times real time, as its own output reports | >= 10,000x | %sx (least %sx, most %sx) | %s | `forklift-sim manoeuvre 4` (median of 11 processes) |\n' \
  "$(printf '%.0f' "$median_factor")" "$(printf '%s\n' "${factors[@]}" | sort -g | head -1 | xargs printf '%.0f')" \
  "$(printf '%s\n' "${factors[@]}" | sort -g | tail -1 | xargs printf '%.0f')" "$met" >> "$rows"

# The workers as a simulation PC runs them (forklift-host --realtime-workers), and the framed
# fleet at normal priority beside it.
measure "forklift-bench-dds --samples 500 --seconds 3 --fleet 1 --frame-sizes 640x480 --realtime" \
  "$alloc" sh -c "exec $bin/forklift-bench-dds --samples 500 --seconds 3 --fleet 1 --frame-sizes 640x480 --realtime --dds-domain \$FORKLIFT_TEST_DOMAIN --dir $work/dds"
measure "forklift-bench-dds --framed-fleet 8 --framed-only --seconds $seconds --realtime" \
  "$alloc" sh -c "exec $bin/forklift-bench-dds --framed-fleet 8 --framed-only --seconds $seconds --realtime --dds-domain \$FORKLIFT_TEST_DOMAIN --dir $work/dds"
measure "forklift-bench-dds --framed-fleet 8 --framed-only --seconds $seconds" \
  "$alloc" sh -c "exec $bin/forklift-bench-dds --framed-fleet 8 --framed-only --seconds $seconds --dds-domain \$FORKLIFT_TEST_DOMAIN --dir $work/dds"
measure "LP_NUM_THREADS=0 forklift-bench-render --benchmark_filter=jpeg_frame" \
  env LP_NUM_THREADS=0 "$bin/forklift-bench-render" --benchmark_filter=jpeg_frame --benchmark_repetitions=3
# A pupil's history on both backends side by side (PostgreSQL a server of its own, filled by SQL):
# its rate on each and PostgreSQL's against SQLite's, measured in the same run.
measure "forklift-bench-server --db sqlite postgresql --runs 0 --seconds $seconds" \
  "$alloc" sh -c "exec $bin/forklift-bench-server --db sqlite postgresql --runs 0 --seconds $seconds --dir ${FORKLIFT_BENCH_DIR:-build/bench-data} --port \$FORKLIFT_TEST_PORT --dds-domain \$FORKLIFT_TEST_DOMAIN"
# The server's DDS ingest: sessions at a worker's 60 Hz, on a copy of that store (its pupils'
# histories asked meanwhile).
ingest_sessions="100 300 500"
[ "$quick" = 1 ] && ingest_sessions="50 300"
history_store="${FORKLIFT_BENCH_DIR:-build/bench-data}/server-10000x50.db"
from=()
[ -f "$history_store" ] && from=(--from "$history_store")
measure "forklift-bench-ingest --sessions $ingest_sessions --seconds $seconds ${from[*]}" \
  "$alloc" sh -c "exec $bin/forklift-bench-ingest --sessions $ingest_sessions --seconds $seconds ${from[*]} --dir $work/ingest --port \$FORKLIFT_TEST_PORT --dds-domain \$FORKLIFT_TEST_DOMAIN"
# Two servers on one PostgreSQL against one, each ingesting the sessions started through it.
measure "forklift-bench-ingest --db postgresql --servers 1 2 --sessions 300 --seconds $seconds" \
  "$alloc" sh -c "exec $bin/forklift-bench-ingest --db postgresql --servers 1 2 --sessions 300 --seconds $seconds --dir $work/ingest-pg --port \$FORKLIFT_TEST_PORT --dds-domain \$FORKLIFT_TEST_DOMAIN"

# The lists and the history as the store grows: generated stores of 100,000, 1 million and 10
# million sessions on both backends (kept in the bench folder: some 15 GB at 10 million; the first
# run generates them, some 15 minutes), every list's p99 at the largest, and each call's growth
# (its p50 from the smallest to the largest, with its p99 at each size).
# --quick: 100,000 sessions alone, no growth rows.
sizes="100000 1000000 10000000"
[ "$quick" = 1 ] && sizes=100000
measure "forklift-bench-store --sessions $sizes --db sqlite postgresql --seconds $seconds" \
  "$bin/forklift-bench-store" --sessions $sizes --db sqlite postgresql --seconds "$seconds" --dir "${FORKLIFT_BENCH_DIR:-build/bench-data}"
# The ingest on a copy of each of those stores (300 sessions, the goal's), on each backend.
bench_dir="${FORKLIFT_BENCH_DIR:-build/bench-data}"
for n in $sizes; do
  suffix=", on a store of $n sessions"
  measure "forklift-bench-ingest --sessions 300 --seconds $seconds --from $bench_dir/store_$n.db" \
    "$alloc" sh -c "exec $bin/forklift-bench-ingest --sessions 300 --seconds $seconds --from $bench_dir/store_$n.db --dir $work/ingest-$n --port \$FORKLIFT_TEST_PORT --dds-domain \$FORKLIFT_TEST_DOMAIN"
  measure "forklift-bench-ingest --db postgresql --from-postgresql $bench_dir/postgresql/store_$n --sessions 300 --seconds $seconds" \
    "$alloc" sh -c "exec $bin/forklift-bench-ingest --db postgresql --from-postgresql $bench_dir/postgresql/store_$n --sessions 300 --seconds $seconds --dir $work/ingest-pg-$n --port \$FORKLIFT_TEST_PORT --dds-domain \$FORKLIFT_TEST_DOMAIN"
  rm -rf "$work/ingest-$n" "$work/ingest-pg-$n"
done
suffix=""

machine="$(nproc) cores ($(lscpu | sed -n 's/^Model name: *//p' | head -1)), $(free -g | awk '/^Mem:/{print $2}') GiB, $(uname -sr), load average $(cut -d' ' -f1-3 /proc/loadavg) at the end, $(date -u +%Y-%m-%d)"
{
  echo "Measured by \`bench/figures.sh\` on $machine."
  echo
  echo "| figure | goal | measured | met | command |"
  echo "|---|---|---|---|---|"
  cat "$rows"
} > "$work/table"
cat "$work/table"
if [ "$readme" = 1 ]; then
  grep -q '<!-- bench-table:begin -->' docs/figures.md || { echo "figures.sh: docs/figures.md has no bench-table markers" >&2; exit 1; }
  awk -v table="$work/table" '
    /<!-- bench-table:begin -->/ { print; while ((getline line < table) > 0) print line; skip = 1; next }
    /<!-- bench-table:end -->/ { skip = 0 }
    !skip' docs/figures.md > "$work/readme" && cp "$work/readme" docs/figures.md
  echo "figures.sh: docs/figures.md's table rewritten" >&2
fi
