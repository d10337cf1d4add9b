"""The nodes' built-in assembly when no file is given: the block in an L bracket (Figs. 12, 14), mu 0.3."""

__all__ = ["DEFAULT_ASSEMBLY_YAML"]

DEFAULT_ASSEMBLY_YAML = """
name: block_in_l_bracket
length_unit: cm
mu: 0.3
bodies:
  - name: bracket
    grounded: true
    boxes:
      - {min: [0, 0, 0], max: [4, 2, 1]}
      - {min: [0, 0, 1], max: [1, 2, 4]}
  - name: block
    boxes: [{min: [1, 0.5, 1], max: [2, 1.5, 2]}]
contacts: auto
"""
