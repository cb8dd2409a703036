#!/usr/bin/env bash
# Worker hosts and two servers: five network namespaces joined by a
# bridge stand for a school's machines. S runs PostgreSQL and server A, T server B on the same
# database, H1 and H2 a forklift-host each, C the cabs; all speak DDS by protocol/config/lan.xml
# (multicast discovery on their one interface) and nothing leaves the namespaces.
#   1. Four sessions started through server A run on both hosts (two each); scripted cabs in C
#      drive them; their events and marks reach the store exactly once (each event of the host's
#      session log once, every mark once). Server B, on the same database, ingests none of them:
#      each session is its starting server's.
#   2. Killing H1's agent and workers fails its session with the reason; the next session goes
#      to H2, the host left.
#   3. Server A stops mid-session: the session goes on, server B takes it over once A's lease has
#      run out and settles it with its mark; A, started again, leaves it to B.
#   4. With DDS Security (--secure): the same school with every identity; a cab with its own
#      identity cannot drive another cab's worker, which never hears a control.
#   5. Nothing is believed without an identity. In clear DDS hosts and servers run only with
#      --trust-clear-hosts; a server without it believes no host: a forged status places nothing,
#      a forged report on its own session changes neither the log nor the mark, each refusal
#      counted. With DDS Security a peer without an identity places, stops and starts nothing, and
#      a host's identity cannot ship a log its session's worker did not sign.
#   6. A host agent restarted in place (SIGHUP) or after a crash (SIGKILL of the agent alone)
#      adopts its running workers; their sessions end with their marks.
#   7. A host that takes a start and stays silent is passed over within the start's budget.
# The namespaces' names and addresses come from the test's DDS domain (forklift-test-alloc), so
# that parallel runs never meet; they are removed however the test ends.
#
#   BUILD/tests/forklift-test-alloc tests/hosts/worker_hosts.sh BUILD/bin data protocol/config scripts OUT FORGE [--secure]
# (FORGE: BUILD/tests/forklift-test-forge, a peer that claims to be a host or a server)
#
# Exit 77 (ctest: skipped, never passed) where namespaces cannot be made (not root, no iproute2)
# or PostgreSQL is not installed.
set -uo pipefail
bin=$(realpath "$1") data=$(realpath "$2") configs=$(realpath "$3") scripts=$(realpath "$4") out=$5 forge=$(realpath "$6") secure=${7:-}
domain=${FORKLIFT_TEST_DOMAIN:?run it through forklift-test-alloc}
port=${FORKLIFT_TEST_PORT:?run it through forklift-test-alloc}
rm -rf "$out" && mkdir -p "$out" && out=$(realpath "$out")
pgbin=${FORKLIFT_PG_BINDIR:-/usr/lib/postgresql/15/bin}

S=fk${domain}s T=fk${domain}t A=fk${domain}a B=fk${domain}b C=fk${domain}c BR=fk${domain}br
if [ "$(id -u)" -ne 0 ] || ! command -v ip >/dev/null || ! ip netns add "$S" 2>"$out/netns.err"; then
  echo "worker_hosts: SKIPPED: this machine cannot make network namespaces ($(cat "$out/netns.err" 2>/dev/null))"
  exit 77
fi
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null; done
  sleep 0.5
  for ns in "$S" "$T" "$A" "$B" "$C"; do
    ip netns pids "$ns" 2>/dev/null | xargs -r kill -9 2>/dev/null
    ip netns del "$ns" 2>/dev/null
  done
  [ -n "${pgdir:-}" ] && rm -rf "$pgdir"
}
trap cleanup EXIT
if [ ! -x "$pgbin/initdb" ] || ! id postgres >/dev/null 2>&1; then
  echo "worker_hosts: SKIPPED: PostgreSQL is not installed (scripts/install-deps.sh installs it)"
  exit 77
fi

# The network: a bridge in S, one veth pair from it to each other machine.
net=10.78.$domain
ip -n "$S" link add "$BR" type bridge
ip -n "$S" link set "$BR" type bridge mcast_snooping 0
ip -n "$S" addr add "$net.1/24" dev "$BR"
ip -n "$S" link set lo up
ip -n "$S" link set "$BR" up
n=2
for ns in "$T" "$A" "$B" "$C"; do
  ip netns add "$ns"
  ip link add "${ns}0" netns "$ns" type veth peer name "${ns}p" netns "$S"
  ip -n "$S" link set "${ns}p" master "$BR" up
  ip -n "$ns" addr add "$net.$n/24" dev "${ns}0"
  ip -n "$ns" link set lo up
  ip -n "$ns" link set "${ns}0" up
  n=$((n + 1))
done
addr_S=$net.1 addr_T=$net.2 addr_C=$net.5

failed=0
fail() { echo "FAILED ($1): $2"; failed=1; }
# Runs a program on machine NS, with that machine's DDS settings; `spawn NS ... &` makes the
# background job the program itself, so that $! is its pid.
spawn() {
  local ns=$1; shift
  local ifc="${ns}0"; [ "$ns" = "$S" ] && ifc=$BR
  exec ip netns exec "$ns" env CYCLONEDDS_URI="file://$configs/lan.xml" FORKLIFT_DDS_INTERFACE="$ifc" FORKLIFT_DDS_DOMAIN="$domain" \
    FORKLIFT_ADMIN_PASSWORD=hosts-admin-password ${FORKLIFT_SECURITY_DIR:+FORKLIFT_SECURITY_DIR=$FORKLIFT_SECURITY_DIR} "$@"
}
on() { (spawn "$@"); }

# PostgreSQL in S, on its address on the school's network (as its IT department runs it).
pgdir=$(mktemp -d /tmp/forklift-hosts-pg.XXXXXX)
chown postgres: "$pgdir"
runuser -u postgres -- "$pgbin/initdb" -D "$pgdir/data" -U forklift -A trust -E UTF8 --locale=C.UTF-8 -N --no-instructions \
  > "$out/initdb.log" 2>&1 || { fail postgresql "initdb: $(tail -3 "$out/initdb.log")"; exit 1; }
echo "host all all $net.0/24 trust" >> "$pgdir/data/pg_hba.conf"
ip netns exec "$S" runuser -u postgres -- "$pgbin/pg_ctl" -D "$pgdir/data" -l "$pgdir/server.log" -w -t 60 \
  -o "-p 5432 -k $pgdir -c listen_addresses=$addr_S -c fsync=off" start > "$out/pg_ctl.log" 2>&1 ||
  { fail postgresql "pg_ctl start: $(cat "$pgdir/server.log")"; exit 1; }
psql_S() { ip netns exec "$S" psql -X -q -t -A -h "$addr_S" -p 5432 -U forklift "$@"; }
psql_S -d postgres -c "CREATE DATABASE forklift" > /dev/null
db="postgresql://forklift@$addr_S:5432/forklift"
sql() { psql_S -d forklift -c "$1"; }

# DDS Security: the school's folder with every identity (servers, hosts, cabs and their workers).
if [ "$secure" = "--secure" ]; then
  pki=$out/pki
  "$scripts/forklift-pki.sh" init "$pki" --school "Hosts School" > /dev/null
  for c in c1 c2 c3 c4; do "$scripts/forklift-pki.sh" add-cab "$pki" "$c" > /dev/null; done
  for h in h1 h2; do "$scripts/forklift-pki.sh" issue "$pki" host "$h" > /dev/null; done
  "$scripts/forklift-pki.sh" issue "$pki" server main > /dev/null
  export FORKLIFT_SECURITY_DIR=$pki
fi

# In clear DDS hosts are believed only on the operator's word (a closed network: these namespaces).
trust=(); [ "$secure" = "--secure" ] || trust=(--trust-clear-hosts)
start_server() {  # NS ADDRESS NAME (A2: server A started again)
  spawn "$1" "$bin/forklift-server" --db "$db" --listen "$2:$port" --no-local-workers --log-dir "$out/$3" \
    --server-id "${3%2}" --server-lease 4 --frame-fps 0 "${trust[@]}" 2> "$out/$3.log" &
  pids+=($!)
  eval "server_$3=$!"
  for _ in $(seq 300); do ip netns exec "$C" curl -sf "http://$2:$port/api/health" > /dev/null && return 0; sleep 0.1; done
  fail "$3" "server $3 never answered: $(tail -5 "$out/$3.log")"
  exit 1
}
start_host() {  # NS ID [MORE ARGUMENTS]
  spawn "$1" "$bin/forklift-host" --host-id "$2" --capacity 2 --start-timeout 30 --log-dir "$out/$2" "${trust[@]}" "${@:3}" >> "$out/$2.log" 2>&1 &
  pids+=($!)
  eval "agent_$2=$!"
}
menu() {  # on the cabs' machine, against server A
  on "$C" "$bin/forklift-menu" --server "http://$addr_S:$port" --token-file "$out/token" "$@"
}
fleet() {  # SERVER_ADDRESS [TOKEN_FILE]: the /api/fleet answer
  ip netns exec "$C" curl -sf -H "Authorization: Bearer $(cat "${2:-$out/token}")" "http://$1:$port/api/fleet"
}
# A field of a server's /api/fleet answer, as Python reads it: fleet_says ADDRESS EXPRESSION [TOKEN_FILE]
fleet_says() { fleet "$1" "${3:-}" | python3 -c "import json,sys; f=json.load(sys.stdin); print($2)" 2>/dev/null; }
forge() {  # NS FORGE_ARGUMENTS: a peer on machine NS that claims to be a host or a server
  (spawn "$1" "$forge" "${@:2}" >> "$out/forge.log" 2>&1)
}
# A session log that claims a perfect mark, as a forger would ship it.
forged_log() {  # SESSION CAB FILE
  printf 'forklift-control-log 1\nsession %s\ncab %s\nmode training\nscore 0x1.9p+6 1 0 completed forged\n' "$1" "$2" > "$3"
}
host_of() {  # SESSION: the host /api/fleet says runs it (asked again while a busy machine gives no answer)
  local h=""
  for _ in $(seq 20); do
    h=$(fleet "$addr_S" | python3 -c "import json,sys; print(next((w['host'] or 'here') for w in json.load(sys.stdin)['workers'] if w['session']=='$1'))" 2>/dev/null)
    [ -n "$h" ] && break
    sleep 0.25
  done
  echo "$h"
}
wait_hosts() {  # N: until server A sees N live hosts
  for _ in $(seq 150); do
    [ "$(fleet "$addr_S" | python3 -c "import json,sys; print(sum(h['alive'] for h in json.load(sys.stdin)['hosts']))" 2>/dev/null)" = "$1" ] && return 0
    sleep 0.2
  done
  fail hosts "server A never saw $1 live worker host(s): $(fleet "$addr_S")"
  exit 1
}
session_state() { sql "SELECT state FROM sessions WHERE public_id = '$1'"; }
wait_state() {  # SESSION STATES_REGEX SECONDS
  for _ in $(seq $(($3 * 5))); do [[ "$(session_state "$1")" =~ ^($2)$ ]] && return 0; sleep 0.2; done
  return 1
}
script=$data/evaluation/scripts/first_drive_yard_exam.csv
start() {  # CAB TIME_LIMIT: starts a session, prints its id
  menu start --pupil "$pupil" --cab "$1" --scenario first_drive_yard --time-limit "$2" | sed -n 's/^session \(s-[0-9]*\) started.*/\1/p'
}
cabs=()
drive() {  # CAB [IDENTITY]: a scripted cab in C, set up in English, in the background
  spawn "$C" env LC_ALL=C.UTF-8 "$bin/forklift-cab" --cab "$1" --script "$script" --wait-worker 60 --no-window --no-sound ${2:+--identity $2} \
    > "$out/cab-$1${2:+-as-$2}.log" 2>&1 &
  cabs+=($!)
}
wait_cabs() { for p in "${cabs[@]}"; do wait "$p"; done; cabs=(); }

start_host "$A" h1
start_host "$B" h2 --realtime-workers  # its workers tick at real-time priority (root may)
start_server "$S" "$addr_S" A
FORKLIFT_PASSWORD=hosts-admin-password menu login --user admin > /dev/null || { fail login "$(tail -3 "$out/A.log")"; exit 1; }
pupil=$(menu pupil-add --name "Hosts Pupil" --email hosts@example.org | sed -E 's/^pupil ([0-9]+):.*/\1/')
wait_hosts 2

if [ "$secure" != "--secure" ]; then
  # 1. Four sessions on two hosts of two places each, started through A; B joins the domain.
  start_server "$T" "$addr_T" B
  # The pupil reads Spanish: each host is asked to tell its worker (fk_WorkerRequest.language), and
  # the cabs, given no --language, speak it.
  sql "UPDATE pupils SET language = 'es' WHERE id = $pupil" > /dev/null
  sessions=()
  for c in c1 c2 c3 c4; do
    s=$(start "$c" 12)
    [ -n "$s" ] || { fail placement "session on $c did not start: $(tail -3 "$out/A.log")"; continue; }
    sessions+=("$s")
    drive "$c"
  done
  declare -A on_host
  for s in "${sessions[@]}"; do on_host[$s]=$(host_of "$s"); done
  echo "placed: $(for s in "${sessions[@]}"; do printf '%s on %s; ' "$s" "${on_host[$s]}"; done)"
  [ "$(printf '%s\n' "${on_host[@]}" | grep -c '^h1$')" -eq 2 ] && [ "$(printf '%s\n' "${on_host[@]}" | grep -c '^h2$')" -eq 2 ] ||
    fail placement "four sessions were not two on each host: ${on_host[*]}"
  wait_cabs
  for c in c1 c2 c3 c4; do
    grep -q '^sesión s-[0-9]*: ' "$out/cab-$c.log" || fail language "cab $c did not speak its pupil's Spanish: $(tail -2 "$out/cab-$c.log")"
  done
  for s in "${sessions[@]}"; do
    wait_state "$s" ended 30 || fail ingest "session $s is $(session_state "$s"), not ended"
    for _ in $(seq 50); do [ "$(sql "SELECT count(*) FROM scores sc JOIN sessions s ON s.id = sc.session_id WHERE s.public_id = '$s'")" = 1 ] && break; sleep 0.2; done
    h=${on_host[$s]}
    logged=$(grep -c '^e ' "$out/$h/$s.ctl")
    stored=$(sql "SELECT count(*) || ' ' || count(DISTINCT e.seq) || ' ' || coalesce(max(e.seq), 0) FROM events e JOIN sessions s ON s.id = e.session_id WHERE s.public_id = '$s'")
    [ "$stored" = "$logged $logged $logged" ] || fail ingest "session $s: its log on $h has $logged events; the store has (count, distinct, last) $stored"
    marks=$(sql "SELECT count(*) FROM scores sc JOIN sessions s ON s.id = sc.session_id WHERE s.public_id = '$s'")
    [ "$marks" = 1 ] || fail ingest "session $s has $marks marks in the store"
    logged_mark=$(sed -n 's/^score \([^ ]*\) .*/\1/p' "$out/$h/$s.ctl")
    [ -n "$logged_mark" ] || fail ingest "session $s: its host's log has no score line"
    # h2 (--realtime-workers) ran its workers' ticks at real-time priority, h1 not.
    realtime=$(grep -o "the tick ran at [a-z-]* priority" "$out/$h/$s.out" 2>&1)
    [ "$realtime" = "the tick ran at $([ "$h" = h2 ] && echo real-time || echo normal) priority" ] ||
      fail realtime "session $s on $h: the worker's summary says '$realtime'"
  done
  # Each session is its starting server's: B believed none of their samples, A every one.
  [ "$(fleet_says "$addr_T" "f['ingested']['states'] + f['ingested']['events'] + f['ingested']['scores']")" = 0 ] ||
    fail ingest "server B ingested samples of server A's sessions: $(fleet_says "$addr_T" "f['ingested']")"
  [ "$(fleet_says "$addr_S" "f['ingested']['states'] > 0 and f['ingested']['scores'] == 4")" = True ] ||
    fail ingest "server A did not ingest its sessions' states and four scores: $(fleet_says "$addr_S" "f['ingested']")"
  [ "$failed" -eq 0 ] && echo "1: four sessions ran two on each host; every event and mark is in the store once, ingested by A alone; h2's ticks ran real time"

  # 2. A host dies mid-session: its session fails with the reason; the next goes to the other.
  s1=$(start c1 25); drive c1
  s2=$(start c2 25); drive c2
  h1_session=$s1 h2_session=$s2
  [ "$(host_of "$s1")" = h1 ] || { h1_session=$s2 h2_session=$s1; }
  wait_state "$h1_session" running 30 || fail host_dies "session $h1_session never ran"
  ip netns pids "$A" | xargs -r kill -9
  wait_state "$h1_session" failed 15 || fail host_dies "session $h1_session on the dead host is $(session_state "$h1_session")"
  reason=$(sql "SELECT reason FROM sessions WHERE public_id = '$h1_session'")
  [[ "$reason" == *"worker host h1 stopped answering"* ]] || fail host_dies "session $h1_session failed for '$reason', not the dead host"
  wait_hosts 1
  s3=$(start c3 10); drive c3
  [ "$(host_of "$s3")" = h2 ] || fail host_dies "the session after h1 died runs on '$(host_of "$s3")', not h2"
  [ "$(session_state "$h2_session")" != failed ] || fail host_dies "session $h2_session on h2 failed too"
  [ "$failed" -eq 0 ] && echo "2: h1 killed: its session failed ('worker host h1 stopped answering'), the next went to h2"
  wait_cabs
  start_host "$A" h1
  wait_hosts 2

  # 3. Server A stops mid-session; server B, on the same database and domain, takes it over
  # when A's lease (4 s) has run out, and settles it.
  s4=$(start c4 15); drive c4
  wait_state "$s4" running 30 || fail two_servers "session $s4 never ran"
  # B neither follows nor runs it: its live view names the server that does.
  live_B=$(ip netns exec "$C" curl -s -H "Authorization: Bearer $(cat "$out/token")" "http://$addr_T:$port/api/sessions/$s4/live")
  [[ "$live_B" == *"is run by the school's server A"* ]] || fail two_servers "server B's live view of $s4 does not name server A: $live_B"
  kill -TERM "$server_A"; wait "$server_A"
  for _ in $(seq 100); do grep -q "took over session $s4" "$out/B.log" && break; sleep 0.1; done
  grep -q "took over session $s4" "$out/B.log" || fail two_servers "server B never took over $s4: $(grep -v 'GET\|POST' "$out/B.log" | tail -3)"
  # ... and A starts again while the session runs: it is B's now.
  start_server "$S" "$addr_S" A2
  wait_cabs
  wait_state "$s4" ended 30 || fail two_servers "session $s4 is $(session_state "$s4") after server A stopped"
  for _ in $(seq 50); do [ "$(sql "SELECT count(*) FROM scores sc JOIN sessions s ON s.id = sc.session_id WHERE s.public_id = '$s4'")" = 1 ] && break; sleep 0.2; done
  [ "$(sql "SELECT count(*) FROM scores sc JOIN sessions s ON s.id = sc.session_id WHERE s.public_id = '$s4'")" = 1 ] ||
    fail two_servers "session $s4 has no mark after server A stopped"
  grep -q "adopted session $s4" "$out/B.log" || fail two_servers "server B never adopted $s4"
  ! grep -q "adopted session $s4" "$out/A2.log" || fail two_servers "server A, started again, adopted $s4, which B runs"
  ! grep -q "refused" "$out/A2.log" "$out/B.log" || fail two_servers "samples were refused: $(grep -h refused "$out/A2.log" "$out/B.log" | head -3)"
  [ "$failed" -eq 0 ] && echo "3: server A stopped mid-session; server B took over $s4 after A's lease and stored its end and mark; A, started again, left it to B"

  # 5. Clear DDS: no host runs without the operator's word; a server without it believes none.
  rc=0; on "$A" "$bin/forklift-host" --host-id h9 --log-dir "$out/h9" > "$out/h9.log" 2>&1 || rc=$?
  [ "$rc" -eq 2 ] && grep -q -- "--security" "$out/h9.log" || fail clear "forklift-host without --security started (exit $rc): $(cat "$out/h9.log")"
  spawn "$C" "$bin/forklift-server" --db "$out/U.db" --listen "$addr_C:$port" --log-dir "$out/U" --frame-fps 0 2> "$out/U.log" &
  pids+=($!)
  for _ in $(seq 300); do ip netns exec "$C" curl -sf "http://$addr_C:$port/api/health" > /dev/null && break; sleep 0.1; done
  menu_U() { on "$C" "$bin/forklift-menu" --server "http://$addr_C:$port" --token-file "$out/token-U" "$@"; }
  FORKLIFT_PASSWORD=hosts-admin-password menu_U login --user admin > /dev/null || fail clear "no login on server U: $(tail -3 "$out/U.log")"
  pupil_U=$(menu_U pupil-add --name "Clear Pupil" | sed -E 's/^pupil ([0-9]+):.*/\1/')
  forge "$B" status --host-id evil --capacity 100 --seconds 2
  [ "$(fleet_says "$addr_C" "len(f['hosts']), f['hosts_believed'], f['refused_samples']['no_identity'] > 0" "$out/token-U")" = "0 False True" ] ||
    fail clear "server U (no --trust-clear-hosts) lists hosts or counts no refusal: $(fleet "$addr_C" "$out/token-U")"
  s5=$(menu_U start --pupil "$pupil_U" --cab c5 --scenario first_drive_yard --time-limit 12 | sed -n 's/^session \(s-[0-9]*\) started.*/\1/p')
  [ -n "$s5" ] || fail clear "server U started no session with a forged host about: $(tail -3 "$out/U.log")"
  drive c5
  [ "$(fleet_says "$addr_C" "[w['host'] for w in f['workers']]" "$out/token-U")" = "[None]" ] ||
    fail clear "session $s5 on server U is not run by U itself: $(fleet "$addr_C" "$out/token-U")"
  forged_log "$s5" c5 "$out/forged.ctl"
  refused_before=$(fleet_says "$addr_C" "f['refused_samples']['no_identity']" "$out/token-U")
  forge "$B" report --host-id "" --session "$s5" --cab c5 --log "$out/forged.ctl" --seconds 2
  forge "$B" report --host-id h1 --session "$s5" --cab c5 --log "$out/forged.ctl" --seconds 2
  wait_cabs
  for _ in $(seq 100); do [ -s "$out/U/$s5.ctl" ] && grep -q '^score ' "$out/U/$s5.ctl" && break; sleep 0.2; done
  ! grep -q forged "$out/U/$s5.ctl" || fail clear "server U took a forged report's log for its own session $s5"
  logged_mark=$(sed -n 's/^score \([^ ]*\) .*/\1/p' "$out/U/$s5.ctl")
  marks_U() { python3 -c "import sqlite3,sys; print(' '.join(float.hex(m) for (m,) in sqlite3.connect(sys.argv[1]).execute('SELECT mark FROM scores')))" "$out/U.db" 2>&1; }
  for _ in $(seq 50); do [ -n "$(marks_U)" ] && break; sleep 0.2; done
  stored_mark=$(marks_U)
  [ -n "$logged_mark" ] && [ "$(python3 -c "print(float.hex(float.fromhex('$logged_mark')))")" = "$stored_mark" ] ||
    fail clear "session $s5: server U stored mark $stored_mark, its worker logged $logged_mark"
  refused_after=$(fleet_says "$addr_C" "f['refused_samples']['no_identity']" "$out/token-U")
  [ "${refused_after:-0}" -gt "${refused_before:-0}" ] || fail clear "the forged reports were not counted ($refused_before, then $refused_after)"
  for forged in "a status of worker host evil in clear DDS" "a report naming no worker host on session $s5 in clear DDS" \
                "a report of worker host h1 on session $s5 in clear DDS"; do
    grep -q "refused $forged" "$out/U.log" || fail clear "server U's log does not name the refusal of $forged"
  done
  [ "$failed" -eq 0 ] && echo "5: clear DDS: a host without --trust-clear-hosts would not start; server U believed no host, ran $s5 itself, kept its worker's log and mark against two forged reports, each refusal counted"

  # 6. A host agent restarted in place (SIGHUP), then after a crash of the agent alone: it adopts
  # its running worker, and the session ends with its mark.
  FORKLIFT_PASSWORD=hosts-admin-password menu login --user admin > /dev/null  # server A was restarted in 3
  for how in HUP KILL; do
    s6=$(start c1 10); drive c1
    h=$(host_of "$s6")
    wait_state "$s6" running 30 || fail restart "session $s6 never ran"
    agent=$(eval echo "\$agent_$h")
    kill -"$how" "$agent"
    if [ "$how" = KILL ]; then
      ns=$A; [ "$h" = h2 ] && ns=$B
      start_host "$ns" "$h"
    fi
    wait_cabs
    wait_state "$s6" ended 30 || fail restart "session $s6 on $h is $(session_state "$s6") after its agent's SIG$how: $(sql "SELECT reason FROM sessions WHERE public_id = '$s6'")"
    for _ in $(seq 50); do [ "$(sql "SELECT count(*) FROM scores sc JOIN sessions s ON s.id = sc.session_id WHERE s.public_id = '$s6'")" = 1 ] && break; sleep 0.2; done
    [ "$(sql "SELECT count(*) FROM scores sc JOIN sessions s ON s.id = sc.session_id WHERE s.public_id = '$s6'")" = 1 ] ||
      fail restart "session $s6 has no mark after its agent's SIG$how"
    grep -q "adopted the worker (pid [0-9]*) of session $s6" "$out/$h.log" || fail restart "host $h never adopted $s6 after SIG$how"
  done
  [ "$failed" -eq 0 ] && echo "6: a host agent restarted in place (SIGHUP) and after SIGKILL adopted its running worker; both sessions ended with their marks"

  # 7. A host that takes starts and never answers (here a believed one, as --trust-clear-hosts
  # believes any): passed over within the start's budget, the session placed on a real host.
  forge "$B" status --host-id silent --capacity 100 --seconds 8 &
  silent_forger=$!
  for _ in $(seq 50); do [ "$(fleet_says "$addr_S" "any(h['id'] == 'silent' and h['alive'] for h in f['hosts'])")" = True ] && break; sleep 0.1; done
  s8=$(start c2 8)
  h8=$(host_of "$s8")
  [ -n "$s8" ] && [[ "$h8" =~ ^h[12]$ ]] || fail silent_host "session '$s8' was not placed on a real host past the silent one: $(tail -3 "$out/A2.log")"
  [ "$(fleet_says "$addr_S" "next(h['passed_over_s'] > 0 for h in f['hosts'] if h['id'] == 'silent')")" = True ] ||
    fail silent_host "the silent host is not passed over: $(fleet "$addr_S")"
  drive c2
  wait_cabs
  wait "$silent_forger"
  [ "$failed" -eq 0 ] && echo "7: a host that took the start and stayed silent was passed over; $s8 ran on $h8"
else
  # 4. DDS Security: cab c1's identity drives c1; with it, cab c2's worker hears nothing.
  s1=$(start c1 12); drive c1
  s2=$(start c2 12)
  drive c2 cab.c1  # c1's identity claiming to be cab c2
  wait_cabs
  wait_state "$s1" ended 30 || fail security "session $s1 (its own cab) is $(session_state "$s1")"
  h=$(ls "$out"/h1/"$s2".ctl "$out"/h2/"$s2".ctl 2>/dev/null | head -1)
  accepted=$(sed -n 's/^controls accepted=\([0-9]*\).*/\1/p' "$h")
  [ "${accepted:-0}" = 0 ] || fail security "cab c2's worker applied $accepted controls sent under cab c1's identity"
  wait_state "$s2" "ended|failed" 60 || fail security "session $s2 is $(session_state "$s2")"
  # An exam on a host: its signed log comes back with the host's report and is chained.
  exam=$(menu start --pupil "$pupil" --cab c3 --scenario counterbalance_exam --mode exam --time-limit 10 |
         sed -n 's/^session \(s-[0-9]*\) started.*/\1/p')
  [ -n "$exam" ] || fail security "the exam did not start: $(tail -3 "$out/A.log")"
  script=$data/evaluation/scripts/counterbalance_exam_clean.csv drive c3
  wait_cabs
  wait_state "$exam" "ended" 30 || fail security "exam $exam is $(session_state "$exam")"
  for _ in $(seq 80); do
    rc=0
    menu verify "$exam" > "$out/verify.txt" 2>&1 || rc=$?
    [ "$rc" -ne 2 ] && [ "$rc" -ne 4 ] && break
    sleep 0.25
  done
  [ "$rc" -eq 0 ] || fail security "exam $exam on host $(grep -l "$exam" "$out"/h*.log | head -1) does not verify (exit $rc): $(cat "$out/verify.txt")"
  [ "$failed" -eq 0 ] && echo "4: with DDS Security cab c1 drove its own worker; under its identity, cab c2's worker heard no control; an exam on a host verifies"

  # 5. A peer without an identity: a status, a kill and a start reach nobody. A host's identity
  # ships a log that is not signed by the session's worker: refused with the reason.
  s7=$(start c1 12); drive c1
  wait_state "$s7" running 30 || fail security "session $s7 never ran"
  h=$(host_of "$s7")
  started_before=$(grep -c "started the worker" "$out"/h1.log "$out"/h2.log | awk -F: '{s += $2} END {print s}')
  forgers=()
  (FORKLIFT_SECURITY_DIR= forge "$C" status --host-id evil --capacity 100 --seconds 2) & forgers+=($!)
  (FORKLIFT_SECURITY_DIR= forge "$C" request --host-id "$h" --session "$s7" --cab c1 --action kill --seconds 2) & forgers+=($!)
  (FORKLIFT_SECURITY_DIR= forge "$C" request --host-id h2 --session s-999999 --cab c4 --action start --seconds 2) & forgers+=($!)
  forged_log "$s7" c1 "$out/forged.ctl"
  forge "$C" --security "$pki" --identity "host.$h" report --host-id "$h" --session "$s7" --cab c1 --log "$out/forged.ctl" \
    --sign-as "host.$h" --seconds 2
  wait "${forgers[@]}"
  wait_cabs
  wait_state "$s7" ended 30 || fail security "session $s7 is $(session_state "$s7") after the forgeries: $(sql "SELECT reason FROM sessions WHERE public_id = '$s7'")"
  [ "$(fleet_says "$addr_S" "[h['id'] for h in f['hosts'] if h['id'] == 'evil']")" = "[]" ] || fail security "a host without an identity is listed"
  started_after=$(grep -c "started the worker" "$out"/h1.log "$out"/h2.log | awk -F: '{s += $2} END {print s}')
  [ "$started_after" -eq "$((started_before))" ] || fail security "a start from a peer without an identity launched a worker"
  grep -q "refused host $h's report that session $s7's worker exited: its session log is not signed by cab c1's worker" "$out/A.log" ||
    fail security "server A did not refuse host $h's log signed as host.$h: $(grep -h "$s7" "$out/A.log" | tail -3)"
  [ "$(fleet_says "$addr_S" "f['refused_samples']['unsigned_log'] >= 1")" = True ] || fail security "the unsigned log was not counted"
  for _ in $(seq 50); do [ "$(sql "SELECT count(*) FROM scores sc JOIN sessions s ON s.id = sc.session_id WHERE s.public_id = '$s7'")" = 1 ] && break; sleep 0.2; done
  stored=$(sql "SELECT sc.mark FROM scores sc JOIN sessions s ON s.id = sc.session_id WHERE s.public_id = '$s7'")
  logged=$(sed -n 's/^score \([^ ]*\) .*/\1/p' "$out/$h/$s7.ctl")
  [ -n "$logged" ] && [ "$(python3 -c "print(float.fromhex('$logged') == float('${stored:-nan}'))")" = True ] ||
    fail security "session $s7 stored mark '$stored'; its worker logged $logged"
  [ "$failed" -eq 0 ] && echo "5: with DDS Security a peer without an identity placed, stopped and started nothing; host $h's log signed as host.$h was refused; $s7 kept its worker's mark"
fi

[ "$failed" -eq 0 ] && echo "worker_hosts${secure:+ $secure}: passed"
exit "$failed"
