#!/usr/bin/env bash
# The worker-host figures for several machines, measured on one: forklift-bench-dds run twice in the
# same sitting, once with the worker beside the cab over loopback, once with the worker in another
# network namespace (a simulation PC) reached over a veth pair with protocol/config/lan.xml, as a
# cab station reaches its school's simulation PC. The worker is started through a wrapper that
# runs it in the other namespace, so the bench measures the same thing both times: control to
# applied state round trip (p50, p99), the frames delivered, and a framed fleet. A third run splits
# the framed fleet over two such simulation PCs (two worker hosts), alternating cab by cab.
#
#   build/tests/forklift-test-alloc bench/hosts.sh [--samples N] [--framed N]    (as root; needs iproute2)
#
# Both "machines" share this box's cores: the figures compare the network paths, not capacity.
set -uo pipefail
cd "$(dirname "$0")/.."
samples=1000 framed=4
while [ $# -gt 0 ]; do
  case "$1" in
    --samples) samples=$2; shift 2 ;;
    --framed) framed=$2; shift 2 ;;
    -h|--help) sed -n '2,11p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "hosts.sh: unknown option '$1' (--samples N, --framed N)" >&2; exit 2 ;;
  esac
done
domain=${FORKLIFT_TEST_DOMAIN:?run it through build/tests/forklift-test-alloc}
bin=$PWD/build/bin configs=$PWD/protocol/config
[ -x "$bin/forklift-bench-dds" ] || { echo "hosts.sh: build first (scripts/build.sh)" >&2; exit 2; }
W=fk${domain}bw V=fk${domain}bv C=fk${domain}bc
work=$(mktemp -d "${TMPDIR:-/tmp}/forklift-hosts-bench.XXXXXX")
cleanup() {
  for ns in "$W" "$V" "$C"; do ip netns pids "$ns" 2>/dev/null | xargs -r kill -9 2>/dev/null; ip netns del "$ns" 2>/dev/null; done
  rm -rf "$work"
}
trap cleanup EXIT
ip netns add "$W" 2>/dev/null && ip netns add "$V" && ip netns add "$C" || { echo "hosts.sh: cannot make network namespaces (root and iproute2 needed)" >&2; exit 2; }
net=10.79.$domain
# C holds a bridge; each simulation PC a veth pair to it.
ip -n "$C" link add "${C}br" type bridge
ip -n "$C" link set "${C}br" type bridge mcast_snooping 0
ip -n "$C" addr add "$net.1/24" dev "${C}br"
ip -n "$C" link set lo up
ip -n "$C" link set "${C}br" up
n=2
for ns in "$W" "$V"; do
  ip link add "${ns}0" netns "$ns" type veth peer name "${ns}p" netns "$C"
  ip -n "$C" link set "${ns}p" master "${C}br" up
  ip -n "$ns" addr add "$net.$n/24" dev "${ns}0"
  ip -n "$ns" link set lo up
  ip -n "$ns" link set "${ns}0" up
  n=$((n + 1))
done

# The worker "on the simulation PC": the bench's --bin-dir holds this wrapper.
mkdir -p "$work/remote-bin"
cat > "$work/remote-bin/forklift-worker" <<EOF
#!/bin/sh
exec ip netns exec $W env CYCLONEDDS_URI=file://$configs/lan.xml FORKLIFT_DDS_INTERFACE=${W}0 $bin/forklift-worker "\$@"
EOF
chmod +x "$work/remote-bin/forklift-worker"
# Two simulation PCs: a framed fleet's cab f<n>-<k> goes to W for odd k, to V for even.
mkdir -p "$work/split-bin"
cat > "$work/split-bin/forklift-worker" <<EOF
#!/bin/sh
ns=$W
prev=
for a in "\$@"; do
  if [ "\$prev" = --cab ]; then case "\$a" in *[02468]) ns=$V ;; esac; fi
  prev=\$a
done
exec ip netns exec \$ns env CYCLONEDDS_URI=file://$configs/lan.xml FORKLIFT_DDS_INTERFACE=\${ns}0 $bin/forklift-worker "\$@"
EOF
chmod +x "$work/split-bin/forklift-worker"

run() {  # NAME BENCH_ENV BIN_DIR [OPTION]: the bench in C
  ip netns exec "$C" env $2 "$bin/forklift-bench-dds" --samples "$samples" --fleet 1 --frame-sizes 640x480 \
    --framed-fleet "$framed" --seconds 5 --dds-domain "$domain" --dir "$work/$1" --bin-dir "$3" ${4:-} > "$work/$1.out" 2> "$work/$1.err"
  grep -P '^FIGURE\t' "$work/$1.out" | cut -f2,4 > "$work/$1.figures"
}
echo "hosts.sh: loopback (worker beside the cab)" >&2
run loopback "FORKLIFT_UNUSED=1" "$bin"
echo "hosts.sh: across namespaces (worker on the simulation PC, lan.xml over a veth pair)" >&2
run across "CYCLONEDDS_URI=file://$configs/lan.xml FORKLIFT_DDS_INTERFACE=${C}br" "$work/remote-bin"
echo "hosts.sh: the framed fleet on two simulation PCs" >&2
run split "CYCLONEDDS_URI=file://$configs/lan.xml FORKLIFT_DDS_INTERFACE=${C}br" "$work/split-bin" --framed-only

echo "Measured by \`bench/hosts.sh --samples $samples --framed $framed\` on $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg), $(date -u +%Y-%m-%d)."
echo
echo "| figure | loopback | worker on a simulation PC (lan.xml) | framed fleet over two simulation PCs |"
echo "|---|---|---|---|"
join -t $'\t' -a 1 -e '-' -o 0,1.2,2.2 <(sort "$work/loopback.figures") <(sort "$work/across.figures") |
  join -t $'\t' -a 1 -e '-' -o 0,1.2,1.3,2.2 - <(sort "$work/split.figures") |
  awk -F'\t' '{printf "| %s | %s | %s | %s |\n", $1, $2, $3, $4}'
grep -q . "$work/across.figures" || { echo "hosts.sh: the run across namespaces printed no figures:" >&2; tail -5 "$work/across.err" >&2; exit 1; }
