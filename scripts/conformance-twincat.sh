#!/bin/sh
# The TwinCAT 3 reader on real TwinCAT files: fetches github.com/mihaiginta/TcOscatBasic (OSCAT
# BASIC 3.35 as .TcPOU/.TcDUT/.TcGVL files and a .plcproj; not copied into the repository) at the
# commit ../shared/corpora/oscat was extracted from, into target/tcoscat, and runs
# crates/compiler/iec/tests/conformance_twincat.rs on it (every original read as its extracted
# text; the figures are printed).
set -eu
cd "$(dirname "$0")/.."
dir=target/tcoscat
commit=a58501fe6cadc4bddd674afad25c4c04e006b564
if [ ! -d "$dir/.git" ]; then
    git clone --quiet https://github.com/mihaiginta/TcOscatBasic "$dir"
fi
git -C "$dir" checkout --quiet "$commit"
PETRIPLC_TCOSCAT="$PWD/$dir" cargo test -p petriplc-iec --test conformance_twincat -- --nocapture
