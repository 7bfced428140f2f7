#!/usr/bin/env bash
# State-space exploration speed and memory: petriplc (release, all cores) against the plain C
# breadth-first anchor (testdata/anchors/naive_bfs.c, cc -O2), measured in the same run
# on the same models. Each model is run RUNS times, interleaved (anchor, analyze, search), so
# machine noise hits all three; the tables show medians of states/s and of peak RSS
# (`/usr/bin/time -v`):
#  1. the whole command a user runs, `petriplc analyze MODEL --json` (reading the model,
#     invariants, boundedness, exploration, deadlocks, liveness, reversibility, home
#     markings, the report): states / wall-clock seconds of the process. Goal: >= 3x the
#     anchor's states/s and peak memory <= the anchor's.
#  2. the search alone (crates/petri/reach/examples/reach-bench): both tools' own timing of the
#     search, without reading the model. Goal: keep >= 3x.
# The anchor's states/s is its own timing of its search (without reading its input), which
# favours it against the whole command.
#
#   bash bench/statespace.sh            # Kanban-PT-00005 FMS-PT-00005 MAPK-PT-00008
#   RUNS=5 bash bench/statespace.sh Kanban-PT-00005
set -euo pipefail
cd "$(dirname "$0")/.."

RUNS=${RUNS:-3}
MCC=testdata/mcc
ANCHORS=testdata/anchors
MODELS=("$@")
[ ${#MODELS[@]} -gt 0 ] || MODELS=(Kanban-PT-00005 FMS-PT-00005 MAPK-PT-00008)

as_root() { if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi; }
if [ ! -x /usr/bin/time ]; then
  echo "== installing time (GNU time, for peak RSS)" >&2
  as_root apt-get update -qq
  as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq time >/dev/null
fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

echo "== building the anchor (cc -O2) and petriplc (release)" >&2
cc -O2 -o "$work/naive_bfs" "$ANCHORS/naive_bfs.c"
cargo build --release --quiet -p petriplc-reach --example reach-bench
cargo build --release --quiet -p petriplc
target=$(cargo metadata --format-version 1 --no-deps | python3 -c 'import json,sys; print(json.load(sys.stdin)["target_directory"])')
ours="$target/release/examples/reach-bench"
petriplc="$target/release/petriplc"

# run NAME CMD... : prints "states/s kbytes" for one run.
run() {
  local out="$work/out" err="$work/err"
  shift
  /usr/bin/time -v "$@" >"$out" 2>"$err"
  local rate kb
  rate=$(sed -n 's/.*=> \([0-9]*\) states\/s.*/\1/p' "$out")
  kb=$(sed -n 's/.*Maximum resident set size (kbytes): \([0-9]*\).*/\1/p' "$err")
  [ -n "$rate" ] && [ -n "$kb" ] || { cat "$out" "$err" >&2; exit 1; }
  echo "$rate $kb"
}
# analyze MODEL.pnml : prints "states/s kbytes" of one whole `petriplc analyze --json`.
analyze() {
  local out="$work/out" err="$work/err" a b states kb
  a=$(date +%s%N)
  /usr/bin/time -v "$petriplc" analyze "$1" --json >"$out" 2>"$err" || { cat "$err" >&2; exit 1; }
  b=$(date +%s%N)
  states=$(python3 -c 'import json,sys; r=json.load(open(sys.argv[1])); assert r["complete"], "incomplete"; print(r["states"])' "$out")
  kb=$(sed -n 's/.*Maximum resident set size (kbytes): \([0-9]*\).*/\1/p' "$err")
  awk -v s="$states" -v a="$a" -v b="$b" -v kb="$kb" 'BEGIN { printf "%.0f %d\n", s / ((b - a) / 1e9), kb }'
}
median() { sort -n | awk '{v[NR]=$1} END {print v[int((NR+1)/2)]}'; }

rows=()
whole=()
for m in "${MODELS[@]}"; do
  pnml="$MCC/$m/model.pnml"
  python3 "$ANCHORS/pnml_to_bfs_input.py" "$pnml" >"$work/$m.in"
  states=$("$ours" "$pnml" | awk '{print $2}')
  : >"$work/a" ; : >"$work/p" ; : >"$work/w"
  for i in $(seq "$RUNS"); do
    echo "== $m run $i/$RUNS: anchor, petriplc analyze, search alone" >&2
    run anchor sh -c "exec '$work/naive_bfs' < '$work/$m.in'" >>"$work/a"
    analyze "$pnml" >>"$work/w"
    run petriplc "$ours" "$pnml" >>"$work/p"
  done
  wr=$(cut -d' ' -f1 "$work/w" | median); wm=$(cut -d' ' -f2 "$work/w" | median)
  ar=$(cut -d' ' -f1 "$work/a" | median); am=$(cut -d' ' -f2 "$work/a" | median)
  pr=$(cut -d' ' -f1 "$work/p" | median); pm=$(cut -d' ' -f2 "$work/p" | median)
  rows+=("$(awk -v m="$m" -v s="$states" -v ar="$ar" -v pr="$pr" -v am="$am" -v pm="$pm" 'BEGIN {
    printf "| %s | %d | %.2f M | %.2f M | **%.1fx** | %d MB | %d MB | %.2f |", m, s, ar/1e6, pr/1e6, pr/ar, am/1024, pm/1024, pm/am }')")
  whole+=("$(awk -v m="$m" -v s="$states" -v ar="$ar" -v wr="$wr" -v am="$am" -v wm="$wm" 'BEGIN {
    printf "| %s | %d | %.2f M | %.2f M | **%.1fx** (%s) | %d MB | %d MB | **%.2f** (%s) |", m, s, ar/1e6, wr/1e6, wr/ar,
      (wr/ar >= 3 ? "met" : "NOT met"), am/1024, wm/1024, wm/am, (wm <= am ? "met" : "NOT met") }')")
done

echo
echo "$(nproc) cores, $RUNS runs each, medians; load $(cut -d' ' -f1-3 /proc/loadavg); $(uname -r); $(date -u +%Y-%m-%d)"
echo
echo "Whole command, \`petriplc analyze MODEL --json\` (goal: >= 3x the anchor's states/s, memory ratio <= 1):"
echo
echo "| model | states | anchor states/s | analyze states/s | speed-up | anchor peak RSS | analyze peak RSS | memory ratio |"
echo "|---|---:|---:|---:|---:|---:|---:|---:|"
printf '%s\n' "${whole[@]}"
echo
echo "The search alone, reach-bench (goal: keep >= 3x):"
echo
echo "| model | states | anchor states/s | petriplc states/s | speed-up | anchor peak RSS | petriplc peak RSS | memory ratio |"
echo "|---|---:|---:|---:|---:|---:|---:|---:|"
printf '%s\n' "${rows[@]}"
