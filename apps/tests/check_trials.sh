#!/bin/sh
# Usage: check_trials.sh ROLLSTEP EXPERIMENTS OUT_DIR
# Two short randomized trials with two local processes, the printed commands, and the
# collection of results written elsewhere.
rollstep=$1
experiments=$2
out=$3
rm -rf "$out" "$out.elsewhere" "$out.report" "$out.named"
fail() { echo "FAIL: $*"; exit 1; }
set -- --experiments "$experiments" --scenario step20 --controller nmpc
"$rollstep" trials "$@" --seeds 0-1 --jobs 2 --out "$out" || fail "trials exited $?"
for s in 0000 0001; do
  [ -s "$out/step20_short_seed$s/result.yaml" ] || fail "no result file of seed $s"
  [ -s "$out/step20_short_seed$s/sim/run.yaml" ] || fail "no run spec of seed $s"
  [ ! -e "$out/step20_short_seed$s/scene.yaml" ] || fail "a scene file beside seed $s's spec"
  [ -s "$out/step20_short_seed$s/sensors.yaml" ] || fail "no sensor file of seed $s"
done
grep -q '^seed: 1$' "$out/step20_short_seed0001/sensors.yaml" || fail "seed 1's sensor noise seed"
grep -q '^sensor_noise_applied: false$' "$out/step20_short_seed0001/result.yaml" \
  || fail "a ground-truth run reads no sensors"
grep -q '^seed: 1$' "$out/step20_short_seed0001/result.yaml" || fail "seed 1's file"
# The drawn step height: in the result file and, as the scene's number, in the run spec.
height=$(sed -n 's/^step_height: //p' "$out/step20_short_seed0001/result.yaml")
[ -n "$height" ] || fail "no drawn step height in the result file"
grep -q "^  step1_height: $height\$" "$out/step20_short_seed0001/sim/run.yaml" \
  || fail "randomized step height not in the run spec"
grep -q '| step20_short | nmpc | 2 | 0 | 0.0 %' "$out/aggregate.md" || fail "aggregate"
grep -q 'seed 0: did not traverse the step' "$out/aggregate.md" || fail "failure reasons"
# One command per seed, each self-contained; run one of them by hand elsewhere, then collect.
"$rollstep" trials "$@" --seeds 3-5 --print-commands --out "$out.elsewhere" > "$out.commands"
[ "$(wc -l < "$out.commands")" -eq 3 ] || fail "expected 3 commands"
grep -q -- "--seeds 4 --no-aggregate --out $out.elsewhere" "$out.commands" || fail "command of seed 4"
sh -c "$(sed -n 2p "$out.commands")" > /dev/null || fail "the printed command failed"
"$rollstep" trials --collect "$out" --collect "$out.elsewhere" --out "$out" > "$out.collect" \
  || fail "collect"
cat "$out.collect"
grep -q '| step20_short | nmpc | 3 | 0 | 0.0 %' "$out.collect" || fail "collected aggregate"
# A scenario by its name (no --controller): the same scenario, the same result file.
"$rollstep" trials --experiments "$experiments" --scenario step20_short --seeds 2 --out "$out.named" \
  > /dev/null || fail "trials by scenario name exited $?"
grep -q '^scenario: step20_short$' "$out.named/step20_short_seed0002/result.yaml" \
  || fail "the named scenario's result file"
grep -q -- '--scenario step20_short --seeds 2 --no-aggregate' \
  "$out.named/step20_short_seed0002/result.yaml" || fail "the named scenario's command"
# The report includes trials collected from a folder.
"$rollstep" report --experiments "$experiments" --only flat_trot --no-videos --trials "$out" \
  --out "$out.report" > /dev/null 2>&1 || fail "report --trials"
grep -q '| step20_short | nmpc | 2 | 0 | 0.0 % | - | - | - |' "$out.report/report.md" \
  || fail "the report's trials table"
echo "trials check passed"
