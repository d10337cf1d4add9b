#!/usr/bin/env bash
# Idempotent setup: venv with pinned ROS 2 Jazzy wheels, build-path fixes, colcon build, `feeder` command.
# Each step runs only when its inputs changed (stamps under .venv and ros_ws/install), so a second
# run with nothing changed only hashes a few files.
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
VENV="$ROOT/.venv"
WS="$ROOT/ros_ws"
say() { printf 'setup: %s\n' "$*"; }

# Concurrent setups (two shells, parallel test runs) would race in pip and colcon: one at a time.
if command -v flock >/dev/null 2>&1; then
  exec 9>"$ROOT/.setup.lock"
  flock 9
fi
die() { printf 'setup: ERROR: %s\n' "$*" >&2; exit 1; }

# --- 1. Tools the build needs; stop at once and say how to get a missing one. -------------------
command -v cmake >/dev/null 2>&1 || die "cmake not found. Install it: 'sudo apt-get install cmake' (Debian/Ubuntu)."
if ! command -v c++ >/dev/null 2>&1 && ! command -v g++ >/dev/null 2>&1; then
  die "no C++ compiler (c++ or g++) found. Install one: 'sudo apt-get install g++' (Debian/Ubuntu)."
fi
command -v cc >/dev/null 2>&1 || command -v gcc >/dev/null 2>&1 || \
  die "no C compiler (cc or gcc) found. Install one: 'sudo apt-get install gcc' (Debian/Ubuntu)."

pick_python() {
  if [ -n "${PYTHON:-}" ]; then echo "$PYTHON"; return; fi
  for candidate in python3.11 python3.12 python3.10 python3; do
    if command -v "$candidate" >/dev/null 2>&1 && "$candidate" -c \
        'import sys; sys.exit(0 if (3, 10) <= sys.version_info[:2] <= (3, 12) else 1)' 2>/dev/null; then
      echo "$candidate"; return
    fi
  done
  die "no Python 3.10, 3.11 or 3.12 found (the ROS 2 Jazzy wheels exist only for those). Install python3.11."
}

# --- 2. The virtual environment with the exact pinned versions. ---------------------------------
if [ ! -x "$VENV/bin/python" ]; then
  python_bin=$(pick_python)
  say "creating .venv with $($python_bin --version)"
  "$python_bin" -m venv "$VENV" || die "'$python_bin -m venv' failed; on Debian/Ubuntu install python3-venv."
fi
lock_hash=$(sha256sum "$ROOT/requirements.lock" | cut -d' ' -f1)
if [ "$(cat "$VENV/.requirements-stamp" 2>/dev/null)" != "$lock_hash" ]; then
  say "installing pinned packages from requirements.lock (first time: about a minute)"
  # uv (pinned in the lock, bootstrapped with pip) installs the set: measured from a cold cache, 40 s
  # against pip's 95 s. Bytecode is compiled at install, as pip does, so that no node's first start pays
  # for it. Files are copied, not hard-linked from uv's cache: the next step edits installed CMake files.
  uv_pin=$(grep -E '^uv==' "$ROOT/requirements.lock") || die "requirements.lock pins no uv"
  "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check "$uv_pin"
  "$VENV/bin/python" -m uv pip install --quiet --python "$VENV/bin/python" --link-mode=copy \
    --compile-bytecode -r "$ROOT/requirements.lock"
  echo "$lock_hash" > "$VENV/.requirements-stamp"
fi

# --- 3. Environment file and the wheels' build paths. -------------------------------------------
# The message wheels' CMake exports name include dirs of the machine that built them; point them at
# this venv's Python and numpy instead (local to the venv, no root needed). See the notes in shared/.
"$VENV/bin/python" "$ROOT/tools/venv_env.py" "$VENV"

# --- 4. Build the colcon workspace when any package source changed. -----------------------------
# --symlink-install makes Python edits live, so a .py file counts by its path only (a new module needs
# no rebuild either, but costs nothing to count); setup.py, package.xml and interfaces count whole.
# The interfaces' generators: only those the Python nodes use (C, Python, the C typesupports; the C++
# headers and C++ typesupports, which only C++ nodes would use, are left out: tools/cmake/
# python_only_interfaces.cmake says how). FEEDER_CXX_INTERFACES=1 builds them all, as a plain
# `colcon build` on a full ROS 2 install does.
python_only=ON
if [ "${FEEDER_CXX_INTERFACES:-0}" = 1 ]; then python_only=OFF; fi
cmake_args=(-DBUILD_TESTING=OFF -DPython3_EXECUTABLE="$VENV/bin/python"
            -DCMAKE_PROJECT_INCLUDE="$ROOT/tools/cmake/python_only_interfaces.cmake"
            -DFEEDER_PYTHON_ONLY_INTERFACES=$python_only)
src_hash=$( { cd "$ROOT" && printf '%s\n' "${cmake_args[@]}" && cat tools/cmake/*.cmake && \
             find feeder_msgs standard_interfaces feeder_planner feeder_device feeder_sim feeder_cell -type f \
             -not -path '*/__pycache__/*' -not -name '*.pyc' \
             \( \( -name '*.py' -not -name setup.py -printf '%p\n' \) -o -printf '%p %s %T@\n' \) | sort; } \
           | sha256sum | cut -d' ' -f1)
# A package whose install is gone (removed by hand, or a new link in ros_ws/src) is built again too.
missing=""
for package in "$WS"/src/*; do
  [ -d "$WS/install/$(basename "$package")" ] || missing="$missing $(basename "$package")"
done
if [ -n "$missing" ] || [ "$(cat "$WS/install/.feeder-build-stamp" 2>/dev/null)" != "$src_hash" ]; then
  say "building ros_ws with colcon"
  (
    set +u
    # shellcheck source=/dev/null
    source "$VENV/feeder-env.sh"
    cd "$WS"
    # colcon runs make with -j<cores> -l<cores>; the load limit lags (a 1-minute average), so after two
    # packages built side by side make ran one job at a time for a minute and more while a core idled.
    # Jobs without a load limit, unless MAKEFLAGS already sets either.
    case " ${MAKEFLAGS:-} " in
      *" -j"*|*" --jobs"*|*" -l"*|*" --load-average"*) ;;
      *) export MAKEFLAGS="${MAKEFLAGS:+$MAKEFLAGS }-j$(nproc 2>/dev/null || echo 2)" ;;
    esac
    colcon --log-base log build --symlink-install --event-handlers console_direct- \
      --cmake-args "${cmake_args[@]}" >"$WS/build.log" 2>&1 \
      || { tail -n 40 "$WS/build.log" >&2; exit 1; }
  ) || die "colcon build failed (full log: ros_ws/build.log)"
  echo "$src_hash" > "$WS/install/.feeder-build-stamp"
fi

# --- 5. The `feeder` command on the venv's PATH. ------------------------------------------------
cat > "$VENV/bin/feeder.new" <<WRAPPER
#!/usr/bin/env bash
# Generated by tools/setup.sh: runs the feeder CLI inside the project's ROS environment.
source "$ROOT/env.sh"
exec python -m feeder_cell.cli.main "\$@"
WRAPPER
chmod +x "$VENV/bin/feeder.new"
mv -f "$VENV/bin/feeder.new" "$VENV/bin/feeder"

# --- 6. The clients the tests drive: Foxglove's for the bridge, node-opcua's for the OPC UA gateway. ---
# npm, pinned by tests/js/package-lock.json. Not fatal: without them only those tests fail, and they name
# the cause (npm-ci.log keeps npm's words).
JS="$ROOT/tests/js"
js_hash=$(sha256sum "$JS/package-lock.json" | cut -d' ' -f1)
if [ "$(cat "$JS/node_modules/.feeder-stamp" 2>/dev/null)" != "$js_hash" ]; then
  say "installing the tests' Foxglove and node-opcua clients from the npm registry (tests/js, npm ci)"
  if (cd "$JS" && timeout 300 npm ci --no-audit --no-fund --fetch-retries=1 --fetch-timeout=60000) \
      >"$JS/npm-ci.log" 2>&1; then
    echo "$js_hash" > "$JS/node_modules/.feeder-stamp"
  else
    say "WARNING: npm ci in tests/js failed (tests/js/npm-ci.log); the bridge's official-client tests" \
      "and the OPC UA security test will fail"
  fi
fi
say "ready. Enter the environment with: source env.sh"
