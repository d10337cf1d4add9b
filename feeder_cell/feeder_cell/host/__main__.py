"""``python -m feeder_cell.host PACKAGE/EXECUTABLE ... --ros-args ...``: the cell host."""

from feeder_cell.host.process import main

main()
