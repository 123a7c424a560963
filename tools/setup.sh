#!/usr/bin/env bash
# Make the workspace usable on a fresh machine: a .venv holding ROS 2 Jazzy's Python side (wheels, or
# the sourced system Jazzy) and the project's pinned dependencies, then a colcon build of skin_msgs,
# skin_kernel (the compiled estimation, C), skin_fw_host (the firmware core built for the
# simulated board, C), skin_driver and skin_lab (the bench, the evaluator, the
# demo; beside the driver, never needed by it). Each step is skipped when its inputs have not changed, so a second run takes a second.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
venv="$root/.venv"
log="$root/.venv-setup.log"

die() { echo "setup: $*" >&2; exit 1; }
say() { [ -n "${SKIN_QUIET:-}" ] || echo "setup: $*" >&2; }

python_ok() {
  "$1" -c 'import sys; sys.exit(0 if (3, 10) <= sys.version_info[:2] <= (3, 13) else 1)' 2>/dev/null
}

# A sourced system ROS 2 Jazzy wins over the wheels: build against what the workstation runs.
system_ros=""
if [ "${ROS_DISTRO:-}" = "jazzy" ] && python3 -c 'import rclpy' 2>/dev/null; then
  system_ros=1
  py=$(command -v python3)
else
  py=""
  for cand in python3.12 python3.11 python3.13 python3.10 python3; do
    if command -v "$cand" >/dev/null 2>&1 && python_ok "$(command -v "$cand")"; then
      py=$(command -v "$cand"); break
    fi
  done
  [ -n "$py" ] || die "missing: python 3.10 to 3.13 (ROS 2 Jazzy wheels exist only for those); install one, e.g. apt-get install python3"
fi
command -v cmake >/dev/null 2>&1 || die "missing: cmake (needed to build skin_msgs); install it, e.g. apt-get install cmake"
command -v cc >/dev/null 2>&1 || command -v gcc >/dev/null 2>&1 \
  || die "missing: a C compiler (needed to build skin_msgs, skin_kernel and skin_fw_host); install one, e.g. apt-get install gcc"
"$py" -c 'import ensurepip, venv' 2>/dev/null || die "missing: python venv support for $py; install it, e.g. apt-get install python3-venv"
pyinc=$("$py" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')
[ -f "$pyinc/Python.h" ] || die "missing: Python headers in $pyinc (needed by rosidl); install them, e.g. apt-get install python3-dev"

hash_of() { cat "$@" | sha1sum | cut -c1-40; }

# --- the virtual environment ------------------------------------------------------------------
reqs=(tools/requirements.txt)
if [ -n "$system_ros" ]; then
  python3 -c 'import numpy, cv2' 2>/dev/null || die "missing: numpy or OpenCV for the system python (rosdep install --from-paths . --ignore-src -y, or apt-get install python3-numpy python3-opencv)"
  python3 -c 'import matplotlib, skimage' 2>/dev/null || die "missing: matplotlib or scikit-image for the system python, which the tests need (rosdep install --from-paths . --ignore-src -y, or apt-get install python3-matplotlib python3-skimage)"
else
  reqs+=(tools/requirements-numeric.txt tools/requirements-ros.txt)
fi
kind="$("$py" -V 2>&1) ${system_ros:+system-ros}"
want="$kind $(hash_of "${reqs[@]}" tools/setup.sh)"
have=$(cat "$venv/.setup-stamp" 2>/dev/null || true)
if [ "$have" != "$want" ]; then
  if [ "${have% *}" != "$kind" ] || [ ! -x "$venv/bin/python" ]; then
    # Another interpreter (or none yet): start from an empty environment.
    say "creating $venv with $("$py" -V 2>&1)${system_ros:+ on the sourced ROS 2 $ROS_DISTRO} (first run: about a minute)"
    rm -rf "$venv"
    if [ -n "$system_ros" ]; then
      "$py" -m venv --system-site-packages "$venv" >"$log" 2>&1 || die "could not create $venv (see $log)"
    else
      "$py" -m venv "$venv" >"$log" 2>&1 || die "could not create $venv (see $log)"
    fi
  else
    say "updating $venv to the pinned requirements"
    : >"$log"
  fi
  pipargs=()
  for r in "${reqs[@]}"; do pipargs+=(-r "$r"); done
  if ! "$venv/bin/python" -m pip install --disable-pip-version-check -q "${pipargs[@]}" >>"$log" 2>&1; then
    if grep -qiE 'connection|resolve|network is unreachable|timed out|temporary failure|no matching distribution' "$log"; then
      die "missing: network access to PyPI (pip could not download the pinned packages; details in $log)"
    fi
    die "pip install failed: $(grep -iE 'error' "$log" | tail -n 1) (details in $log)"
  fi
  if [ -z "$system_ros" ]; then
    # The wheels' CMake exports name the include dirs of the machine that built them; point them here.
    npinc=$("$venv/bin/python" -c 'import numpy; print(numpy.get_include())')
    { grep -rlE '/opt/python/cp[0-9]+-cp[0-9]+' "$venv/share" --include='*.cmake' 2>/dev/null || true; } |
    while read -r f; do
      sed -i -E \
        -e "s#/opt/python/cp[0-9]+-cp[0-9]+/lib/python3\.[0-9]+/site-packages/numpy/_core/include#$npinc#g" \
        -e "s#/opt/python/cp[0-9]+-cp[0-9]+/include/python3\.[0-9]+#$pyinc#g" "$f"
    done
  fi
  echo "$want" >"$venv/.setup-stamp"
  rm -f "$root/install/.build-stamp"
fi

# --- the colcon build -------------------------------------------------------------------------
build_inputs=$(find package.xml setup.py setup.cfg resource skin_msgs skin_kernel firmware/core firmware/host launch config skin_driver skin_lab \
  -type f \( -name '*.py' -o -name '*.xml' -o -name '*.txt' -o -name '*.msg' -o -name '*.srv' -o -name '*.action' \
  -o -name '*.c' -o -name '*.h' \
  -o -name '*.yaml' -o -name '*.rviz' -o -name '*.cfg' -o -name 'skin_driver' -o -name 'skin_lab' \) -not -path '*/__pycache__/*' | sort)
bwant=$(hash_of $build_inputs; echo "$want")
if [ "$(cat install/.build-stamp 2>/dev/null)" != "$bwant" ]; then
  say "colcon build of skin_msgs, skin_kernel, skin_fw_host, skin_driver and skin_lab"
  prefix=${AMENT_PREFIX_PATH:-}
  [ -n "$system_ros" ] || prefix="$venv"
  # shellcheck disable=SC1091
  if ! ( . "$venv/bin/activate"
         export AMENT_PREFIX_PATH="$prefix" CMAKE_PREFIX_PATH="$prefix${CMAKE_PREFIX_PATH:+:$CMAKE_PREFIX_PATH}"
         colcon --log-base build/log build --base-paths . skin_msgs skin_kernel firmware/host skin_lab --build-base build --install-base install \
           --event-handlers console_cohesion- status- summary- \
           --cmake-args -DPython3_EXECUTABLE="$venv/bin/python" -DBUILD_TESTING=OFF ) >"$root/build-colcon.log" 2>&1; then
    tail -n 30 "$root/build-colcon.log" >&2
    die "colcon build failed (full log: build-colcon.log)"
  fi
  echo "$bwant" >install/.build-stamp
fi
