"""Trajectories and what can be trusted of them.

integrate    each source on a common time grid; mirror: MuJoCo's schemes on any source's dynamics
reference    heyoka's Taylor integrator on the hand equations, in extended precision (cached)
compiled, fast   the hand equations compiled, and the fastest method at a check's error
freeruns, estimate, trust   the free runs judged with their own error estimates
chaos, flow, lyapunov   how errors grow, how far ahead a run can be trusted
experiments  the notes' own simulation experiments; constrained: the model as published
drakerun     Drake's own free run (information, not judged)
"""

__all__ = [
    "chaos",
    "compiled",
    "constrained",
    "drakerun",
    "estimate",
    "experiments",
    "fast",
    "flow",
    "freeruns",
    "integrate",
    "lyapunov",
    "mirror",
    "reference",
    "trust",
]
