#!/usr/bin/env bash
# Runs every check petriplc has, on a fresh machine: installs what the tests need, then
# formatting, lints and the whole test suite. CI runs exactly this (.ci/run).
set -euo pipefail
cd "$(dirname "$0")/.."

as_root() { if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi; }

# xmllint validates what we write against the PNML and PLCopen grammars; Graphviz's dot lays
# out the reachability graphs `petriplc analyze --svg` draws; cc builds the generated C that
# the differential tests run against the simulator.
missing=()
command -v xmllint >/dev/null 2>&1 || missing+=(libxml2-utils)
command -v dot >/dev/null 2>&1 || missing+=(graphviz)
command -v cc >/dev/null 2>&1 || missing+=(gcc libc6-dev)
if [ ${#missing[@]} -gt 0 ]; then
  echo "== installing ${missing[*]}"
  as_root apt-get update -qq
  as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >/dev/null
fi

# blark, a third-party IEC 61131-3 ST parser (pinned), checks the ST petriplc generates.
BLARK_VERSION=0.8.3
if ! target/py/bin/blark --version 2>/dev/null | grep -q "$BLARK_VERSION"; then
  echo "== installing blark $BLARK_VERSION into target/py"
  if ! python3 -m venv target/py >/dev/null 2>&1; then
    as_root apt-get update -qq
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv >/dev/null
    python3 -m venv target/py
  fi
  target/py/bin/pip install -q "blark==$BLARK_VERSION"
fi
export PETRIPLC_BLARK="$PWD/target/py/bin/blark"

if [ ! -d ../shared/data/mcc ]; then
  echo "error: ../shared (seeds, schemas, MCC models) must sit beside this checkout" >&2
  exit 2
fi

echo "== cargo fmt --check"
cargo fmt --all -- --check
echo "== cargo clippy"
cargo clippy --workspace --all-targets --locked -- -D warnings
echo "== cargo test"
cargo test --workspace --locked
echo "== the five big Model Checking Contest models (0.7 to 6.1 million states), release build"
cargo test --release --locked -p petriplc-reach --test mcc_big
