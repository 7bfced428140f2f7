#!/usr/bin/env bash
# update() of a module map against memcpy of the same words, in the same process, in turns
# (crates/plc/runtime/examples/update-ratio.rs): the module owns a quarter of the 32-bit points,
# interleaved (word i owned by module i mod 4, the worst case) or as one block; nothing
# changes between updates (a steady scan), except in `interleaved-changed`, where every word
# is rewritten (untimed) before each update and each memcpy. Prints the medians and the
# median per-round ratio against the goal (interleaved <= 2x memcpy), and the time of two
# memcpys: the traffic of any exchange of interleaved words (both images read and written).
#
#   bash bench/update.sh              # 64 k words, 9 rounds
#   WORDS="1024 65536" ROUNDS=15 bash bench/update.sh
set -euo pipefail
cd "$(dirname "$0")/.."

WORDS=${WORDS:-65536}
ROUNDS=${ROUNDS:-9}
[ $# -eq 0 ] || { echo "usage: [WORDS=\"n ...\"] [ROUNDS=n] bash bench/update.sh" >&2; exit 2; }

target=$(cargo metadata --format-version 1 --no-deps | python3 -c 'import json,sys; print(json.load(sys.stdin)["target_directory"])')
echo "== building update-ratio (release)" >&2
cargo build --release --quiet -p petriplc-runtime --example update-ratio
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for n in $WORDS; do
  "$target/release/examples/update-ratio" "$n" "$ROUNDS" >>"$work/out"
done

echo
echo "$(nproc) cores, $ROUNDS rounds, medians; load $(cut -d' ' -f1-3 /proc/loadavg); $(uname -r); $(date -u +%Y-%m-%d)"
echo
echo "| update(), owner | words | petriplc update() | anchor: memcpy, same run | ratio | goal | two memcpys (an exchange's traffic) |"
echo "|---|---:|---:|---:|---:|---|---:|"
awk '{
  for (i = 1; i <= NF; i++) { split($i, kv, "="); f[kv[1]] = kv[2] }
  shape = $1
  goal = (shape ~ /^interleaved/) ? ("<= 2x: " (f["ratio"] <= 2 ? "met" : "NOT met")) : "-"
  printf "| %s | %d | %.1f µs | %.1f µs | **%.2fx** | %s | %.1f µs (%.2fx) |\n",
    shape, f["words"], f["update_ns"] / 1000, f["memcpy_ns"] / 1000, f["ratio"], goal,
    f["two_ns"] / 1000, f["two_ns"] / f["memcpy_ns"]
}' "$work/out"
