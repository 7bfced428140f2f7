#!/usr/bin/env bash
# Scan-timing lateness: petriplc's Period (crates/plc/runtime/examples/cyclic.rs, release) against
# the bare clock_nanosleep(TIMER_ABSTIME) loop testdata/anchors/cyclic.c (cc -O2), in the
# same run. Both wake at every deadline of a 1 ms period for SECONDS and report lateness
# (wake-up time - deadline) p50/p99/max over all wake-ups. Runs are interleaved (anchor,
# petriplc, anchor, ...) so machine noise hits both; the table shows medians over RUNS runs and
# the p99 ratio petriplc/anchor against the goal of 1.2.
#
#   bash bench/scan_timing.sh            # 3 runs x 10 s each (about a minute)
#   bash bench/scan_timing.sh --quick    # 3 runs x 2 s each
#   RT=50 bash bench/scan_timing.sh      # both on SCHED_FIFO 50 (anchor via chrt, petriplc via --rt)
#   RUNS=5 PERIOD_US=500 bash bench/scan_timing.sh
set -euo pipefail
cd "$(dirname "$0")/.."

RUNS=${RUNS:-3}
PERIOD_US=${PERIOD_US:-1000}
SECONDS_PER_RUN=10
RT=${RT:-}
ANCHORS=testdata/anchors
for arg in "$@"; do
  case "$arg" in
    --quick) SECONDS_PER_RUN=2 ;;
    *) echo "usage: [RUNS=n] [PERIOD_US=us] [RT=prio] bash bench/scan_timing.sh [--quick]" >&2; exit 2 ;;
  esac
done

target=$(cargo metadata --format-version 1 --no-deps | python3 -c 'import json,sys; print(json.load(sys.stdin)["target_directory"])')
anchor="$target/cyclic-anchor"
ours="$target/release/examples/cyclic"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

echo "== building the anchor (cc -O2) and petriplc (release)" >&2
mkdir -p "$target"
cc -O2 -o "$anchor" "$ANCHORS/cyclic.c"
cargo build --release --quiet -p petriplc-runtime --example cyclic

anchor_cmd=("$anchor" "$PERIOD_US" "$SECONDS_PER_RUN")
ours_cmd=("$ours" "$PERIOD_US" "$SECONDS_PER_RUN")
policy=SCHED_OTHER
if [ -n "$RT" ]; then
  policy="SCHED_FIFO $RT"
  anchor_cmd=(chrt -f "$RT" "${anchor_cmd[@]}")
  ours_cmd+=(--rt "$RT")
fi

# run CMD... : prints "p50 p99 max overruns" of one run (µs; overruns "-" for the anchor, which
# catches up missed deadlines back to back instead of counting them); stderr goes to the log.
run() {
  local out
  out=$("$@" 2>"$work/err") || { cat "$work/err" >&2; exit 1; }
  cat "$work/err" >>"$work/log"
  local over
  over=$(sed -n 's/.* overruns \([0-9]*\)$/\1/p' "$work/err")
  echo "$out" | awk -v o="${over:--}" '/^wakeups / {print $4, $6, $8, o; ok=1} END {exit !ok}' \
    || { echo "unexpected output: $out" >&2; exit 1; }
}
median() { sort -g | awk '{v[NR]=$1} END {print v[int((NR+1)/2)]}'; }

: >"$work/a"; : >"$work/p"; : >"$work/log"
for i in $(seq "$RUNS"); do
  echo "== run $i/$RUNS: anchor, then petriplc (${SECONDS_PER_RUN} s each)" >&2
  run "${anchor_cmd[@]}" >>"$work/a"
  run "${ours_cmd[@]}" >>"$work/p"
done
grep -h '^warning' "$work/log" | sort -u >&2 || true

row() { # NAME FILE
  local p50 p99 max over
  p50=$(cut -d' ' -f1 "$2" | median); p99=$(cut -d' ' -f2 "$2" | median); max=$(cut -d' ' -f3 "$2" | median)
  over=$(cut -d' ' -f4 "$2" | median)
  echo "| $1 | $p50 | $p99 | $max | $over |"
}
a99=$(cut -d' ' -f2 "$work/a" | median)
p99=$(cut -d' ' -f2 "$work/p" | median)

echo
echo "$(nproc) cores, period ${PERIOD_US} µs, ${SECONDS_PER_RUN} s per run, $RUNS runs each, medians;" \
  "scheduling: $policy; $(uname -r); $(date -u +%Y-%m-%d)"
echo
echo "| loop | lateness p50 µs | p99 µs | max µs | overruns |"
echo "|---|---:|---:|---:|---:|"
row "anchor (cyclic.c, cc -O2)" "$work/a"
row "petriplc (Period, release)" "$work/p"
echo
awk -v p="$p99" -v a="$a99" 'BEGIN {
  r = (a > 0) ? p / a : 0
  printf "p99 ratio petriplc/anchor: **%.2f** (goal <= 1.2: %s)\n", r, (r <= 1.2 ? "met" : "NOT met") }'
echo "overruns: deadlines petriplc skipped because a wake-up came more than one period late (median" \
  "per run); cyclic.c wakes for such deadlines back to back instead and records each as lateness."
