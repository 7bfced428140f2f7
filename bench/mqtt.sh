#!/usr/bin/env bash
# MQTT figures (release build, Debian's mosquitto on a free loopback port):
#
# 1. End-to-end latency PLC A -> PLC B: two `petriplc run` processes (bench/mqtt/a.conf,
#    b.conf; every module at 1 ms). A's timeline sets X; A publishes a/X; B takes it into Y
#    and publishes b/Y back in the same scan; A takes it into Z. A's logger records when X
#    and Z changed, on one clock: one way = (Z - X) / 2, which includes a scan of each
#    side's mqtt module (up to 1 ms each) and the logger's.
# 2. Sustained changes: one PLC whose timeline gives K points a new value every 1 ms for 5 s
#    (a counter, so every scan of the mqtt module sees each point change), all published. The
#    module's status counts what it published and what it coalesced (a change overwritten
#    before the network sent it: the broker slower than the changes); its cycle time and
#    overruns show when its scan suffers. Sustained = the highest rate of changes seen by the
#    scan with under 1% coalesced and the module's mean cycle under 10% of its 1 ms scan.
#
#   bash bench/mqtt.sh            # 3 latency runs x 8 s, K = 1 10 100 400 (about 1.5 min)
#   RUNS=5 K="1 100" bash bench/mqtt.sh
set -euo pipefail
cd "$(dirname "$0")/.."

RUNS=${RUNS:-3}
K=${K:-"1 10 100 400"}
for arg in "$@"; do
  echo "usage: [RUNS=n] [K=\"1 10 100\"] bash bench/mqtt.sh ($arg?)" >&2; exit 2
done

target=$(cargo metadata --format-version 1 --no-deps | python3 -c 'import json,sys; print(json.load(sys.stdin)["target_directory"])')
petriplc="$target/release/petriplc"
work=$(mktemp -d)
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

echo "== building petriplc (release)" >&2
cargo build --release --quiet -p petriplc
command -v mosquitto >/dev/null || PATH="$PATH:/usr/sbin"
command -v mosquitto >/dev/null || { echo "needs Debian's mosquitto (apt-get install mosquitto)" >&2; exit 1; }

port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
user=""; [ "$(id -u)" -eq 0 ] && user="user root"
printf '%s\nlistener %s 127.0.0.1\nset_tcp_nodelay true\nallow_anonymous true\npersistence false\nlog_dest none\n' "$user" "$port" >"$work/mosquitto.conf"
mosquitto -c "$work/mosquitto.conf" &
pids+=($!)
for _ in $(seq 50); do python3 -c "import socket; socket.create_connection(('127.0.0.1',$port),0.2)" 2>/dev/null && break; sleep 0.1; done
broker="mqtt:broker=127.0.0.1:$port"

: >"$work/lat"
for i in $(seq "$RUNS"); do
  echo "== latency run $i/$RUNS (8 s)" >&2
  "$petriplc" run bench/mqtt/b.conf --plc-id "bench-b-$$" --for 9s --set "$broker" --log-level warn 2>"$work/b.err" &
  b=$!
  sleep 0.5
  "$petriplc" run bench/mqtt/a.conf --plc-id "bench-a-$$" --for 8s --set "$broker" \
    --set "log:file=$work/a$i.csv" --log-level warn 2>"$work/a.err" || { cat "$work/a.err" >&2; exit 1; }
  wait "$b"
  # X rows and the Z rows that echo them: one way = half the round trip, in µs.
  python3 - "$work/a$i.csv" >>"$work/lat" <<'PY'
import csv, sys
sent = {}
for row in csv.DictReader(open(sys.argv[1])):
    t, p, v = float(row["time"]), row["point"], row["value"]
    if p == "X":
        sent[v] = t
    elif p == "Z" and v in sent:
        print((t - sent.pop(v)) / 2 * 1e6)
PY
done

pct() { sort -g | awk -v p="$1" '{v[NR]=$1} END {i=int((NR-1)*p+0.5)+1; print v[i]}'; }
n=$(wc -l <"$work/lat")

: >"$work/load"
for k in $K; do
  echo "== $k points changing every 1 ms (5 s)" >&2
  dir="$work/k$k"; mkdir -p "$dir"
  {
    echo "[PLC]"; echo "module driver timeline"; echo "module mqtt mqtt"
    for j in $(seq "$k"); do echo "point p$j \"counts\" driver u16"; done
    echo "[driver]"; echo "file = counts.csv"; echo "scan_period = T#1ms"
    echo "[mqtt]"; echo "broker = 127.0.0.1:$port"; echo "topic_prefix = load"; echo "scan_period = T#1ms"
    for j in $(seq "$k"); do echo "publish p$j"; done
  } >"$dir/plc.conf"
  python3 - "$k" >"$dir/counts.csv" <<'PY'
import sys
k = int(sys.argv[1])
print("time," + ",".join(f"p{j}" for j in range(1, k + 1)))
for i in range(5000):
    print(f"{i / 1000:.3f}," + ",".join(str(i) for _ in range(k)))
PY
  "$petriplc" run "$dir/plc.conf" --plc-id "bench-k-$$" --for 5s --log-level warn 2>"$dir/err" || { cat "$dir/err" >&2; exit 1; }
  # The report's second line for the module is its status line (`… N published …`).
  line=$(grep -E '^mqtt ' "$dir/err")
  detail=$(grep -A1 -E '^mqtt ' "$dir/err" | tail -1)
  cycle=$(echo "$line" | awk '{print $6}')
  overruns=$(echo "$line" | awk '{print $8}')
  published=$(echo "$detail" | sed -n 's/.* \([0-9]*\) published.*/\1/p')
  coalesced=$(echo "$detail" | sed -n 's/.* \([0-9]*\) coalesced.*/\1/p')
  echo "$k $cycle $overruns $published ${coalesced:-0}" >>"$work/load"
done

echo
echo "$(nproc) cores, mosquitto $(mosquitto -h 2>/dev/null | head -1 | awk '{print $3}'), every module at 1 ms," \
  "$RUNS latency runs; $(uname -r); $(date -u +%Y-%m-%d)"
echo
echo "End-to-end latency PLC A -> PLC B (half the A -> B -> A round trip), $n samples:" \
  "p50 $(pct 0.5 <"$work/lat" | xargs printf '%.0f') µs, p99 $(pct 0.99 <"$work/lat" | xargs printf '%.0f') µs," \
  "max $(pct 1 <"$work/lat" | xargs printf '%.0f') µs"
echo
echo "| points changing | changes/s seen by the scan | published/s | coalesced | mqtt cycle min/mean/max µs | overruns in 5 s |"
echo "|---:|---:|---:|---:|---|---:|"
while read -r k cycle overruns published coalesced; do
  awk -v k="$k" -v c="$cycle" -v o="$overruns" -v p="$published" -v q="$coalesced" \
    'BEGIN { printf "| %d | %.0f | %.0f | %.1f%% | %s | %d |\n", k, (p + q) / 5, p / 5, (p + q ? 100 * q / (p + q) : 0), c, o }'
done <"$work/load"
echo
awk '{ split($2, c, "/"); seen = ($4 + $5) / 5;
       if (seen > 0 && $5 < 0.01 * ($4 + $5) && c[2] + 0 < 100 && seen > best) best = seen }
     END { if (best) printf "Sustained point changes/s before the scan is affected: %.0f (under 1%% coalesced, mqtt mean cycle under 100 µs of its 1 ms scan)\n", best;
           else print "Sustained point changes/s before the scan is affected: below the smallest load offered" }' "$work/load"
