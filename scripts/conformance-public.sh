#!/bin/sh
# `petriplc check` on a public corpus of IEC 61131-3 code written by others (OpenPLC users'
# programs, Beremiz projects, other compilers' test suites, TwinCAT libraries): per-file
# verdicts, the accepted share per source and a table of first errors by code
# (scripts/conformance_public.py does the work; docs/iec.md, "How it is tested", has figures).
#
# The code is not in the repository: PETRIPLC_PUBLIC names a directory of snapshots, each
# repository below as `OWNER+NAME/repo` (a bare git directory, as the snapshot tool lays
# them) or `OWNER+NAME` (a checkout); each is read at the commit listed here. A repository
# that is missing is reported and left out of the figures.
#
#   PETRIPLC_PUBLIC=/path/to/snapshots sh scripts/conformance-public.sh
#
# Files that are not valid for any compiler (a suite's tests of its own errors) are counted
# apart. With matiec (PETRIPLC_MATIEC=DIR holding iec2c and its lib/, or DIR/READY beside
# them), matiec's verdict on every Structured Text file is a column too.
# PETRIPLC_PUBLIC_OUT=FILE writes the per-file verdicts there (tab-separated) as well.
set -eu
cd "$(dirname "$0")/.."
: "${PETRIPLC_PUBLIC:?set PETRIPLC_PUBLIC to a directory of repository snapshots}"
cargo build --quiet -p petriplc --bin petriplc
exec python3 scripts/conformance_public.py target/debug/petriplc "$PETRIPLC_PUBLIC" <<'EOF'
# source | repository | commit | dialect | unit | files (globs; !glob leaves out; ?glob: invalid on purpose)
openplc-users | gracesrm/OpenPLC_Sample_Programs | 6a2b13e1c09a | auto | file | *.st *plc.xml !*/build/* !*RobotStudio/RobotStudio/PLCPython/*
openplc-users | kato-works/openplc_school_01 | 08c47f3f86b8 | auto | file | */OpenPLC Runtime v4/src/program.st
openplc-users | jasoncala/openplc-temperature-control | 8592032bf578 | auto | file | plc/exported/*.st
openplc-users | extralsc/openPLC_watertank | a130250d1623 | auto | file | *.st
openplc-users | thiagoralves/OpenPLC_v3 | bb35f6966b3e | auto | file | webserver/st_files/*.st
openplc-oscat | wonka929/OSCAT_OpenPLC | 7805d6df1fba | auto | file | */build/generated_plc.st
beremiz | beremiz/beremiz | 9eb53af357cd | auto | file | exemples/*/plc.xml tests/projects/*/plc.xml
matiec | beremiz/matiec | 6bb2c339df6f | iec | file | lib/*.txt tests/*_TEST.xml
ironplc | ironplc/ironplc | 755a31748528 | auto | file | compiler/resources/test/*.st compiler/plc2plc/resources/test/*.st compiler/ironplc-cli/resources/test/*.st examples/*.st tests/e2e/*.st integrations/vscode/*.st ?*_error.st ?*/binary_file.st ?*/invalid.st
blark | klauer/blark | 1922eed94885 | auto | file | blark/tests/source/*.st blark/tests/POUs/*.TcPOU
twincat-tcunit | tcunit/TcUnit | d447f95dff58 | twincat | project | TcUnit/TcUnit/TcUnit.plcproj
twincat-collections | fisothemes/TwinCat-Dynamic-Collections | d1317df9075d | twincat | project | src/*TcDynCollections.plcproj
codesys-export | MichielVanwelsenaere/HomeAutomation.CoDeSys3 | 298b7bfd7376 | codesys | file | src/Exports/PLCopen.xml
EOF
