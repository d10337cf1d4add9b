"""Fidelity models of the MEMS field array: ideal (exact integrals), array (actuator cells), dynamic (pymunk)."""
