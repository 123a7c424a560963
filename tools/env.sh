# Source this (or run `tools/with-env.sh CMD`) to use the workspace: venv, skin_msgs and the sources.
# The colcon and venv scripts read unset variables: lift `set -u` while they run.
_skin_flags=$-
set +u
_skin_root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
# shellcheck disable=SC1091
. "$_skin_root/.venv/bin/activate"
# shellcheck disable=SC1091
. "$_skin_root/install/local_setup.bash"
if [ -z "${ROS_DISTRO:-}" ]; then
  # The wheels are a ROS prefix of their own: ament_index must find their share/ and ours.
  export AMENT_PREFIX_PATH="$_skin_root/install/skin_driver:$_skin_root/install/skin_msgs:$_skin_root/.venv"
fi
# The sources win over the installed copy, so an edit is live without a rebuild.
export PYTHONPATH="$_skin_root${PYTHONPATH:+:$PYTHONPATH}"
# Keep DDS discovery on this machine unless the user chose otherwise.
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
case $_skin_flags in *u*) set -u ;; esac
unset _skin_root _skin_flags
