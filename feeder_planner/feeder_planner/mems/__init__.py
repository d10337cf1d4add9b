"""MEMS field array mechanics: exact lifted radial potential, fields, equilibria (Lamiroux & Kavraki)."""
