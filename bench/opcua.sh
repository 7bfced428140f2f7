#!/usr/bin/env bash
# OPC UA server figures beside the Modbus server's, in the same run and the same PLC
# (bench/opcua/plc.conf, release): reads of ten points per request with 1 and 10 clients
# (crates/io/opcua/examples/opcua_load.rs: async-opcua's client, one session per client,
# requests back to back; crates/io/modbus/examples/modbus_load.rs: FC 3 of ten registers, one
# connection per client), and the subscription latency from the scan that changes a point to
# the client's notification (source timestamp to arrival, same clock). Runs are interleaved
# (Modbus, OPC UA, Modbus, ...) so machine noise hits both; medians over RUNS runs.
#
#   bash bench/opcua.sh            # 3 runs x 5 s per protocol and client count (about 2 min)
#   bash bench/opcua.sh --quick    # 3 runs x 1 s
#   RUNS=5 CLIENTS="1 4 10" bash bench/opcua.sh
set -euo pipefail
cd "$(dirname "$0")/.."

RUNS=${RUNS:-3}
CLIENTS=${CLIENTS:-"1 10"}
SECONDS_PER_RUN=5
for arg in "$@"; do
  case "$arg" in
    --quick) SECONDS_PER_RUN=1 ;;
    *) echo "usage: [RUNS=n] [CLIENTS=\"1 10\"] bash bench/opcua.sh [--quick]" >&2; exit 2 ;;
  esac
done

target=$(cargo metadata --format-version 1 --no-deps | python3 -c 'import json,sys; print(json.load(sys.stdin)["target_directory"])')
petriplc="$target/release/petriplc"
mbload="$target/release/examples/modbus_load"
uaload="$target/release/examples/opcua_load"
work=$(mktemp -d)
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

echo "== building petriplc and the load generators (release)" >&2
cargo build --release --quiet -p petriplc
cargo build --release --quiet -p petriplc-modbus --example modbus_load
cargo build --release --quiet -p petriplc-opcua --example opcua_load

free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }
wait_port() { # PORT: until something accepts there (10 s at most)
  for _ in $(seq 100); do
    if python3 -c "import socket,sys; socket.create_connection(('127.0.0.1',$1),0.2)" 2>/dev/null; then return 0; fi
    sleep 0.1
  done
  echo "nothing listens on port $1" >&2; return 1
}

id="bench-opcua-$$"
mb_port=$(free_port)
ua_port=$(free_port)
"$petriplc" run bench/opcua/plc.conf --plc-id "$id" --set "mb:listen=127.0.0.1:$mb_port" \
  --set "opcua:listen=127.0.0.1:$ua_port" --log-level warn >"$work/plc.log" 2>&1 &
pids+=($!)
wait_port "$mb_port"
wait_port "$ua_port"
url="opc.tcp://127.0.0.1:$ua_port/"
ns="urn:petriplc:$id"
nodes="h0 h1 h2 h3 h4 h5 h6 h7 h8 h9"

fields() { sed -n 's/.*req_per_s=\([0-9.]*\) p50_us=\([0-9.]*\) p99_us=\([0-9.]*\).*/\1 \2 \3/p'; }
fail() { echo "$1 failed" >&2; cat "$work/plc.log" >&2; exit 1; }
median() { sort -g | awk '{v[NR]=$1} END {print v[int((NR+1)/2)]}'; }

for c in $CLIENTS; do
  : >"$work/m$c"; : >"$work/u$c"
  for i in $(seq "$RUNS"); do
    echo "== $c client(s), run $i/$RUNS: Modbus, then OPC UA (${SECONDS_PER_RUN} s each)" >&2
    { "$mbload" "127.0.0.1:$mb_port" "$c" "$SECONDS_PER_RUN" 10 || fail modbus_load; } | fields >>"$work/m$c"
    # shellcheck disable=SC2086
    { "$uaload" read "$url" "$ns" "$c" "$SECONDS_PER_RUN" $nodes || fail opcua_load; } | fields >>"$work/u$c"
  done
done
: >"$work/sub"
for i in $(seq "$RUNS"); do
  echo "== subscription latency, run $i/$RUNS (4 s)" >&2
  { "$uaload" sub "$url" "$ns" 4 toggle || fail "opcua_load sub"; } |
    sed -n 's/.*notifications=\([0-9]*\).* p50_us=\([0-9.]*\) p99_us=\([0-9.]*\).*/\1 \2 \3/p' >>"$work/sub"
done

echo
echo "$(nproc) cores, reads of 10 points per request (OPC UA Read of 10 nodes, Modbus FC 3 of 10" \
  "registers), one PLC serving both, ${SECONDS_PER_RUN} s per run, $RUNS runs each, medians;" \
  "$(uname -r); $(date -u +%Y-%m-%d)"
echo
echo "| clients | server | requests/s | p50 µs | p99 µs |"
echo "|---:|---|---:|---:|---:|"
for c in $CLIENTS; do
  for s in m u; do
    name=$([ $s = m ] && echo "petriplc modbus_server" || echo "petriplc opcua_server")
    echo "| $c | $name | $(cut -d' ' -f1 "$work/$s$c" | median) | $(cut -d' ' -f2 "$work/$s$c" | median) | $(cut -d' ' -f3 "$work/$s$c" | median) |"
  done
done
echo
echo "Subscription latency (scan that changed \`toggle\` -> client notification; 10 ms scan," \
  "10 ms publishing interval, sampling 0): notifications per run $(cut -d' ' -f1 "$work/sub" | median)," \
  "p50 $(cut -d' ' -f2 "$work/sub" | median) µs, p99 $(cut -d' ' -f3 "$work/sub" | median) µs (medians of $RUNS runs)"
