#!/usr/bin/env bash
# Where the Modbus TCP server spends its time with 16 clients: `perf record` of the PLC running
# bench/modbus/plc.conf while crates/io/modbus/examples/modbus_load keeps 16 connections busy,
# then a summary of the profile (self time by symbol, and the callers of the top ones).
# Writes OUT (default out/modbus-profile.txt); the summary of the figures in docs/modbus.md
# and docs/performance.md is bench/modbus/profile-16-clients.txt.
#
#   bash bench/modbus/profile.sh                 # the default: threads = 1
#   THREADS=2 OUT=out/modbus-profile-2.txt bash bench/modbus/profile.sh
set -euo pipefail
cd "$(dirname "$0")/../.."

THREADS=${THREADS:-1}
OUT=${OUT:-out/modbus-profile.txt}
PERF=${PERF:-perf}
command -v "$PERF" >/dev/null || { echo "perf is needed (PERF=/path/to/perf)" >&2; exit 3; }
target=$(cargo metadata --format-version 1 --no-deps | python3 -c 'import json,sys; print(json.load(sys.stdin)["target_directory"])')
cargo build --release --quiet -p petriplc
cargo build --release --quiet -p petriplc-modbus --example modbus_load
work=$(mktemp -d)
plc=""
cleanup() { [ -z "$plc" ] || kill -INT "$plc" 2>/dev/null || true; wait 2>/dev/null || true; rm -rf "$work"; }
trap cleanup EXIT
port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
"$target/release/petriplc" run bench/modbus/plc.conf --plc-id "modbus-profile-$$" \
  --set "mb:listen=127.0.0.1:$port" --set "mb:threads=$THREADS" --log-level warn >"$work/plc.log" 2>&1 &
plc=$!
for _ in $(seq 100); do
  python3 -c "import socket; socket.create_connection(('127.0.0.1',$port),0.2)" 2>/dev/null && break
  sleep 0.1
done
"$target/release/examples/modbus_load" "127.0.0.1:$port" 16 6 10 >"$work/load.txt" &
load=$!
sleep 1
"$PERF" record -q -F 999 -g -p "$plc" -o "$work/perf.data" -- sleep 4 >/dev/null 2>&1
wait "$load"
mkdir -p "$(dirname "$OUT")"
{
  echo "# modbus_server, threads = $THREADS, 16 clients, FC 3 x 10 registers; $(nproc) cores;" \
    "load $(cut -d' ' -f1-3 /proc/loadavg); $(uname -r); $(date -u +%Y-%m-%dT%H:%MZ)"
  echo "# load generator: $(cat "$work/load.txt")"
  echo
  echo "## self time by symbol (top 25)"
  "$PERF" report -i "$work/perf.data" --no-children --sort symbol -g none --stdio 2>/dev/null \
    | grep -E '^ +[0-9.]+%' | head -25 || true
  echo
  echo "## time including callees, by symbol (top 40)"
  "$PERF" report -i "$work/perf.data" --children --sort symbol -g none --stdio 2>/dev/null \
    | grep -E '^ +[0-9.]+%' | head -40 || true
  echo
  echo "## user space: the event loop (mio), io_uring, the server's code, locks, allocation (including callees)"
  "$PERF" report -i "$work/perf.data" --children --sort symbol -g none --stdio 2>/dev/null \
    | grep -E '^ +[0-9.]+%' | grep -iE 'mio|uring|petriplc|mutex|futex|malloc|free|epoll' | head -20 || true
} >"$OUT"
echo "profile summary: $OUT"
