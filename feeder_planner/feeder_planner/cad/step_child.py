"""The child process that reads a STEP file with OpenCASCADE: ``python -m feeder_planner.cad.step_child``.

Arguments: PATH TOLERANCE UNIT|none OUT. Writes OUT (an .npz: the solids, or the InputError); see
``feeder_planner.cad.step.read_step_solids``, which runs it so that a crash stays in this process.
"""

from __future__ import annotations

import sys

from feeder_planner.cad.step import save_step_solids


def main(argv: list[str]) -> int:
    """Read the file named by ``argv`` and save what was read; exit 0 unless OpenCASCADE crashes."""
    path, tolerance, unit, out = argv
    save_step_solids(path, float(tolerance), None if unit == "none" else float(unit), out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
