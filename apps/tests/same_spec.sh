#!/bin/sh
# Usage: same_spec.sh ROLLSTEP OUT_DIR
# A run given as options and the same run given as its spec file (the run.yaml the first
# wrote) write the same log.csv and plan.csv.gz, byte for byte, and the same run.yaml but for
# the output folder. An NMPC trot on the estimator's state with a command schedule: the
# estimator, the sensors and the schedule all come through the spec. Then the run again in
# its own folder (--spec DIR/run.yaml --out DIR): an interrupted rerun leaves its run.yaml
# (the input) in place beside FAILED, a finished one the same run.yaml. Then control settings
# given inline (control:) instead of a file.
set -u
rollstep=$1 out=$2
fail() { echo "FAIL: $*"; exit 1; }
rm -rf "$out"
"$rollstep" sim --scene step20 --controller nmpc --gait trot --command 0:0.2,0.3:0.1:0:0.1 \
  --duration 0.5 --mpc-timing deterministic --state-source inekf --log-every 5 \
  --out "$out/options" >/dev/null || fail "the run with options failed"
[ -f "$out/options/run.yaml" ] || fail "no run.yaml"
"$rollstep" sim --spec "$out/options/run.yaml" --out "$out/spec" >/dev/null ||
  fail "the run of the spec failed"
cmp -s "$out/options/log.csv" "$out/spec/log.csv" || fail "the logs differ"
cmp -s "$out/options/plan.csv.gz" "$out/spec/plan.csv.gz" || fail "the plans differ"
grep -v '^out:' "$out/options/run.yaml" > "$out/a.yaml"
grep -v '^out:' "$out/spec/run.yaml" > "$out/b.yaml"
cmp -s "$out/a.yaml" "$out/b.yaml" || fail "the run.yaml files differ"
grep -q '^state_source: inekf$' "$out/spec/run.yaml" || fail "run.yaml lacks the state source"
# In place, interrupted (SIGTERM) once the run is under way: the spec it was given stays.
cp "$out/spec/run.yaml" "$out/given.yaml"
sed -i 's/^duration: .*/duration: 60/' "$out/spec/run.yaml"
"$rollstep" sim --spec "$out/spec/run.yaml" --out "$out/spec" >/dev/null 2>&1 &
pid=$!
# The previous run's log.csv goes when the run starts writing (interrupts are then caught).
i=0
while [ -e "$out/spec/log.csv" ] && [ $i -lt 600 ]; do sleep 0.1; i=$((i + 1)); done
sleep 0.5
kill -TERM $pid; wait $pid  # SIGTERM: a background job of sh ignores SIGINT
[ -f "$out/spec/FAILED" ] || fail "the interrupted rerun left no FAILED"
[ -f "$out/spec/run.yaml" ] || fail "the interrupted rerun removed its input spec run.yaml"
# In place, to the end: the same run.yaml.
cp "$out/given.yaml" "$out/spec/run.yaml"
"$rollstep" sim --spec "$out/spec/run.yaml" --out "$out/spec" >/dev/null ||
  fail "the rerun in place failed"
cmp -s "$out/given.yaml" "$out/spec/run.yaml" || fail "the rerun in place changed run.yaml"
cmp -s "$out/options/log.csv" "$out/spec/log.csv" || fail "the rerun in place logs differently"
# Control settings inline: a spec whose control: section holds a control file's keys runs as
# the file given by --control-config, and the run.yaml it writes (the settings whole, inline)
# runs the same again.
printf 'mpc:\n  period: 0.04\n  latency: 0.02\nfeedback:\n  foot_kp: 300\n' > "$out/control.yaml"
"$rollstep" sim --scene step20 --controller nmpc --gait trot --vx 0.15 --duration 0.3 \
  --mpc-timing deterministic --control-config "$out/control.yaml" --log-every 5 \
  --out "$out/file" >/dev/null || fail "the run with a control file failed"
grep -v '^control_config:' "$out/file/run.yaml" | grep -v '^control: null$' > "$out/inline.yaml"
printf 'control:\n  mpc: {period: 0.04, latency: 0.02}\n  feedback: {foot_kp: 300}\n' \
  >> "$out/inline.yaml"
"$rollstep" sim --spec "$out/inline.yaml" --out "$out/inline" >/dev/null ||
  fail "the run of the inline spec failed"
cmp -s "$out/file/log.csv" "$out/inline/log.csv" || fail "the inline settings log differently"
cmp -s "$out/file/plan.csv.gz" "$out/inline/plan.csv.gz" || fail "the inline settings plan differently"
grep -q '^  feedback:$' "$out/inline/run.yaml" || fail "run.yaml lacks the inline settings"
"$rollstep" sim --spec "$out/inline/run.yaml" --out "$out/inline_again" >/dev/null ||
  fail "the run of the written inline spec failed"
cmp -s "$out/file/log.csv" "$out/inline_again/log.csv" ||
  fail "the written inline spec logs differently"
grep -v '^out:' "$out/inline/run.yaml" > "$out/c.yaml"
grep -v '^out:' "$out/inline_again/run.yaml" > "$out/d.yaml"
cmp -s "$out/c.yaml" "$out/d.yaml" || fail "the inline run.yaml files differ"
echo "the spec's run equals the options' run"
