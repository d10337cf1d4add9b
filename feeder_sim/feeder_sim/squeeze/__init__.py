"""Simulated squeeze-grasp orienting station: its fidelity models.

The ideal fidelity is Goldberg's quasi-static model walked contact by contact, beside the planner's
closed form, so that each checks the other.
"""

from feeder_sim.squeeze.ideal import IdealSqueeze, ideal_squeeze

__all__ = ["IdealSqueeze", "ideal_squeeze"]
