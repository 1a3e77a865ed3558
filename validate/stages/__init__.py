"""What `run` adds after the verdict, system by system.

pipeline     the main job: the verdict, then printed forms, equivalence, derived equations,
             trajectories, estimates, chaos, experiments and the audit, each stage timed
equivalence  two formulations of one chain mapped onto each other
derived      the model's derived equations as text and results data
"""

__all__ = ["derived", "equivalence", "pipeline"]
