#!/usr/bin/env bash
# The stress run (docs/reliability.md): the whole suite N times on a fresh clone of this
# repository's committed HEAD, with a CPU load on every core (Debian's stress-ng) or without one;
# every failure is listed with its run, its test id and how to replay it.
#
#   tools/stress.sh [--runs N] [--load PERCENT[,PERCENT...] | --no-load] [--workers W] [--keep]
#                   [--reuse-build DIR] [-- PYTEST_ARGS...]
#
# --runs N        runs of the suite at each load (5)
# --load PERCENT  stress-ng's --cpu-load on every core (60); 0 or --no-load: without a load;
#                 several, comma-separated (60,0): N runs at each, in turn, on one clone
# --workers W     pytest-xdist workers, as make test's SKIN_TEST_WORKERS (2)
# --keep          keep the clone and the logs (kept anyway when a run fails)
# --reuse-build DIR  skip the clone's `make setup`: link DIR's .venv and copy its install/ (the
#                 compiled skin_msgs and skin_kernel of DIR's sources); to try the script out
#                 quickly, never for the measurement
# PYTEST_ARGS     instead of the whole suite (a selection, to try the script out)
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
runs=5 load=60 workers=2 keep="" reuse="" args=()
while [ $# -gt 0 ]; do
  case $1 in
    --runs) runs=$2; shift 2 ;;
    --load) load=$2; shift 2 ;;
    --no-load) load=0; shift ;;
    --workers) workers=$2; shift 2 ;;
    --keep) keep=1; shift ;;
    --reuse-build) reuse=$(cd "$2" && pwd); shift 2 ;;
    --) shift; args=("$@"); break ;;
    *) echo "stress: unknown option $1 (see the head of $0)" >&2; exit 2 ;;
  esac
done
[[ $runs =~ ^[1-9][0-9]*$ ]] || { echo "stress: --runs wants a positive count" >&2; exit 2; }
loads=()
IFS=, read -r -a loads <<<"$load"
for l in "${loads[@]}"; do
  [[ $l =~ ^[0-9]+$ ]] && [ "$l" -le 100 ] \
    || { echo "stress: --load wants percentages 0..100, comma-separated" >&2; exit 2; }
done
max_load=$(printf '%s\n' "${loads[@]}" | sort -n | tail -n 1)

if [ "$max_load" -gt 0 ] && ! command -v stress-ng >/dev/null 2>&1; then
  if [ "$(id -u)" -eq 0 ]; then
    echo "stress: installing stress-ng (apt-get)" >&2
    { apt-get update -qq && apt-get install -y -qq stress-ng; } >/dev/null \
      || { echo "stress: apt-get could not install stress-ng" >&2; exit 1; }
  else
    echo "stress: missing: stress-ng (apt-get install stress-ng as root), or run with --no-load" >&2
    exit 1
  fi
fi

work=$(mktemp -d -t skin-stress.XXXXXX)
clone="$work/skin_driver"
load_pid=""
finish() {
  if [ -n "$load_pid" ]; then
    kill "$load_pid" 2>/dev/null || true
    wait "$load_pid" 2>/dev/null || true
  fi
}
trap finish EXIT
git clone -q --no-hardlinks "$here" "$clone"
echo "stress: a fresh clone of $(git -C "$clone" rev-parse --short HEAD) in $clone" \
     "(uncommitted changes are not in it)"
cd "$clone"
if [ -n "$reuse" ]; then
  ln -s "$(readlink -f "$reuse/.venv")" .venv
  cp -a "$reuse/install" install
  setup=(true)
else
  setup=(make setup)
fi
"${setup[@]}"

# pytest-randomly, when installed, shuffles the order; each run then gets a seed of its own.
randomly=""
if tools/with-env.sh python -c 'import pytest_randomly' 2>/dev/null; then
  randomly=1
fi

failed_runs=0 total=0
report="$work/failures.txt"
: >"$report"
for load in "${loads[@]}"; do
  if [ "$load" -gt 0 ]; then
    # --cpu 0: one worker per online core.
    stress-ng --cpu 0 --cpu-load "$load" --quiet >/dev/null 2>&1 &
    load_pid=$!
    echo "stress: stress-ng --cpu 0 --cpu-load $load on $(nproc) cores (pid $load_pid)"
  else
    echo "stress: no load"
  fi
  failed_here=0
  for i in $(seq 1 "$runs"); do
    total=$(( total + 1 ))
    seeding=() seed="none (pytest-randomly not installed: the order is the files')"
    if [ -n "$randomly" ]; then
      seed=$(( (RANDOM << 15) | RANDOM ))
      seeding=(-p randomly "--randomly-seed=$seed")
    fi
    log="$work/run$total.log"
    start=$SECONDS
    set +e
    SKIN_TEST_WORKERS=$workers bash tools/run-tests.sh "${seeding[@]}" "${args[@]}" >"$log" 2>&1
    rc=$?
    set -e
    took=$(( SECONDS - start ))
    tally=$(grep -E '(passed|failed|error).* in [0-9.]+s' "$log" | tail -n 1 | tr -d '=' || true)
    echo "stress: load $load %, run $i of $runs: exit $rc in ${took} s, seed $seed:${tally:- no tally}"
    if [ "$rc" -ne 0 ]; then
      failed_here=$(( failed_here + 1 ))
      # -ra's summary names each failed, erroneous and crashed test: its id, then a dash.
      grep -E '^(FAILED|ERROR) ' "$log" | sed "s/^/  run $total (load $load %): /" \
        | tee -a "$report" || true
      for id in $(grep -E '^(FAILED|ERROR) ' "$log" | awk '{print $2}' | sort -u); do
        echo "    replay: (cd $clone && tools/run-tests.sh ${seeding[*]} $id)" | tee -a "$report"
      done
      echo "    log: $log" | tee -a "$report"
    fi
  done
  finish
  load_pid=""
  failed_runs=$(( failed_runs + failed_here ))
  echo "stress: $(( runs - failed_here )) of $runs runs green" \
       "($([ "$load" -gt 0 ] && echo "stress-ng --cpu-load $load on every core" || echo "no load"))"
done
if [ -s "$report" ]; then
  echo "stress: the failures, run by run:"
  cat "$report"
fi
echo "stress: $(( total - failed_runs )) of $total runs green in all"
if [ "$failed_runs" -gt 0 ] || [ -n "$keep" ]; then
  echo "stress: clone and logs kept in $work"
else
  rm -rf "$work"
fi
[ "$failed_runs" -eq 0 ]
