# Source this (or run `tools/with-env.sh CMD`) to use the workspace: venv, skin_msgs and the sources.
# `make setup` makes both .venv and install/ here; in a colcon workspace clone there are neither,
# and the sourced workspace (`source install/setup.bash`) provides Python, rclpy and skin_msgs.
# The colcon and venv scripts read unset variables: lift `set -u` while they run.
_skin_flags=$-
set +u
_skin_root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
_skin_ok=1
if [ -f "$_skin_root/.venv/bin/activate" ]; then
  # shellcheck disable=SC1091
  . "$_skin_root/.venv/bin/activate"
fi
if [ -f "$_skin_root/install/local_setup.bash" ]; then
  # shellcheck disable=SC1091
  . "$_skin_root/install/local_setup.bash"
elif ! python3 -c 'import rclpy, skin_msgs' 2>/dev/null; then
  echo "tools/env.sh: no ROS 2 environment here: run \`make setup\` in $_skin_root, or source" \
    "your colcon workspace's install/setup.bash first" >&2
  _skin_ok=0
fi
if [ -z "${ROS_DISTRO:-}" ] && [ -d "$_skin_root/install/skin_driver" ]; then
  # The wheels are a ROS prefix of their own: ament_index must find their share/ and ours.
  export AMENT_PREFIX_PATH="$_skin_root/install/skin_lab:$_skin_root/install/skin_driver:$_skin_root/install/skin_kernel:$_skin_root/install/skin_fw_host:$_skin_root/install/skin_msgs:$_skin_root/.venv"
fi
# The sources win over the installed copy, so an edit is live without a rebuild (the lab's too).
export PYTHONPATH="$_skin_root:$_skin_root/skin_lab${PYTHONPATH:+:$PYTHONPATH}"
# The estimation's matrices are small: BLAS threads only fight the process's own threads and
# the other jobs for the cores (model_fit's turn-on renders ran 3-8x slower with two of them
# on a busy two-core machine). One unless the user chose otherwise.
export OPENBLAS_NUM_THREADS="${OPENBLAS_NUM_THREADS:-1}"
# Keep DDS discovery on this machine unless the user chose otherwise.
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
case $_skin_flags in *u*) set -u ;; esac
_skin_status=$(( 1 - _skin_ok ))
unset _skin_root _skin_flags _skin_ok
return "$_skin_status"
