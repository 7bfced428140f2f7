#!/usr/bin/env bash
# One scan of the ST that `petriplc compile` writes for N = 1, 100, 1000 copies of seed 002's
# mixer net, on the IEC engine (release), against the C that `petriplc compile --lang c` writes
# for the same nets built with cc -O2 (its own translation unit, linked with bench/iec/c_scan.c),
# in the same run, every input TRUE (each copy fires a transition every scan). The engine
# runs twice: its machine code (petriplc-iec-jit, the default) and the bytecode VM alone.
# Runs are interleaved (C, machine code, VM, C, …); the table shows the median over RUNS
# runs of each side's median wall-clock ns per scan, the CPU ns per scan (process CPU time
# / scans: what a scan costs even when the machine is shared), and the ratios engine/C
# against the goal of 3. Then the compile time of the 1000-copy program: `petriplc check
# --pou mixer` (read, parse, check, bytecode), and what its machine code would take.
# Then the IL `petriplc compile --lang il` writes for the same nets against that ST, both on
# the engine (interleaved likewise; goal: IL within 1.2x of ST, one lowered form for both).
# Then the same logic as LD against ST (both PLCopen projects `petriplc compile` writes) on the
# engine.
#
#   bash bench/iec_scan.sh            # 5 runs
#   RUNS=9 bash bench/iec_scan.sh
set -euo pipefail
cd "$(dirname "$0")/.."

RUNS=${RUNS:-5}
target=$(cargo metadata --format-version 1 --no-deps | python3 -c 'import json,sys; print(json.load(sys.stdin)["target_directory"])')
work="$target/iec-bench"
mkdir -p "$work"

echo "== building petriplc and the engine's timer (release)" >&2
cargo build --release --quiet -p petriplc
cargo build --release --quiet -p petriplc-iec --example scan_time
petriplc="$target/release/petriplc"
engine="$target/release/examples/scan_time"

for n in 1 100 1000; do
  python3 bench/iec/mixer_copies.py "$n" "$work/mixer-$n.pnml"
  "$petriplc" compile "$work/mixer-$n.pnml" --names sipn --lang st --plain --out "$work/mixer-$n.st" 2>/dev/null
  "$petriplc" compile "$work/mixer-$n.pnml" --names sipn --lang il --plain --out "$work/mixer-$n.il" 2>/dev/null
  "$petriplc" compile "$work/mixer-$n.pnml" --names sipn --lang c --out "$work/mixer-$n.c" 2>/dev/null
  "$petriplc" compile "$work/mixer-$n.pnml" --names sipn --lang st --out "$work/mixer-$n-st.xml" 2>/dev/null
  "$petriplc" compile "$work/mixer-$n.pnml" --names sipn --lang ld --out "$work/mixer-$n-ld.xml" 2>/dev/null
  cc -std=c99 -O2 -c -o "$work/mixer-$n.o" "$work/mixer-$n.c"
  cc -O2 -o "$work/c_scan-$n" bench/iec/c_scan.c "$work/mixer-$n.o"
done

median() { sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
ratio() { python3 -c "print(f'{$1 / $2:.2f}')"; }

# Three sides per N, interleaved within each run: the C, the engine's machine code
# (petriplc-iec-jit, what `petriplc sim` and the iec module run) and the bytecode VM alone.
printf "%-5s %9s %9s %9s | %9s %9s %9s | %7s %7s | %7s %7s\n" N "C ns" "jit ns" "vm ns" \
  "C cpu" "jit cpu" "vm cpu" "jit/C" "vm/C" "jit/C" "vm/C"
printf "%-5s %29s | %29s | %15s | %15s\n" "" "wall-clock ns per scan" "CPU ns per scan" \
  "wall ratio" "CPU ratio (goal 3)"
for n in 1 100 1000; do
  scans=$((2000000 / n))
  cw=(); jw=(); vw=(); cc=(); jc=(); vc=()
  for ((r = 0; r < RUNS; r++)); do
    read -r w c < <("$work/c_scan-$n" $((n * 4)) "$scans" 11)
    cw+=("$w"); cc+=("$c")
    read -r w c _ < <("$engine" "$work/mixer-$n.st" "$scans" 11)
    jw+=("$w"); jc+=("$c")
    read -r w c _ < <("$engine" "$work/mixer-$n.st" "$scans" 11 vm)
    vw+=("$w"); vc+=("$c")
  done
  m() { printf "%s\n" "$@" | median; }
  a=$(m "${cw[@]}"); b=$(m "${jw[@]}"); d=$(m "${vw[@]}")
  e=$(m "${cc[@]}"); f=$(m "${jc[@]}"); g=$(m "${vc[@]}")
  printf "%-5s %9.1f %9.1f %9.1f | %9.1f %9.1f %9.1f | %7s %7s | %7s %7s\n" "$n" "$a" "$b" "$d" \
    "$e" "$f" "$g" "$(ratio "$b" "$a")" "$(ratio "$d" "$a")" "$(ratio "$f" "$e")" "$(ratio "$g" "$e")"
done
echo "(jit: machine code where petriplc-iec-jit makes it: N = 1 and 100; the 1000-copy program is"
echo " past its size limit of 8192 instructions, so the VM runs it there too)"

# One logic, two languages: the LD project `compile --lang ld` writes against the ST project
# `compile --lang st` writes, both PLCopen XML with the same configuration, on the engine
# (issue 17: within 1.2x).
echo
printf "%-6s %14s %14s %14s %14s %8s %8s\n" N "ST ns/scan" "LD ns/scan" "ST cpu ns" "LD cpu ns" "ratio" "cpu ratio"
for n in 1 100 1000; do
  scans=$((2000000 / n))
  s_wall=(); l_wall=(); s_cpu=(); l_cpu=()
  for ((r = 0; r < RUNS; r++)); do
    read -r w c _ < <("$engine" "$work/mixer-$n-st.xml" "$scans" 11)
    s_wall+=("$w"); s_cpu+=("$c")
    read -r w c _ < <("$engine" "$work/mixer-$n-ld.xml" "$scans" 11)
    l_wall+=("$w"); l_cpu+=("$c")
  done
  sw=$(printf "%s\n" "${s_wall[@]}" | median); lw=$(printf "%s\n" "${l_wall[@]}" | median)
  sc=$(printf "%s\n" "${s_cpu[@]}" | median); lc=$(printf "%s\n" "${l_cpu[@]}" | median)
  printf "%-6s %14.1f %14.1f %14.1f %14.1f %8.2f %8.2f\n" "$n" "$sw" "$lw" "$sc" "$lc" \
    "$(python3 -c "print($lw / $sw)")" "$(python3 -c "print($lc / $sc)")"
done

echo
lines=$(wc -l < "$work/mixer-1000.st")
ms=(); jit=()
for ((r = 0; r < RUNS; r++)); do
  start=$(date +%s%N)
  "$petriplc" check "$work/mixer-1000.st" --pou mixer 2>/dev/null
  ms+=("$(( ($(date +%s%N) - start) / 1000000 ))")
  read -r _ _ _ j < <("$engine" "$work/mixer-1000.st" 1 1)
  jit+=("$(python3 -c "print(round($j * 1000))")")
done
echo "compile of the 1000-copy program ($lines lines): median $(printf "%s\n" "${ms[@]}" | median) ms (petriplc check --pou mixer: read, parse, check, bytecode; goal < 1000 ms); machine code (made when a machine starts; above petriplc-iec-jit's size limit, so not used for this program): median $(printf "%s\n" "${jit[@]}" | median) ms"

echo
printf "%-6s %14s %14s %14s %14s %8s %8s\n" N "ST ns/scan" "IL ns/scan" "ST cpu ns" "IL cpu ns" "ratio" "cpu ratio"
for n in 1 100 1000; do
  scans=$((2000000 / n))
  s_wall=(); i_wall=(); s_cpu=(); i_cpu=()
  for ((r = 0; r < RUNS; r++)); do
    read -r w c _ < <("$engine" "$work/mixer-$n.st" "$scans" 11)
    s_wall+=("$w"); s_cpu+=("$c")
    read -r w c _ < <("$engine" "$work/mixer-$n.il" "$scans" 11)
    i_wall+=("$w"); i_cpu+=("$c")
  done
  sw=$(printf "%s\n" "${s_wall[@]}" | median); iw=$(printf "%s\n" "${i_wall[@]}" | median)
  sc=$(printf "%s\n" "${s_cpu[@]}" | median); ic=$(printf "%s\n" "${i_cpu[@]}" | median)
  printf "%-6s %14.1f %14.1f %14.1f %14.1f %8.2f %8.2f\n" "$n" "$sw" "$iw" "$sc" "$ic" \
    "$(python3 -c "print($iw / $sw)")" "$(python3 -c "print($ic / $sc)")"
done
lines=$(wc -l < "$work/mixer-1000.il")
ms=()
for ((r = 0; r < RUNS; r++)); do
  start=$(date +%s%N)
  "$petriplc" check "$work/mixer-1000.il" --pou mixer 2>/dev/null
  ms+=("$(( ($(date +%s%N) - start) / 1000000 ))")
done
echo "compile of the 1000-copy IL program ($lines lines): median $(printf "%s\n" "${ms[@]}" | median) ms (petriplc check --pou mixer)"
