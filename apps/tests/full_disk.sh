#!/bin/sh
# Usage: full_disk.sh ROLLSTEP DIR
# A run into a 64 kB tmpfs fills it: the error names the file and the reason, the exit
# status is non-zero and no log.csv or summary.txt is left. Exit 77 (skipped) if
# mounting a tmpfs is not permitted.
set -u
rollstep=$1 dir=$2
umount "$dir" 2>/dev/null
mkdir -p "$dir" || exit 1
mount -t tmpfs -o size=64k tmpfs "$dir" 2>/dev/null || { echo "cannot mount a tmpfs: skipped"; exit 77; }
err=$("$rollstep" sim --duration 5 --log-every 1 --out "$dir/run" 2>&1 >/dev/null)
rc=$?
echo "$err"
echo "exit status $rc"
left=$(ls -A "$dir/run" 2>/dev/null)
umount "$dir"
[ $rc -ge 1 ] && [ $rc -le 123 ] || { echo "FAIL: exit status $rc"; exit 1; }
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
[ $rc -ge 1 ] && [ $rc -le 123 ] || { echo "FAIL: plan on a full disk: exit status $rc"; exit 1; }
[ "$left" = "FAILED " ] || { echo "FAIL: plan on a full disk left: $left"; exit 1; }
echo "$failed" | grep -q "rollstep plan failed: .*No space left on device" || { echo "FAIL: plan's FAILED: $failed"; exit 1; }
echo "full disk reported, nothing partial left ($left)"
