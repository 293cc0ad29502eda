#!/bin/sh
# Usage: check_interrupt.sh COMMAND ROLLSTEP EXPERIMENTS OUT_DIR
# A run of `rollstep COMMAND` (sim, plan, report or trials) interrupted part-way by SIGINT
# or SIGTERM, as a user's Ctrl-C or a scheduler's kill would: it must end within a second
# with status 128 + the signal, leave its folder with the previous outputs untouched or only
# FAILED with the reason, and no temporary files.
set -u
command=$1 rollstep=$2 experiments=$3 out=$4
fail() { echo "FAIL: $*"; ls -laR "$out" 2>/dev/null | head -60; exit 1; }
rm -rf "$out"
mkdir -p "$out"
# A script's background jobs start with SIGINT ignored (and rollstep keeps it so, as nohup's
# SIGHUP): the runs to interrupt start with the default, as from a terminal.
interruptible="env --default-signal=INT"

# Waits (at most 60 s) until a file matching the pattern exists: the run is under way.
wait_for() {
  n=0
  while [ -z "$(find "$out" -path "$1" 2>/dev/null | head -1)" ]; do
    n=$((n + 1))
    [ $n -le 600 ] || fail "no $1 after 60 s"
    sleep 0.1
  done
}
# Sends signal $2 to process $1 and checks that it ends within a second with 128 + signal.
interrupt() {
  pid=$1 sig=$2 code=$3
  t0=$(date +%s%N)
  kill -s "$sig" "$pid"
  wait "$pid"
  rc=$?
  t1=$(date +%s%N)
  ms=$(((t1 - t0) / 1000000))
  echo "$command: SIG$sig -> exit status $rc after $ms ms"
  [ "$rc" -eq "$code" ] || fail "SIG$sig: expected exit status $code, got $rc"
  [ "$ms" -le 1000 ] || fail "SIG$sig: the run took $ms ms to end"
}
no_temporaries() {
  left=$(find "$out" -name '.*.tmp.*')
  [ -z "$left" ] || fail "temporary files left: $left"
}

case $command in
sim)
  "$rollstep" sim --duration 0.05 --out "$out/run" > /dev/null || fail "the first run"
  [ -f "$out/run/log.csv" ] || fail "the first run left no log.csv"
  # With the map log: a run that ends part-way leaves neither the map's index nor its
  # snapshots (nor the earlier run's).
  $interruptible "$rollstep" sim --controller cbfqp --gait trot --vx 0.1 --terrain perception \
    --log-map "$out/run/map" --duration 60 --out "$out/run" 2> "$out/stderr" &
  pid=$!
  wait_for "$out/run/map/heights_0001.npy"
  interrupt $pid INT 130
  [ "$(ls -A "$out/run" | tr '\n' ' ')" = "FAILED map " ] || fail "left in the folder: $(ls -A "$out/run")"
  grep -q "rollstep sim failed: interrupted by SIGINT" "$out/run/FAILED" || fail "FAILED: $(cat "$out/run/FAILED")"
  [ -z "$(ls -A "$out/run/map")" ] || fail "map log left: $(ls -A "$out/run/map")"
  grep -q "interrupted by SIGINT" "$out/stderr" || fail "no message on stderr"
  no_temporaries
  $interruptible "$rollstep" sim --duration 60 --out "$out/run" 2> /dev/null &
  pid=$!
  wait_for "$out/run/.log.csv.tmp.*"
  interrupt $pid TERM 143
  [ "$(ls -A "$out/run" | tr '\n' ' ')" = "FAILED map " ] || fail "left in the folder: $(ls -A "$out/run")"
  grep -q "interrupted by SIGTERM" "$out/run/FAILED" || fail "FAILED: $(cat "$out/run/FAILED")"
  no_temporaries
  # SIGKILL cannot be handled: the next run removes what the killed one left.
  $interruptible "$rollstep" sim --controller cbfqp --gait trot --vx 0.1 --terrain perception \
    --log-map "$out/run/map" --duration 60 --out "$out/run" 2> /dev/null &
  pid=$!
  wait_for "$out/run/map/heights_0001.npy"
  kill -s KILL $pid
  wait $pid
  [ -n "$(find "$out" -name '.*.tmp.*')" ] || fail "SIGKILL: no temporaries to clean up (test)"
  $interruptible "$rollstep" sim --controller cbfqp --gait trot --vx 0.1 --terrain perception \
    --log-map "$out/run/map" --duration 0.05 --out "$out/run" > /dev/null 2>&1 || fail "the run after SIGKILL"
  no_temporaries
  ;;
plan)
  "$rollstep" plan --duration 1.5 --out "$out/plan" > /dev/null || fail "the first plan"
  cp -r "$out/plan" "$out/before"
  # A long solve: interrupted, the previous plan stays as it was. Without the solver's huge
  # pages: the kernel's work for them (MADV_COLLAPSE, compaction in page faults) cannot be
  # interrupted and took up to 5 s on a loaded machine; this checks rollstep's own part.
  printf 'solver:\n  huge_pages: false\n' > "$out/no_huge_pages.yaml"
  $interruptible "$rollstep" plan --duration 20 --config "$out/no_huge_pages.yaml" --out "$out/plan" > /dev/null 2>&1 &
  pid=$!
  sleep 1
  interrupt $pid TERM 143
  diff -r "$out/before" "$out/plan" || fail "the previous plan changed"
  $interruptible "$rollstep" plan --duration 20 --config "$out/no_huge_pages.yaml" --out "$out/plan" > /dev/null 2>&1 &
  pid=$!
  sleep 1
  interrupt $pid INT 130
  diff -r "$out/before" "$out/plan" || fail "the previous plan changed"
  no_temporaries
  ;;
report)
  # An earlier report in the folder: replaced as a whole, so interrupted, none is left.
  mkdir -p "$out/report"
  echo "an earlier report" > "$out/report/report.md"
  echo "an earlier report" > "$out/report/report.html"
  $interruptible "$rollstep" report --experiments "$experiments" --no-videos --out "$out/report" \
    > /dev/null 2> "$out/stderr" &
  pid=$!
  wait_for "$out/report/runs/stand_long/.log.csv.tmp.*"
  sleep 0.3
  interrupt $pid INT 130
  grep -q "rollstep report failed: interrupted by SIGINT" "$out/report/FAILED" || fail "no FAILED"
  [ ! -e "$out/report/report.md" ] && [ ! -e "$out/report/report.html" ] || fail "a report is left"
  grep -q "interrupted by SIGINT" "$out/report/runs/stand_long/FAILED" || fail "the run's FAILED"
  [ ! -e "$out/report/runs/stand_long/log.csv" ] || fail "the run's log is left"
  no_temporaries
  ;;
trials)
  # Two trial processes at once; the parent alone gets SIGTERM (as from a scheduler) and
  # passes it on: every unfinished trial leaves FAILED, the folder no aggregate.
  $interruptible "$rollstep" trials --experiments "$experiments" --scenario stand_long --seeds 0-3 --jobs 2 \
    --out "$out/trials" > /dev/null 2> "$out/stderr" &
  pid=$!
  wait_for "$out/trials/stand_long_seed0000/sim/.log.csv.tmp.*"
  wait_for "$out/trials/stand_long_seed0001/sim/.log.csv.tmp.*"
  sleep 0.3
  interrupt $pid TERM 143
  grep -q "rollstep trials failed: interrupted by SIGTERM" "$out/trials/FAILED" || fail "no FAILED"
  [ ! -e "$out/trials/aggregate.md" ] || fail "an aggregate is left"
  for s in 0000 0001; do
    d="$out/trials/stand_long_seed$s"
    [ -f "$d/FAILED" ] || fail "seed $s: no FAILED"
    [ ! -e "$d/result.yaml" ] || fail "seed $s: a result is left"
    grep -q "interrupted by SIGTERM" "$d/sim/FAILED" || fail "seed $s: the sim's FAILED"
  done
  [ ! -e "$out/trials/stand_long_seed0002" ] || fail "a trial started after the interrupt"
  no_temporaries
  # The unfinished trials are listed, not left out.
  "$rollstep" trials --collect "$out/trials" > "$out/collect" 2>&1
  rc=$?
  cat "$out/collect"
  [ $rc -eq 3 ] || fail "--collect of unfinished trials: expected exit status 3, got $rc"
  grep -q "not counted: .*stand_long_seed0001: unfinished: rollstep trials failed" "$out/collect" \
    || fail "--collect does not name the unfinished trial"
  # In one process, SIGINT as from Ctrl-C.
  $interruptible "$rollstep" trials --experiments "$experiments" --scenario stand_long --seeds 5 \
    --out "$out/one" > /dev/null 2>&1 &
  pid=$!
  wait_for "$out/one/stand_long_seed0005/sim/.log.csv.tmp.*"
  interrupt $pid INT 130
  grep -q "interrupted by SIGINT" "$out/one/stand_long_seed0005/FAILED" || fail "no trial FAILED"
  [ ! -e "$out/one/stand_long_seed0005/result.yaml" ] || fail "a result is left"
  no_temporaries
  ;;
*)
  fail "unknown command $command"
  ;;
esac
echo "interrupt check passed"
