#!/usr/bin/env bash
# Builds the C module blinker.c and runs it under `petriplc run`, from any folder:
#
#   bash examples/c-module/run.sh [petriplc run options, e.g. --for 5s or --plc-id demo]
#
# 1. libpetriplc (the C API, crates/plc/capi) with cargo, in target/c-module/, 2. blinker linked
# statically against it into out/c-module/, 3. `petriplc run examples/c-module/plc.conf` with
# your options.
# `petriplc` is the one on your PATH (cargo install --path crates/cli), else it is built.
set -euo pipefail
cd "$(dirname "$0")/../.."
target="${CARGO_TARGET_DIR:-target}"

# The library gets a target folder of its own: built alone, its dependencies resolve other
# features than in the whole workspace, and sharing target/debug would rebuild shared crates
# in place (under a running `cargo test`, or back and forth with `cargo build`).
echo "== cargo build -p petriplc-capi (into $target/c-module)" >&2
CARGO_TARGET_DIR="$target/c-module" cargo build --quiet -p petriplc-capi
mkdir -p out/c-module
echo "== cc blinker.c -> out/c-module/blinker" >&2
cc -std=c99 -Wall -Wextra -O2 -I crates/plc/capi/include examples/c-module/blinker.c \
   "$target/c-module/debug/libpetriplc.a" -lpthread -ldl -lm -o out/c-module/blinker

if command -v petriplc >/dev/null 2>&1; then
  petriplc=petriplc
else
  echo "== petriplc is not on your PATH: cargo build --release -p petriplc" >&2
  cargo build --quiet --release -p petriplc
  petriplc="$target/release/petriplc"
fi
echo "== $petriplc run examples/c-module/plc.conf $*" >&2
exec "$petriplc" run examples/c-module/plc.conf "$@"
