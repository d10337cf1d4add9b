# Source this file (bash) to enter the project's environment: venv, ROS 2 Jazzy wheels, built ros_ws.
# Run `make setup` first. Safe to source more than once.
FEEDER_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
export FEEDER_ROOT
if [ ! -f "$FEEDER_ROOT/.venv/feeder-env.sh" ] || [ ! -f "$FEEDER_ROOT/ros_ws/install/local_setup.bash" ]; then
  echo "env.sh: the environment is not set up yet; run 'make setup' in $FEEDER_ROOT" >&2
  return 1 2>/dev/null || exit 1
fi
# shellcheck source=/dev/null
source "$FEEDER_ROOT/.venv/feeder-env.sh"
# colcon's local_setup adds the workspace packages to AMENT_PREFIX_PATH, PYTHONPATH and LD_LIBRARY_PATH.
_feeder_nounset=$([[ $- == *u* ]] && echo 1 || true)
set +u
# shellcheck source=/dev/null
source "$FEEDER_ROOT/ros_ws/install/local_setup.bash"
[ -n "$_feeder_nounset" ] && set -u
unset _feeder_nounset
