#!/bin/sh
# Usage: check_outputs.sh ROLLSTEP DIVERGING_ROBOT OUT_DIR
# The outputs rule of `rollstep sim`: a successful run leaves DIR/log.csv (units in the
# header) and DIR/summary.txt; a run that fails after it started (here: a robot whose
# simulation diverges at once) removes them, leaves DIR/FAILED with the error and no
# temporary files, and exits non-zero; the next successful run removes FAILED.
set -u
rollstep=$1 robot=$2 out=$3
fail() { echo "FAIL: $*"; ls -la "$out"; exit 1; }
rm -rf "$out"
"$rollstep" sim --duration 0.05 --out "$out" || fail "first run failed"
[ -f "$out/log.csv" ] && [ -f "$out/summary.txt" ] && [ -f "$out/replay.json" ] || fail "no log.csv, summary.txt or replay.json"
head -n 1 "$out/log.csv" | grep -q 'time\[s\],base_x\[m\]' || fail "no units in the CSV header"
"$rollstep" sim --duration 0.05 --robot "$robot" --out "$out"
rc=$?
[ $rc -ge 1 ] && [ $rc -le 123 ] || fail "diverging run exited with $rc"
[ -f "$out/FAILED" ] || fail "no FAILED marker"
grep -q "diverged" "$out/FAILED" || fail "FAILED does not hold the error"
[ ! -e "$out/log.csv" ] && [ ! -e "$out/summary.txt" ] || fail "old or partial results left"
[ -z "$(ls -A "$out" | grep -v '^FAILED$')" ] || fail "temporary files left"
"$rollstep" sim --duration 0.05 --out "$out" >/dev/null || fail "third run failed"
[ ! -e "$out/FAILED" ] && [ -f "$out/summary.txt" ] || fail "FAILED not removed by a good run"
echo "outputs rule holds"
