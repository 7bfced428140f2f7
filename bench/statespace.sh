#!/usr/bin/env bash
# State-space exploration speed and memory: petriplc (crates/reach, release, all cores)
# against the plain C breadth-first anchor (../shared/bench/anchors/naive_bfs.c, cc -O2),
# measured in the same run on the same models. Each tool explores each model RUNS times
# (interleaved, so machine noise hits both); the table shows medians of states/s (the tools'
# own timing of the search, without reading the model) and of peak RSS (`/usr/bin/time -v`).
#
#   bash bench/statespace.sh            # Kanban-PT-00005 FMS-PT-00005 MAPK-PT-00008
#   RUNS=5 bash bench/statespace.sh Kanban-PT-00005
set -euo pipefail
cd "$(dirname "$0")/.."

RUNS=${RUNS:-3}
MCC=../shared/data/mcc
ANCHORS=../shared/bench/anchors
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
target=$(cargo metadata --format-version 1 --no-deps | python3 -c 'import json,sys; print(json.load(sys.stdin)["target_directory"])')
ours="$target/release/examples/reach-bench"

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
median() { sort -n | awk '{v[NR]=$1} END {print v[int((NR+1)/2)]}'; }

rows=()
for m in "${MODELS[@]}"; do
  pnml="$MCC/$m/model.pnml"
  python3 "$ANCHORS/pnml_to_bfs_input.py" "$pnml" >"$work/$m.in"
  states=$("$ours" "$pnml" | awk '{print $2}')
  : >"$work/a" ; : >"$work/p"
  for i in $(seq "$RUNS"); do
    echo "== $m run $i/$RUNS" >&2
    run anchor sh -c "exec '$work/naive_bfs' < '$work/$m.in'" >>"$work/a"
    run petriplc "$ours" "$pnml" >>"$work/p"
  done
  ar=$(cut -d' ' -f1 "$work/a" | median); am=$(cut -d' ' -f2 "$work/a" | median)
  pr=$(cut -d' ' -f1 "$work/p" | median); pm=$(cut -d' ' -f2 "$work/p" | median)
  rows+=("$(awk -v m="$m" -v s="$states" -v ar="$ar" -v pr="$pr" -v am="$am" -v pm="$pm" 'BEGIN {
    printf "| %s | %d | %.2f M | %.2f M | **%.1fx** | %d MB | %d MB | %.2f |", m, s, ar/1e6, pr/1e6, pr/ar, am/1024, pm/1024, pm/am }')")
done

echo
echo "$(nproc) cores, $RUNS runs each, medians; $(date -u +%Y-%m-%d)"
echo
echo "| model | states | anchor states/s | petriplc states/s | speed-up | anchor peak RSS | petriplc peak RSS | memory ratio |"
echo "|---|---:|---:|---:|---:|---:|---:|---:|"
printf '%s\n' "${rows[@]}"
