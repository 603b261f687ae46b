#!/usr/bin/env bash
# scripts/check-thread-safety on the fixtures beside this file: shared state touched as its
# annotations say passes; a guarded member read without its lock, a REQUIRES function called
# without it and a read after letting go each fail, naming the file, the line and the mutex.
set -euo pipefail
check=${1:?usage: check_thread_safety_test.sh PATH/TO/check-thread-safety}
here=$(cd "$(dirname "$0")" && pwd)
out=$(mktemp /tmp/fleetmap-thread-safety-test.XXXXXX)
trap 'rm -f "$out"' EXIT

expect_pass() {  # what, fixture
  if ! "$check" --files "$here/$2" >"$out" 2>&1; then
    echo "FAIL: $1: check-thread-safety refused it:"; cat "$out"; exit 1
  fi
  echo "ok: $1"
}
expect_fail() {  # what, fixtures (space-separated), strings the message must hold...
  local what=$1 fixture files=()
  for fixture in $2; do files+=("$here/$fixture"); done
  shift 2
  if "$check" --files "${files[@]}" >"$out" 2>&1; then
    echo "FAIL: $what: check-thread-safety passed"; cat "$out"; exit 1
  fi
  for text in "$@"; do
    if ! grep -qF -- "$text" "$out"; then
      echo "FAIL: $what: the message does not say '$text':"; cat "$out"; exit 1
    fi
  done
  echo "ok: $what"
}

expect_pass "state touched under its lock" locked_counter.cc
expect_fail "a guarded member read without its lock" unguarded_read.cc \
  "unguarded_read.cc:13:" "reading variable 'count_' requires holding mutex 'mutex_'" \
  "-Werror,-Wthread-safety-analysis"
expect_fail "a REQUIRES function called without the lock" unlocked_call.cc \
  "unlocked_call.cc:9:" "calling function 'PushLocked' requires holding mutex 'mutex_'"
expect_fail "a read after letting the lock go" unlocked_call.cc \
  "unlocked_call.cc:13:" "reading variable 'size_' requires holding mutex 'mutex_'"
expect_fail "one unguarded file among sound ones" "locked_counter.cc unguarded_read.cc" \
  "unguarded_read.cc:13:" "1 of 2 units break the locking they declare"
