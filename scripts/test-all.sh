#!/usr/bin/env bash
# Runs every check petriplc has, on a fresh machine: installs what the tests need, then
# formatting, lints and the whole test suite. CI runs exactly this (.ci/run).
set -euo pipefail
cd "$(dirname "$0")/.."

as_root() { if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi; }

# The tests' own data is in testdata/ (testdata/SOURCES.md). Third-party code that must not
# be copied into the repository (MatPLC's configurations, Beremiz's projects, OSCAT) is read
# by the conformance tests from ../shared beside the checkout, when it is there.
if [ -d ../shared ]; then
  echo "== conformance over third-party code: ../shared is beside the checkout, its tests run"
else
  echo "== conformance over third-party code skipped: no ../shared beside the checkout (each such test says so)"
fi

# xmllint validates what we write against the PNML and PLCopen grammars; Graphviz's dot lays
# out the reachability graphs `petriplc analyze --svg` draws; cc builds the generated C that
# the differential tests run against the simulator.
# mbpoll is a third-party Modbus client the Modbus server is tested with; tmux runs the
# vitrine in a real terminal for its tests; Debian's chromium is the browser Playwright drives
# for the HMI's test.
missing=()
command -v xmllint >/dev/null 2>&1 || missing+=(libxml2-utils)
command -v dot >/dev/null 2>&1 || missing+=(graphviz)
command -v cc >/dev/null 2>&1 || missing+=(gcc libc6-dev)
command -v mbpoll >/dev/null 2>&1 || missing+=(mbpoll)
command -v tmux >/dev/null 2>&1 || missing+=(tmux)
command -v chromium >/dev/null 2>&1 || missing+=(chromium)
command -v npm >/dev/null 2>&1 || missing+=(nodejs npm)
# Debian's mosquitto is the broker the MQTT tests start (on free loopback ports), with its
# clients mosquitto_pub/mosquitto_sub/mosquitto_passwd; openssl makes their TLS certificates.
{ command -v mosquitto || [ -x /usr/sbin/mosquitto ]; } >/dev/null 2>&1 || missing+=(mosquitto)
command -v mosquitto_pub >/dev/null 2>&1 || missing+=(mosquitto-clients)
command -v openssl >/dev/null 2>&1 || missing+=(openssl)
# systemd-analyze verifies the example unit file of `petriplc run` as a service.
command -v systemd-analyze >/dev/null 2>&1 || missing+=(systemd)
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

# pymodbus (pinned), a third-party Modbus client (TCP and serial) for the Modbus tests.
PYMODBUS_VERSION=3.16.1
if ! target/py/bin/python -c "import serial, pymodbus, sys; sys.exit(pymodbus.__version__ != '$PYMODBUS_VERSION')" 2>/dev/null; then
  echo "== installing pymodbus $PYMODBUS_VERSION and pyserial 3.5 into target/py"
  target/py/bin/pip install -q "pymodbus==$PYMODBUS_VERSION" "pyserial==3.5"
fi
export PETRIPLC_PYTHON="$PWD/target/py/bin/python"

# SciPy (pinned) is the reference the DSP blocks' filter design and outputs are held to.
SCIPY_VERSION=1.17.1
if ! target/py/bin/python -c "import scipy, sys; sys.exit(scipy.__version__ != '$SCIPY_VERSION')" 2>/dev/null; then
  echo "== installing scipy $SCIPY_VERSION (and numpy 2.4.6) into target/py"
  target/py/bin/python -m pip install -q "scipy==$SCIPY_VERSION" "numpy==2.4.6"
fi

# Python asyncua (pinned), a third-party OPC UA client for the opcua_server tests, and
# paho-mqtt (pinned), a third-party MQTT client for the two-cell test.
ASYNCUA_VERSION=2.1.0
PAHO_VERSION=2.2.0
if ! target/py/bin/python -c "import sys; from importlib.metadata import version as v; sys.exit(not (v('asyncua') == '$ASYNCUA_VERSION' and v('paho-mqtt') == '$PAHO_VERSION'))" 2>/dev/null; then
  echo "== installing asyncua $ASYNCUA_VERSION and paho-mqtt $PAHO_VERSION into target/py"
  target/py/bin/python -m pip install -q "asyncua==$ASYNCUA_VERSION" "paho-mqtt==$PAHO_VERSION"
fi
# pysparkplug (pinned; protobuf classes compiled from Eclipse Tahu's sparkplug_b.proto) on
# Google's protobuf runtime (pinned) decodes the Sparkplug B messages of the mqtt tests. It
# asks for paho-mqtt<2 for its own client, which the tests do not use: --no-deps.
PROTOBUF_VERSION=6.33.1
PYSPARKPLUG_VERSION=0.6.1
if ! target/py/bin/python -c "import sys; from importlib.metadata import version as v; sys.exit(not (v('protobuf') == '$PROTOBUF_VERSION' and v('pysparkplug') == '$PYSPARKPLUG_VERSION'))" 2>/dev/null; then
  echo "== installing protobuf $PROTOBUF_VERSION and pysparkplug $PYSPARKPLUG_VERSION into target/py"
  target/py/bin/python -m pip install -q "protobuf==$PROTOBUF_VERSION"
  target/py/bin/python -m pip install -q --no-deps "pysparkplug==$PYSPARKPLUG_VERSION"
fi

# playwright-core (pinned) drives chromium in the HMI's browser test.
PLAYWRIGHT_VERSION=1.65.1
if ! grep -qs "\"version\": \"$PLAYWRIGHT_VERSION\"" target/node/node_modules/playwright-core/package.json; then
  echo "== installing playwright-core $PLAYWRIGHT_VERSION into target/node"
  mkdir -p target/node
  npm install --silent --no-audit --no-fund --prefix target/node "playwright-core@$PLAYWRIGHT_VERSION"
fi

echo "== cargo fmt --check"
cargo fmt --all -- --check
echo "== no import circles between the modules of a crate"
python3 scripts/module-circles.py
echo "== cargo clippy"
cargo clippy --workspace --all-targets --locked -- -D warnings
echo "== cargo test"
cargo test --workspace --locked
echo "== the five big Model Checking Contest models (0.7 to 6.1 million states), release build"
cargo test --release --locked -p petriplc-reach --test mcc_big
