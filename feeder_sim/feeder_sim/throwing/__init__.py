"""Simulated throwing arm: the paper's analytic model and a pymunk dynamic model."""
