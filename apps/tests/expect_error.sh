#!/bin/sh
# Usage: expect_error.sh REGEX PROGRAM [ARGS...]
# Passes if PROGRAM exits with a clear error status (1..123: not 0, not a crash or a
# timeout) and its standard error matches the extended regular expression REGEX.
# With MKFIFO=PATH in the environment, PATH is made a FIFO first (a program that opens
# it for reading would block: the 30 s timeout then fails the test).
regex=$1
shift
if [ -n "$MKFIFO" ]; then
  rm -f "$MKFIFO" && mkfifo "$MKFIFO" || exit 1
fi
err=$(mktemp)
timeout 30 "$@" 2>"$err"
rc=$?
cat "$err"
echo "exit status $rc"
ok=1
if [ $rc -lt 1 ] || [ $rc -gt 123 ]; then
  echo "FAIL: expected an exit status in 1..123"
  ok=0
fi
if ! grep -Eq -- "$regex" "$err"; then
  echo "FAIL: standard error does not match: $regex"
  ok=0
fi
rm -f "$err"
[ -n "$MKFIFO" ] && rm -f "$MKFIFO"
[ $ok = 1 ]
