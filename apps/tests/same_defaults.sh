#!/bin/sh
# Usage: same_defaults.sh ROLLSTEP CONTROL_YAML OUT_DIR
# `rollstep sim --controller nmpc` without --control-config runs the library's default
# control settings: its log equals, value for value, that of the same run given the file
# that documents those defaults (config/control.yaml; tests/control/control_settings_test
# checks that it equals ControlSettings{}). A trot at 0.3 m/s towards step20: the speed
# rule, the climbing settings and the solver's iterations all act within the run.
set -u
rollstep=$1 defaults=$2 out=$3
fail() { echo "FAIL: $*"; exit 1; }
rm -rf "$out"
run_plain() {
  "$rollstep" sim --scene step20 --controller nmpc --gait trot --vx 0.3 --duration 0.6 \
    --mpc-timing deterministic --out "$out/plain" >/dev/null || fail "run without a file failed"
}
run_plain
"$rollstep" sim --scene step20 --controller nmpc --gait trot --vx 0.3 --duration 0.6 \
  --mpc-timing deterministic --control-config "$defaults" --out "$out/file" >/dev/null ||
  fail "run with $defaults failed"
cmp -s "$out/plain/log.csv" "$out/file/log.csv" || fail "the logs differ"
grep -q "speed  *trot period" "$out/plain/summary.txt" || fail "no speed rule in the summary"
echo "the default run equals the documented defaults' run"
