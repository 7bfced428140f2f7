#!/bin/sh
# Records matiec's results of OSCAT BASIC's functions and function blocks anew, then compares
# petriplc with them: crates/compiler/iec/tests/conformance_matiec.rs with MATIEC_RECORD=1.
# Needs PETRIPLC_MATIEC=/path/to/matiec, a folder holding a matiec build's `iec2c` and its
# `lib/` (the IEC and C library matiec installs beside iec2c), gcc with its undefined-behaviour
# sanitizer, and ../shared/corpora/oscat beside the checkout. PETRIPLC_MATIEC_COMMIT names the
# matiec commit in the recording's header (default: the word in $PETRIPLC_MATIEC/COMMIT's
# third field, if that file exists). The recording is testdata/matiec/oscat_basic.txt: commit
# it with the ALLOW list of the test brought up to date.
set -eu
cd "$(dirname "$0")/.."
: "${PETRIPLC_MATIEC:?set PETRIPLC_MATIEC to a folder with matiec's iec2c and lib/}"
[ -x "$PETRIPLC_MATIEC/iec2c" ] || { echo "no $PETRIPLC_MATIEC/iec2c" >&2; exit 1; }
[ -d "$PETRIPLC_MATIEC/lib/C" ] || { echo "no $PETRIPLC_MATIEC/lib/C" >&2; exit 1; }
if [ -z "${PETRIPLC_MATIEC_COMMIT:-}" ] && [ -f "$PETRIPLC_MATIEC/COMMIT" ]; then
    PETRIPLC_MATIEC_COMMIT=$(awk '{print $3; exit}' "$PETRIPLC_MATIEC/COMMIT")
fi
export PETRIPLC_MATIEC PETRIPLC_MATIEC_COMMIT="${PETRIPLC_MATIEC_COMMIT:-unknown}"
MATIEC_RECORD=1 cargo test -p petriplc-iec --test conformance_matiec -- --nocapture
