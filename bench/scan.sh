#!/usr/bin/env bash
# Interpreted scans against the generated C, in the same run:
#  1. `petriplc sim` of seed 002's mixer for 10^7 scans (1 ms period, the mixer timeline,
#     whole command, trace to a file) against the C `petriplc compile --lang c` writes for it
#     (cc -O2, -DPETRIPLC_MAIN: its software-in-the-loop main, same timeline, same trace);
#     the two traces must be identical. Goal: <= 2x.
#  2. 1000 mixer copies where one copy's input changes per scan: the incremental scanner
#     (crates/petri/sim/examples/scan-copies.rs, what `petriplc sim` and the petrinet module run)
#     against the generated C's step() on the same schedule (bench/scan/driver.c), time per
#     scan of the scan loop; both print a checksum of the final marking, which must agree.
#     Goal: faster than the C (ratio < 1). The reference evaluator is shown for comparison.
# Runs are interleaved (anchor, petriplc, ...) so machine noise hits both; medians of RUNS.
#
#   bash bench/scan.sh              # 5 runs each
#   RUNS=3 SCANS=10000000 COPIES=1000 bash bench/scan.sh
set -euo pipefail
cd "$(dirname "$0")/.."

RUNS=${RUNS:-5}
SCANS=${SCANS:-10000000}
COPIES=${COPIES:-1000}
COPY_SCANS=${COPY_SCANS:-80000}
[ $# -eq 0 ] || { echo "usage: [RUNS=n] [SCANS=n] [COPIES=n] [COPY_SCANS=n] bash bench/scan.sh" >&2; exit 2; }

target=$(cargo metadata --format-version 1 --no-deps | python3 -c 'import json,sys; print(json.load(sys.stdin)["target_directory"])')
petriplc="$target/release/petriplc"
copies="$target/release/examples/scan-copies"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

echo "== building petriplc (release) and the generated C (cc -O2)" >&2
cargo build --release --quiet -p petriplc
cargo build --release --quiet -p petriplc-sim --example scan-copies
"$petriplc" compile examples/mixer/mixer.pnml --names sipn --lang c --out "$work/mixer.c" 2>/dev/null
cc -std=c99 -O2 -DPETRIPLC_MAIN -o "$work/mixer" "$work/mixer.c"
"$copies" write "$COPIES" "$work/mixers.pnml"
"$petriplc" compile "$work/mixers.pnml" --lang c --out "$work/mixers.c" 2>/dev/null
cc -O2 -I"$work" -DPETRIPLC_MAIN -DGENERATED='"mixers.c"' -o "$work/driver" bench/scan/driver.c

# seconds CMD... : wall-clock seconds of a command, its output in $work/out.
seconds() {
  local a b
  a=$(date +%s%N)
  "$@" >"$work/out"
  b=$(date +%s%N)
  awk -v a="$a" -v b="$b" 'BEGIN { printf "%.4f\n", (b - a) / 1e9 }'
}
median() { sort -g | awk '{v[NR]=$1} END {print v[int((NR+1)/2)]}'; }
field() { sed -n "s/.*$1=\([0-9.]*\).*/\1/p" "$work/out"; }

until_s=$(awk -v n="$SCANS" 'BEGIN { printf "%.3f", n / 1000 }')
: >"$work/mc"; : >"$work/ms"; : >"$work/cc"; : >"$work/ci"; : >"$work/cr"
for i in $(seq "$RUNS"); do
  echo "== run $i/$RUNS: mixer, $SCANS scans (C, then petriplc sim)" >&2
  seconds "$work/mixer" examples/mixer/timeline.csv --period 1ms --until "${until_s}s" >>"$work/mc"
  cp "$work/out" "$work/c.csv"
  seconds "$petriplc" sim examples/mixer/mixer.pnml --names sipn --inputs examples/mixer/timeline.csv \
    --period 1ms --until "${until_s}s" >>"$work/ms"
  cmp -s "$work/c.csv" "$work/out" || { echo "the traces of the C and of petriplc sim differ" >&2; exit 1; }
  echo "== run $i/$RUNS: $COPIES copies, $COPY_SCANS scans (C, incremental, reference)" >&2
  "$work/driver" "$COPY_SCANS" >"$work/out"; field ns_per_scan >>"$work/cc"; c_sum=$(field checksum)
  "$copies" run "$work/mixers.pnml" "$COPY_SCANS" >"$work/out"; field ns_per_scan >>"$work/ci"
  [ "$(field checksum)" = "$c_sum" ] || { echo "checksums differ: the C and the scanner disagree" >&2; exit 1; }
  "$copies" run "$work/mixers.pnml" "$COPY_SCANS" reference >"$work/out"; field ns_per_scan >>"$work/cr"
  [ "$(field checksum)" = "$c_sum" ] || { echo "checksums differ: the C and the reference disagree" >&2; exit 1; }
done

mc=$(median <"$work/mc"); ms=$(median <"$work/ms")
cc=$(median <"$work/cc"); ci=$(median <"$work/ci"); cr=$(median <"$work/cr")
echo
echo "$(nproc) cores, $RUNS runs each, medians; load $(cut -d' ' -f1-3 /proc/loadavg); $(uname -r); $(date -u +%Y-%m-%d)"
echo
echo "| what | petriplc | anchor (generated C, cc -O2) | ratio | goal |"
echo "|---|---:|---:|---:|---|"
awk -v s="$ms" -v c="$mc" -v n="$SCANS" 'BEGIN {
  r = s / c
  printf "| petriplc sim, mixer, %d scans, whole command | %.2f s (%.1f ns/scan) | %.2f s (%.1f ns/scan) | **%.2fx** | <= 2x: %s |\n",
    n, s, s * 1e9 / n, c, c * 1e9 / n, r, (r <= 2 ? "met" : "NOT met") }'
awk -v i="$ci" -v c="$cc" -v r="$cr" -v k="$COPIES" 'BEGIN {
  q = i / c
  printf "| %d mixers, one input changing per scan, per scan | %.1f µs | %.1f µs | **%.2fx** | < 1x: %s |\n",
    k, i / 1000, c / 1000, q, (q < 1 ? "met" : "NOT met")
  printf "| the same, reference evaluator (every transition every pass) | %.1f µs | %.1f µs | %.2fx | - |\n",
    r / 1000, c / 1000, r / c }'
