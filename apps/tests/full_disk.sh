#!/bin/sh
# Usage: full_disk.sh ROLLSTEP DIR [EXPERIMENTS]
# A run into a 64 kB tmpfs fills it: the error names the file and the reason, the exit
# status is 74 (an output could not be written) and no log.csv or summary.txt is left.
# With EXPERIMENTS (a short experiments file): only the report, on disks that fill at its
# first run and part-way through its pages. Exit 77 (skipped) if mounting a tmpfs is not
# permitted.
set -u
rollstep=$1 dir=$2 experiments=${3:-}
umount "$dir" 2>/dev/null
mkdir -p "$dir" || exit 1
mount -t tmpfs -o size=64k tmpfs "$dir" 2>/dev/null || { echo "cannot mount a tmpfs: skipped"; exit 77; }
umount "$dir"

if [ -n "$experiments" ]; then
  # The report fails as a whole with status 74 (a run that cannot write its log is not a
  # failed experiment; a replay page that cannot be written is not a warning): DIR holds
  # FAILED with the reason, no report.md, report.html, figures or temporaries.
  for size in 64k 1000k; do
    mount -t tmpfs -o size=$size tmpfs "$dir" || exit 1
    err=$("$rollstep" report --experiments "$experiments" --out "$dir/report" 2>&1 >/dev/null)
    rc=$?
    echo "$err" | tail -n 2
    top=$(ls -A "$dir/report" | tr '\n' ' ')
    temporaries=$(find "$dir/report" -name '*.tmp.*')
    failed=$(cat "$dir/report/FAILED" 2>/dev/null)
    umount "$dir"
    [ $rc -eq 74 ] || { echo "FAIL: report on a $size disk: exit status $rc"; exit 1; }
    [ "$top" = "FAILED runs " ] || { echo "FAIL: report on a $size disk left: $top"; exit 1; }
    [ -z "$temporaries" ] || { echo "FAIL: report on a $size disk left: $temporaries"; exit 1; }
    echo "$failed" | grep -q "rollstep report failed: .*No space left on device" ||
      { echo "FAIL: report's FAILED on a $size disk: $failed"; exit 1; }
  done
  # A trial that cannot write its outputs is no verdict on the controller: trials fails
  # with 74 instead of counting a failed trial.
  mount -t tmpfs -o size=64k tmpfs "$dir" || exit 1
  "$rollstep" trials --experiments "$experiments" --scenario step20_short --controller nmpc \
    --seeds 0-1 --out "$dir/trials" >/dev/null 2>&1
  rc=$?
  results=$(find "$dir/trials" -name result.yaml)
  failed=$(cat "$dir/trials/FAILED" 2>/dev/null)
  umount "$dir"
  [ $rc -eq 74 ] || { echo "FAIL: trials on a full disk: exit status $rc"; exit 1; }
  [ -z "$results" ] || { echo "FAIL: trials on a full disk left results: $results"; exit 1; }
  echo "$failed" | grep -q "No space left on device" || { echo "FAIL: trials' FAILED: $failed"; exit 1; }
  echo "full disk reported, nothing partial left"
  exit 0
fi

mount -t tmpfs -o size=64k tmpfs "$dir" || exit 1
err=$("$rollstep" sim --duration 5 --log-every 1 --out "$dir/run" 2>&1 >/dev/null)
rc=$?
echo "$err"
echo "exit status $rc"
left=$(ls -A "$dir/run" 2>/dev/null)
umount "$dir"
[ $rc -eq 74 ] || { echo "FAIL: exit status $rc"; exit 1; }
echo "$err" | grep -q "log.csv.*No space left on device" || { echo "FAIL: message"; exit 1; }
case "$left" in
  *log.csv* | *summary.txt* | *.tmp.*) echo "FAIL: left behind: $left"; exit 1 ;;
esac
# plan replaces its three files as a whole: a longer plan (about 250 kB) fills the disk that
# held the first (150 kB) part-way; no new file is left beside an old one, only FAILED with
# the reason.
mount -t tmpfs -o size=200k tmpfs "$dir" || exit 1
"$rollstep" plan --duration 1.5 --out "$dir/plan" > /dev/null 2>&1 || { umount "$dir"; echo "FAIL: the first plan"; exit 1; }
err=$("$rollstep" plan --duration 2.5 --out "$dir/plan" 2>&1 >/dev/null)
rc=$?
echo "$err"
left=$(ls -A "$dir/plan" | tr '\n' ' ')
failed=$(cat "$dir/plan/FAILED" 2>/dev/null)
umount "$dir"
[ $rc -eq 74 ] || { echo "FAIL: plan on a full disk: exit status $rc"; exit 1; }
[ "$left" = "FAILED " ] || { echo "FAIL: plan on a full disk left: $left"; exit 1; }
echo "$failed" | grep -q "rollstep plan failed: .*No space left on device" || { echo "FAIL: plan's FAILED: $failed"; exit 1; }
echo "full disk reported, nothing partial left ($left)"
