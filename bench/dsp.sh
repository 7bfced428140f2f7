#!/usr/bin/env bash
# The dsp module's scan cost: petriplc-dsp's criterion benchmark (crates/base/dsp/benches/chain.rs:
# a chain of 1000 mixed blocks, and filters with 1000 second-order sections in all), the whole
# module scan with its points (crates/plc/modules/benches/dsp_module.rs, through the harness:
# update(), scan, update() on a real process image) against,
# in the same run, a plain C cascade of sections stepped sample by sample
# (bench/dsp/sos_anchor.c, cc -O2: the floor) and SciPy's sosfilt on a whole array (its C
# loop, which a PLC stepping one scan at a time cannot use). Prints medians and ratios.
#
#   bash bench/dsp.sh
#
# Needs a C compiler and the Python of target/py with SciPy (scripts/test-all.sh installs it).
set -euo pipefail
cd "$(dirname "$0")/.."

target=$(cargo metadata --format-version 1 --no-deps | python3 -c 'import json,sys; print(json.load(sys.stdin)["target_directory"])')
anchor="$target/sos-anchor"
cc -O2 -o "$anchor" bench/dsp/sos_anchor.c -lm
python=${PETRIPLC_PYTHON:-target/py/bin/python}

median() { sort -g | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR+1)/2] : (a[NR/2] + a[NR/2+1]) / 2}'; }

c_runs=()
for _ in 1 2 3 4 5; do c_runs+=("$("$anchor" 1000 100000)"); done
c_ns=$(printf '%s\n' "${c_runs[@]}" | median)

scipy_ns=$("$python" - <<'PY'
import time
import numpy as np
from scipy import signal
sos = np.tile([1.0, -1.6, 0.8, 1.0, -1.5, 0.7], (1000, 1))
sos[0, :3] *= 0.01
x = np.sin(np.arange(20000) * 0.05)
runs = []
for _ in range(5):
    t = time.perf_counter()
    signal.sosfilt(sos, x)
    runs.append((time.perf_counter() - t) * 1e9 / x.size / 1000)
print(f"{sorted(runs)[2]:.3f}")
PY
)

out=$(cargo bench -q -p petriplc-dsp --bench chain 2>/dev/null)
# criterion's line "time:   [low median high]" per benchmark, in order: mixed, then sos.
times=$(echo "$out" | grep -E "^ +time: +\[[0-9]" | grep -v "%" | sed -E 's/.*\[[^ ]+ [^ ]+ ([^ ]+) ([^ ]+) .*/\1 \2/')
to_ns() { awk -v v="$1" -v u="$2" 'BEGIN { f = (u == "ns") ? 1 : (u == "µs" || u == "us") ? 1e3 : (u == "ms") ? 1e6 : 1e9; printf "%.1f", v * f }'; }
read -r mixed_v mixed_u <<<"$(echo "$times" | sed -n 1p)"
read -r sos_v sos_u <<<"$(echo "$times" | sed -n 2p)"
mixed_ns=$(to_ns "$mixed_v" "$mixed_u")
module_out=$(cargo bench -q -p petriplc-modules --bench dsp_module 2>/dev/null)
read -r module_v module_u <<<"$(echo "$module_out" | grep -E "^ +time: +\[[0-9]" | grep -v "%" | sed -E 's/.*\[[^ ]+ [^ ]+ ([^ ]+) ([^ ]+) .*/\1 \2/')"
module_ns=$(to_ns "$module_v" "$module_u")
sos_ns=$(to_ns "$sos_v" "$sos_u")

printf '%-44s %12s %14s\n' "" "per scan" "per block"
printf '%-44s %9s ns %11s ns\n' "petriplc: 1000 mixed blocks (Chain::scan)" "$mixed_ns" "$(awk -v t="$mixed_ns" 'BEGIN{printf "%.1f", t/1000}')"
printf '%-44s %9s ns %11s ns\n' "petriplc: the module's scan, 1000 blocks" "$module_ns" "$(awk -v t="$module_ns" 'BEGIN{printf "%.1f", t/1000}')"
printf '%-44s %9s ns %11s ns\n' "petriplc: 1000 second-order sections" "$sos_ns" "$(awk -v t="$sos_ns" 'BEGIN{printf "%.2f", t/1000}')"
printf '%-44s %9s ns %11s ns\n' "C anchor: 1000 sections, stepped" "$(awk -v c="$c_ns" 'BEGIN{printf "%.1f", c*1000}')" "$c_ns"
printf '%-44s %9s    %11s ns\n' "SciPy sosfilt on an array (per sample)" "-" "$scipy_ns"
echo "ratio petriplc/C per section: $(awk -v p="$sos_ns" -v c="$c_ns" 'BEGIN{printf "%.2f", p/1000/c}') (goal: under 50 ns per section)"
