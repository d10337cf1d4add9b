"""Throwing-arm mechanics (Lynch, Northrop, Pan: stable limit sets): grasp, flight, impact, throw map, limit sets."""
