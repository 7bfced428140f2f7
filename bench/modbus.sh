#!/usr/bin/env bash
# Modbus TCP server throughput and latency: petriplc's modbus_server module (a PLC running
# bench/modbus/plc.conf, release) against the libmodbus server
# testdata/anchors/modbus_server.c (cc -O2), in the same run. A load generator
# (crates/io/modbus/examples/modbus_load.rs: one blocking connection per client, requests back to
# back) reads 10 holding registers with 1 and with 16 concurrent clients. Runs are interleaved
# (anchor, petriplc, anchor, ...) so machine noise hits both; the table shows medians over RUNS
# runs, and the ratios petriplc/anchor of throughput and p99 latency against the goals (16
# clients: throughput >= 1.2x, p99 <= 1x).
#
#   bash bench/modbus.sh            # 3 runs x 5 s per server and client count (about 2 min)
#   bash bench/modbus.sh --quick    # 3 runs x 1 s
#   RUNS=5 CLIENTS="1 4 16" bash bench/modbus.sh
#
# Needs libmodbus-dev (installed here when missing) and a C compiler.
set -euo pipefail
cd "$(dirname "$0")/.."

RUNS=${RUNS:-3}
CLIENTS=${CLIENTS:-"1 16"}
SECONDS_PER_RUN=5
ANCHORS=testdata/anchors
for arg in "$@"; do
  case "$arg" in
    --quick) SECONDS_PER_RUN=1 ;;
    *) echo "usage: [RUNS=n] [CLIENTS=\"1 16\"] bash bench/modbus.sh [--quick]" >&2; exit 2 ;;
  esac
done

as_root() { if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi; }
if ! pkg-config --exists libmodbus; then
  echo "== installing libmodbus-dev (the anchor's library)" >&2
  as_root apt-get update -qq
  as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libmodbus-dev >/dev/null
fi

target=$(cargo metadata --format-version 1 --no-deps | python3 -c 'import json,sys; print(json.load(sys.stdin)["target_directory"])')
anchor="$target/modbus-anchor"
load="$target/release/examples/modbus_load"
petriplc="$target/release/petriplc"
work=$(mktemp -d)
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

echo "== building the anchor (cc -O2) and petriplc (release)" >&2
mkdir -p "$target"
# shellcheck disable=SC2046
cc -O2 -o "$anchor" "$ANCHORS/modbus_server.c" $(pkg-config --cflags --libs libmodbus)
cargo build --release --quiet -p petriplc
cargo build --release --quiet -p petriplc-modbus --example modbus_load

free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }
wait_port() { # PORT: until something accepts there (10 s at most)
  for _ in $(seq 100); do
    if python3 -c "import socket,sys; socket.create_connection(('127.0.0.1',$1),0.2)" 2>/dev/null; then return 0; fi
    sleep 0.1
  done
  echo "nothing listens on port $1" >&2; return 1
}

anchor_port=$(free_port)
"$anchor" "$anchor_port" >"$work/anchor.log" 2>&1 &
pids+=($!)
ours_port=$(free_port)
"$petriplc" run bench/modbus/plc.conf --plc-id "bench-modbus-$$" \
  --set "mb:listen=127.0.0.1:$ours_port" --log-level warn >"$work/plc.log" 2>&1 &
pids+=($!)
wait_port "$anchor_port"
wait_port "$ours_port"

# run PORT CLIENTS: prints "req_per_s p50 p99" of one run.
run() {
  local out
  out=$("$load" "127.0.0.1:$1" "$2" "$SECONDS_PER_RUN" 10) || { echo "load generator failed" >&2; cat "$work/plc.log" >&2; exit 1; }
  echo "$out" | sed -n 's/.*req_per_s=\([0-9.]*\) p50_us=\([0-9.]*\) p99_us=\([0-9.]*\).*/\1 \2 \3/p'
}
median() { sort -g | awk '{v[NR]=$1} END {print v[int((NR+1)/2)]}'; }

for c in $CLIENTS; do
  : >"$work/a$c"; : >"$work/p$c"
  for i in $(seq "$RUNS"); do
    echo "== $c client(s), run $i/$RUNS: anchor, then petriplc (${SECONDS_PER_RUN} s each)" >&2
    run "$anchor_port" "$c" >>"$work/a$c"
    run "$ours_port" "$c" >>"$work/p$c"
  done
done

echo
echo "$(nproc) cores, FC 3 reading 10 holding registers, ${SECONDS_PER_RUN} s per run, $RUNS runs each," \
  "medians; $(uname -r); $(date -u +%Y-%m-%d)"
echo
echo "| clients | server | requests/s | p50 µs | p99 µs |"
echo "|---:|---|---:|---:|---:|"
for c in $CLIENTS; do
  for s in a p; do
    name=$([ $s = a ] && echo "libmodbus (modbus_server.c)" || echo "petriplc modbus_server")
    echo "| $c | $name | $(cut -d' ' -f1 "$work/$s$c" | median) | $(cut -d' ' -f2 "$work/$s$c" | median) | $(cut -d' ' -f3 "$work/$s$c" | median) |"
  done
done
echo
for c in $CLIENTS; do
  a=$(cut -d' ' -f1 "$work/a$c" | median); p=$(cut -d' ' -f1 "$work/p$c" | median)
  a99=$(cut -d' ' -f3 "$work/a$c" | median); p99=$(cut -d' ' -f3 "$work/p$c" | median)
  awk -v a="$a" -v p="$p" -v a99="$a99" -v p99="$p99" -v c="$c" 'BEGIN {
    r = (a > 0) ? p / a : 0; q = (a99 > 0) ? p99 / a99 : 0
    # The issue'"'"'s goals are for 16 clients; with fewer, petriplc should not be slower.
    g = (c >= 16) ? 1.2 : 1
    printf "%s client(s): throughput ratio petriplc/libmodbus **%.2f** (goal >= %g: %s), p99 ratio **%.2f** (goal <= 1: %s)\n",
      c, r, g, (r >= g ? "met" : "NOT met"), q, (q <= 1 ? "met" : "NOT met") }'
done
