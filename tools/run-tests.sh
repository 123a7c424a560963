#!/usr/bin/env bash
# Run the whole test suite inside the workspace environment; extra arguments go to pytest.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
# A domain of its own keeps this run's nodes apart from anything else on the machine; each
# pytest-xdist worker takes the next one (test/conftest.py).
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$(( (RANDOM % 80) + 10 ))}"
export PYTHONDONTWRITEBYTECODE=1
# The firmware first: its set-up (as root it installs the ARM toolchain, cmocka and QEMU), the
# core's host tests and every board's image. Without them and not root, setup-firmware.sh says
# in one line what is missing and the firmware steps are skipped (test/firmware skips too).
set +e
bash tools/setup-firmware.sh
fw=$?
set -e
case $fw in
  0) bash tools/build-firmware.sh --test ;;
  1) ;;
  *) exit "$fw" ;;
esac
# The kernel's C unit tests under the sanitizers (cmocka, which the firmware's set-up installs).
bash tools/test-kernel.sh
# A bound on the whole run (SKIN_TEST_WALL_S, 0 for none), several times what it takes: a
# process stuck where no test's timeout reaches it (between two tests, say) fails the run in
# time to read why, not at CI's own limit. Past the bound every Python process of the run prints
# its threads' stacks (SIGUSR1, test/conftest.py), and then the run is stopped.
wall="${SKIN_TEST_WALL_S:-1800}"
descendants() {  # of $1, leaving out $2 and its own; from /proc, as procps may be missing
  local stat line pid kid p
  local -A parent=()
  for stat in /proc/[0-9]*/stat; do
    line=$(<"$stat") 2>/dev/null || continue
    pid=${stat#/proc/}
    # The fields after the command name, which may hold spaces: state, then the parent.
    read -r _ parent[${pid%/stat}] _ <<<"${line##*) }"
  done
  local frontier=("$1") next
  while [ "${#frontier[@]}" -gt 0 ]; do
    next=()
    for kid in "${!parent[@]}"; do
      for p in "${frontier[@]}"; do
        if [ "${parent[$kid]}" = "$p" ] && [ "$kid" != "$2" ]; then
          echo "$kid"
          next+=("$kid")
        fi
      done
    done
    frontier=("${next[@]}")
  done
}
if [ "$wall" -gt 0 ]; then
  (
    sleep "$wall" </dev/null >/dev/null 2>&1
    echo "run-tests: the suite ran past its ${wall} s bound (SKIN_TEST_WALL_S): the stacks" \
         "of its Python processes follow, then it is stopped" >&2
    me=$BASHPID
    procs=$(descendants "$$" "$me")
    for p in $procs; do
      case "$(cat "/proc/$p/comm" 2>/dev/null || true)" in
        python*) kill -USR1 "$p" 2>/dev/null || true ;;
      esac
    done
    sleep 10
    kill -TERM $procs 2>/dev/null || true
    sleep 5
    kill -KILL $procs 2>/dev/null || true
  ) &
  watchdog=$!
  # However this script ends (Ctrl-C too), the watchdog and its sleep end with it.
  stop_watchdog() {
    local sleeping
    sleeping=$(descendants "$watchdog" "")
    kill "$watchdog" $sleeping 2>/dev/null || true
  }
  trap stop_watchdog EXIT
fi
set +e
tools/with-env.sh python -m pytest -n "${SKIN_TEST_WORKERS:-2}" "$@"
rc=$?
set -e
if [ "$rc" -eq 5 ]; then
  echo "run-tests: pytest collected no test; that is a failure here" >&2
  exit 1
fi
exit "$rc"
