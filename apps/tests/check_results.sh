#!/bin/sh
# Usage: check_results.sh ROLLSTEP EXPERIMENTS OUT_DIR
# Trial result files are read as inputs: `trials --collect` counts every trial folder and
# names those it cannot count (unfinished, unreadable: which key, why), escapes their text
# in aggregate.md, refuses the options it does not use; `report --trials` refuses a bad
# result before it touches the previous report; `trials` aggregates exactly its seeds; the
# figure script has a time limit; standard output on a full device is an error.
set -u
rollstep=$1 experiments=$2 out=$3
fail() { echo "FAIL: $*"; exit 1; }
rm -rf "$out"
mkdir -p "$out"
result() {  # result DIR KEY VALUE: a valid result file with KEY: VALUE in place
  mkdir -p "$1"
  {
    echo "scenario: stand_short"
    echo "controller: stand"
    [ "$2" = seed ] || echo "seed: 1"
    echo "step_height: 0.15"
    echo "friction: 0.8"
    echo "start_offset: 0.01"
    echo "sensor_noise: 1"
    echo "sensor_noise_applied: false"
    [ "$2" = passed ] || echo "passed: false"
    [ "$2" = failure ] || echo "failure: \"fell\""
    [ "$2" = traverse_time ] || echo "traverse_time: null"
    echo "mean_abs_vz: null"
    echo "mean_abs_wy: null"
    echo "command: \"rollstep trials --seeds 1\""
    [ -z "$2" ] || [ "$2" = scenario ] || echo "$2: $3"
  } | sed "s/^scenario: stand_short$/scenario: ${SCENARIO:-stand_short}/" > "$1/result.yaml"
}
# collect_error CASE REGEX: --collect of the case's folder lists it as unreadable, and why.
collect_error() {
  "$rollstep" trials --collect "$out/bad/$1" --out "$out/agg_$1" > /dev/null 2> "$out/err"
  rc=$?
  [ $rc -eq 3 ] || fail "$1: expected exit status 3, got $rc: $(cat "$out/err")"
  grep -Eq -- "$2" "$out/err" || fail "$1: stderr does not match $2: $(cat "$out/err")"
}
result "$out/bad/traverse_huge" traverse_time 1e308
collect_error traverse_huge "bad/traverse_huge: unreadable: .*result.yaml: line 1[0-9]: traverse_time: 1e\+?308 is outside"
result "$out/bad/traverse_negative" traverse_time -100
collect_error traverse_negative "line 1[0-9]: traverse_time: -100 is outside"
result "$out/bad/seed_huge" seed 1e30
collect_error seed_huge "seed: '1e30' is not a seed"
result "$out/bad/seed_wraps" seed 18446744073709551616
collect_error seed_wraps "seed: '18446744073709551616' is not a seed"
SCENARIO="{a: 1}" result "$out/bad/scenario_mapping" scenario x
collect_error scenario_mapping "line 1: scenario: expected text"
result "$out/bad/passed_failure" passed true
collect_error passed_failure "passed: true with a failure"
mkdir -p "$out/bad/fifo" && mkfifo "$out/bad/fifo/result.yaml"
collect_error fifo "bad/fifo: unreadable: trial result .*result.yaml': is a FIFO"
mkdir -p "$out/bad/unfinished_seed0007"
collect_error unfinished_seed0007 "unfinished_seed0007: unfinished: no result.yaml"
# Hostile text from a result file: shown, never rendered as markup or new table rows.
result "$out/hostile/a" failure '"fell\n| x | y | 1 | 1 | 100 % |\n<script>alert(1)</script>"'
"$rollstep" trials --collect "$out/hostile" > /dev/null 2>&1 || fail "collect of hostile text"
! grep -q '^| x' "$out/hostile/aggregate.md" || fail "a table row from a result file"
grep -q '^- seed 1: `fell | x | y | 1 | 1 | 100 % | <script>alert(1)</script>`$' \
  "$out/hostile/aggregate.md" || fail "the failure text not shown as it is: $(cat "$out/hostile/aggregate.md")"
# A folder of results reached through a symbolic link is counted; a loop is not followed twice.
result "$out/real/t1" "" ""
mkdir -p "$out/linked" && ln -s "$out/real" "$out/linked/set" && ln -s "$out/linked" "$out/real/loop"
"$rollstep" trials --collect "$out/linked" > "$out/linked.out" 2>&1 || fail "collect through a link"
grep -q '| stand_short | stand | 1 | 0 | 0.0 %' "$out/linked.out" || fail "the linked result not counted once"
# Options that --collect does not use are refused.
for option in "--no-aggregate" "--seeds 1" "--scenario stand_short" "--print-commands" "--jobs 2"; do
  # shellcheck disable=SC2086
  "$rollstep" trials --collect "$out/real" $option > /dev/null 2> "$out/err" && fail "--collect with $option"
  grep -q -- "${option%% *}: is not used by --collect" "$out/err" || fail "$option: $(cat "$out/err")"
done
# report --trials with a bad result: an input error, and the previous report untouched.
mkdir -p "$out/report"
echo "an earlier report" > "$out/report/report.md"
"$rollstep" report --experiments "$experiments" --only stand_short --trials "$out/bad/traverse_huge" \
  --out "$out/report" > /dev/null 2> "$out/err" && fail "report with a bad trial result"
grep -q "traverse_huge.*traverse_time: 1e+*308 is outside" "$out/err" || fail "report's error: $(cat "$out/err")"
[ "$(cat "$out/report/report.md")" = "an earlier report" ] || fail "the earlier report was touched"
# trials aggregates exactly the seeds asked, whatever the folder held before.
"$rollstep" trials --experiments "$experiments" --scenario stand_short --seeds 0-1 --out "$out/t" \
  > /dev/null 2>&1 || fail "trials 0-1"
"$rollstep" trials --experiments "$experiments" --scenario stand_short --seeds 2 --out "$out/t" \
  > /dev/null 2>&1 || fail "trials 2"
grep -q '| stand_short | stand | 1 |' "$out/t/aggregate.md" || fail "the aggregate of seed 2: $(cat "$out/t/aggregate.md")"
"$rollstep" trials --collect "$out/t" > /dev/null 2>&1 || fail "collect"
grep -q '| stand_short | stand | 3 |' "$out/t/aggregate.md" || fail "the collected aggregate"
# --print-commands loads the scenario's scene file: no command is printed that would fail.
printf 'scenarios:\n  - {name: s, title: s, scene: flat, controller: stand, duration: 1, scene_config: %s}\n' \
  "$out/bad_scene.yaml" > "$out/bad_scene_experiments.yaml"
printf 'start_xx: 1\n' > "$out/bad_scene.yaml"
"$rollstep" trials --experiments "$out/bad_scene_experiments.yaml" --scenario s --seeds 0-2 \
  --print-commands --out "$out/p" > "$out/p.out" 2> "$out/err" && fail "--print-commands with a bad scene file"
grep -q "bad_scene.yaml" "$out/err" || fail "--print-commands' error: $(cat "$out/err")"
[ ! -s "$out/p.out" ] || fail "commands printed"
# ... and builds the scene at the ends of the trial ranges: a start offset that puts the
# block inside the robot is an error before any trial.
printf 'scenarios:\n  - {name: s, title: s, scene: step20, controller: stand, duration: 1, scene_config: %s}\n' \
  "$out/near_scene.yaml" > "$out/near_experiments.yaml"
printf 'base: step20\nparameters: {start_x: 0.5}\n' > "$out/near_scene.yaml"
"$rollstep" trials --experiments "$out/near_experiments.yaml" --scenario s --seeds 0-2 \
  --print-commands --out "$out/p" > "$out/p.out" 2> "$out/err" && fail "--print-commands with the block in the robot"
grep -q "start_offset -0.2.*boxes\[0\] (scene config .*step20.yaml': line 12) reaches inside" "$out/err" || fail "near start: $(cat "$out/err")"
# A figure script that never ends is stopped at its time limit, and the report says so.
printf 'import time\ntime.sleep(1000)\n' > "$out/hang.py"
t0=$(date +%s)
ROLLSTEP_FIGURES_SCRIPT="$out/hang.py" ROLLSTEP_FIGURES_TIME_LIMIT=2 "$rollstep" report \
  --experiments "$experiments" --only stand_short --no-videos --trials "$out/bad/unfinished_seed0007" \
  --out "$out/hang" > /dev/null 2> "$out/err" || fail "report with a hanging figure script: $(cat "$out/err")"
[ $(($(date +%s) - t0)) -lt 60 ] || fail "the report waited for the figure script"
grep -q "the figure script did not end within 2 s" "$out/hang/report.md" || fail "the report does not say why"
# ... and it lists the unfinished trial it was given.
grep -q "Not counted: 1 of 1 trial folders hold no result" "$out/hang/report.md" \
  || fail "the report does not list the unfinished trial"
grep -q "unfinished_seed0007.*unfinished: no result.yaml" "$out/hang/report.md" || fail "the unfinished trial's reason"
# ffmpeg that never takes its frames: stopped at the time limit, the report says why.
mkdir -p "$out/bin"
printf '#!/bin/sh\nexec sleep 1000\n' > "$out/bin/ffmpeg" && chmod +x "$out/bin/ffmpeg"
t0=$(date +%s)
PATH="$out/bin:$PATH" ROLLSTEP_FIGURES_SCRIPT="$out/none.py" ROLLSTEP_FIGURES_TIME_LIMIT=2 \
  "$rollstep" report --experiments "$experiments" --only stand_video --out "$out/video" > /dev/null \
  2> "$out/err" || fail "report with a stuck ffmpeg: $(cat "$out/err")"
[ $(($(date +%s) - t0)) -lt 60 ] || fail "the report waited for ffmpeg"
if grep -q "Videos not available" "$out/video/report.md"; then
  echo "videos not available here: ffmpeg's time limit not checked"
else
  grep -q "Pictures failed: stand_video: ffmpeg did not finish .* within 2 s and was stopped" \
    "$out/video/report.md" || fail "the report does not say why the video is missing"
  [ -z "$(find "$out/video" -name 'video_*')" ] || fail "a part of the video is left"
fi
# Standard output on a full device: an error of every command, not exit status 0.
if [ -w /dev/full ]; then
  "$rollstep" trials --collect "$out/t" > /dev/full 2> "$out/err" && fail "trials wrote to /dev/full"
  grep -q "cannot write to standard output" "$out/err" || fail "trials: $(cat "$out/err")"
  "$rollstep" plan --duration 0.3 --out "$out/plan" > /dev/full 2> "$out/err" && fail "plan wrote to /dev/full"
  grep -q "standard output" "$out/err" || fail "plan: $(cat "$out/err")"
  "$rollstep" report --experiments "$experiments" --only stand_short --no-videos --out "$out/full" \
    > /dev/full 2> "$out/err" && fail "report wrote to /dev/full"
  grep -q "standard output" "$out/err" || fail "report: $(cat "$out/err")"
  "$rollstep" sim --duration 0.05 --out "$out/sim" > /dev/full 2> "$out/err" && fail "sim wrote to /dev/full"
fi
# sim --log-map naming a file: an input error, found before the previous outputs are removed.
"$rollstep" sim --duration 0.05 --out "$out/keep" > /dev/null || fail "sim"
"$rollstep" sim --controller cbfqp --terrain perception --duration 0.1 --log-map "$experiments" \
  --out "$out/keep" > /dev/null 2> "$out/err" && fail "sim --log-map a file"
grep -q -- "--log-map '.*': cannot create the directory: exists and is not a directory" "$out/err" \
  || fail "sim --log-map: $(cat "$out/err")"
[ -f "$out/keep/log.csv" ] && [ -f "$out/keep/summary.txt" ] && [ ! -e "$out/keep/FAILED" ] \
  || fail "sim --log-map a file: the previous outputs were touched"
# A word that is not a command.
"$rollstep" nosuch 2> "$out/err" && fail "rollstep nosuch"
grep -q "'nosuch' is not a command (the commands: sim, plan, report, trials" "$out/err" || fail "nosuch: $(cat "$out/err")"
echo "results check passed"
