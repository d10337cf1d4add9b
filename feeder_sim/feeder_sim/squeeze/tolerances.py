"""Model constants of the simulated squeeze gripper (one place, stated)."""

from __future__ import annotations

from typing import Final

# The longest a single tick may advance the gripper (s): a longer gap (a stalled host, a held clock
# released) is counted in capped_ticks and not simulated, so a jaw never jumps through a phase unseen.
MAX_ADVANCE_PER_TICK: Final = 0.5
# Largest number of squeezes one ~/run_plan goal may ask for (a plan of a part at the vertex limit is
# far shorter: Goldberg's plans have O(n) squeezes).
MAX_GOAL_SQUEEZES: Final = 1000
# Jaw and turn speeds the model accepts: slower would take hours a squeeze, faster is not quasi-static.
MAX_JAW_SPEED: Final = 2.0  # m/s
MAX_TURN_SPEED: Final = 50.0  # rad/s
