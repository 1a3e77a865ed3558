"""The model's own equations of motion, derived symbolically (the notes' section-3 method).

derivation   T, V, M, C v, G and the passive forces from the model's kinematic tree
readable     the same as a person would write them: simplified, in their coordinates
"""

__all__ = ["derivation", "readable"]
