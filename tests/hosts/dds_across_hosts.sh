#!/usr/bin/env bash
# DDS across machines: two network namespaces joined by a veth pair stand for
# a simulation PC and a cab station on their own network, with nothing else on it. A real worker
# in one and a real scripted cab in the other drive a session under each shipped network
# configuration: lan.xml (multicast discovery, the interface by name), lan-unicast.xml and
# routed.xml (no multicast, the interface by network address, the other machine as the peer).
# Each must discover the other, the worker apply the cab's controls and the cab hear the states
# and the session's end. The namespaces' names and addresses come from the test's DDS domain
# (forklift-test-alloc), so that parallel runs never meet; they are removed however it ends.
#
#   BUILD/tests/forklift-test-alloc tests/hosts/dds_across_hosts.sh BUILD/bin data protocol/config OUT
#
# Exit 77 (ctest: skipped, never passed) where namespaces cannot be made (not root, no iproute2).
set -uo pipefail
bin=$1 data=$2 configs=$3 out=$4
domain=${FORKLIFT_TEST_DOMAIN:?run it through forklift-test-alloc}
rm -rf "$out" && mkdir -p "$out"

W=fk${domain}w C=fk${domain}c
if [ "$(id -u)" -ne 0 ] || ! command -v ip >/dev/null || ! ip netns add "$W" 2>"$out/netns.err"; then
  echo "dds_across_hosts: SKIPPED: this machine cannot make network namespaces ($(cat "$out/netns.err" 2>/dev/null))"
  exit 77
fi
cleanup() { ip netns del "$W" 2>/dev/null; ip netns del "$C" 2>/dev/null; }
trap cleanup EXIT
ip netns add "$C"
net=10.77.$domain
ip link add "${W}0" netns "$W" type veth peer name "${C}0" netns "$C"
ip -n "$W" addr add "$net.1/24" dev "${W}0"
ip -n "$C" addr add "$net.2/24" dev "${C}0"
for ns in "$W" "$C"; do ip -n "$ns" link set lo up; done
ip -n "$W" link set "${W}0" up
ip -n "$C" link set "${C}0" up

failed=0
fail() { echo "FAILED ($1): $2"; failed=1; }

# drive CONFIG WORKER_ENV CAB_ENV: one session on cab "hostcab", 3 s of sim time.
drive() {
  local cfg=$1 wenv=$2 cenv=$3 session=h-$1
  ip netns exec "$W" env $wenv "$bin/forklift-worker" --cab hostcab --session "$session" \
    --scenario "$data/manoeuvres/manoeuvre_4.json" --dds-domain "$domain" --dds-config "$configs/$cfg.xml" \
    --log "$out/$cfg.ctl" --duration 3 --start-timeout 60 >"$out/$cfg-worker.log" 2>&1 &
  local worker=$!
  ip netns exec "$C" env $cenv "$bin/forklift-cab" --cab hostcab --script "$data/manoeuvres/manoeuvre_4.csv" \
    --dds-domain "$domain" --dds-config "$configs/$cfg.xml" --wait-worker 60 --no-window --no-sound >"$out/$cfg-cab.log" 2>&1
  local cab_rc=$?
  wait "$worker"
  local worker_rc=$?
  [ "$worker_rc" -eq 0 ] || fail "$cfg" "the worker exited $worker_rc: $(tail -3 "$out/$cfg-worker.log")"
  [ "$cab_rc" -eq 0 ] || fail "$cfg" "the cab exited $cab_rc: $(tail -3 "$out/$cfg-cab.log")"
  local accepted
  accepted=$(sed -n 's/^controls accepted=\([0-9]*\).*/\1/p' "$out/$cfg.ctl")
  [ "${accepted:-0}" -gt 100 ] || fail "$cfg" "the worker applied ${accepted:-no} controls from the other machine"
  grep -q "session $session: Session over: the session's time has run" "$out/$cfg-cab.log" || fail "$cfg" "the cab never heard the session end"
  # The cab's line comes about once a second of its own clock: any line from 1 s of sim time on shows that
  # states came from the other machine, however busy this one is.
  grep -Eq "^t= *[1-9][0-9]*\.[0-9] s" "$out/$cfg-cab.log" || fail "$cfg" "the cab never showed the truck's state after 1 s"
  [ "$failed" -eq 0 ] && echo "$cfg: the worker applied $accepted controls sent from the other machine; the cab heard its states and the end"
}

drive lan "FORKLIFT_DDS_INTERFACE=${W}0" "FORKLIFT_DDS_INTERFACE=${C}0"
drive lan-unicast "FORKLIFT_DDS_NETWORK=$net.0 FORKLIFT_DDS_PEER=$net.2" "FORKLIFT_DDS_NETWORK=$net.0 FORKLIFT_DDS_PEER=$net.1"
# routed: only the cab names its peer (a test centre knows its school's address, not the reverse).
drive routed "FORKLIFT_DDS_NETWORK=$net.0 FORKLIFT_DDS_PEER=$net.1" "FORKLIFT_DDS_NETWORK=$net.0 FORKLIFT_DDS_PEER=$net.1"

# A shipped configuration without its interface: refused in words, not by Cyclone.
ip netns exec "$W" "$bin/forklift-worker" --cab hostcab --session h-bad --dds-domain "$domain" \
  --dds-config "$configs/lan.xml" --duration 1 >"$out/unset.log" 2>&1
rc=$?
{ [ "$rc" -ne 0 ] && grep -q "FORKLIFT_DDS_INTERFACE" "$out/unset.log"; } ||
  fail unset "a missing FORKLIFT_DDS_INTERFACE was not named (exit $rc): $(tail -2 "$out/unset.log")"

# Nothing of it reached this machine's own network: the namespaces have no other link.
[ "$(ip -n "$W" -o link show | wc -l)" -eq 2 ] || fail isolation "the worker's namespace has another link"

[ "$failed" -eq 0 ] && echo "dds_across_hosts: passed"
exit "$failed"
