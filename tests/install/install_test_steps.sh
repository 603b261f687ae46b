# Sourced by the install tests (outside_project_test.sh, debian_package_test.sh): each runs as
# named steps whose output is shown only when a step fails, in a temporary directory removed at
# the end, however the test ends.

# install_test_start WORK_PARENT NAME: makes $work under WORK_PARENT and the trap that reports
# the failed step ($step) with the end of its output ($log) and removes $work.
install_test_start() {
  mkdir -p "$1"
  work=$(mktemp -d "$1/$2.XXXXXX")
  log=$work/step.log
  step="setup"
  trap install_test_end EXIT
}

install_test_end() {
  local rc=$?
  if [ $rc -ne 0 ]; then
    echo "FAILED at step: $step (exit $rc)" >&2
    if [ -s "$log" ]; then
      echo "--- output of that step (last 60 lines) ---" >&2
      tail -n 60 "$log" >&2
    fi
  fi
  rm -rf "$work"
}

# run STEP COMMAND...: runs one step with its output in $log.
run() {
  step=$1
  shift
  echo "== $step"
  "$@" >"$log" 2>&1
}

# fail MESSAGE: ends the test at the current step.
fail() {
  echo "$*" >&2
  exit 1
}
