#!/usr/bin/env bash
# The lint and type gate of `make test` (and so of CI): ruff (style, imports, bugs, naming, docstrings)
# over the whole tree, then mypy over every package. Each tool prints its own
# messages; the first failing tool fails the gate. Configuration: pyproject.toml.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
BIN="$ROOT/.venv/bin"
echo "gate: ruff check"
"$BIN/ruff" check --quiet .
echo "gate: ruff format --check"
"$BIN/ruff" format --check --quiet .
echo "gate: mypy (every package)"
# The nodes and the kits import rclpy and the message packages, which live on the ROS paths env.sh sets.
"$BIN/mypy" --no-error-summary
echo "gate: passed"
