"""Where a run starts and how it is stepped, as two values instead of loose arguments.

`Start(q0, v0, tau)` is the initial state and the constant generalized force of a free run;
`Scheme(integrator, timestep)` is MuJoCo's fixed-step scheme a run (or its mirror on another source)
steps with. Both are frozen: a run never changes its start or its scheme.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ..core.arrays import Vector


@dataclass(frozen=True)
class Start:
    """The start of a free run.

    Attributes:
        q0: (nq,) the coordinates at the first sample.
        v0: (nv,) the velocities at the first sample.
        tau: (nv,) the generalized force held constant over the run (N m or N).
    """

    q0: Vector
    v0: Vector
    tau: Vector

    @classmethod
    def of(cls, q0: ArrayLike, v0: ArrayLike, tau: ArrayLike) -> Start:
        """The start with each part as a float array."""
        return cls(np.asarray(q0, dtype=float), np.asarray(v0, dtype=float), np.asarray(tau, dtype=float))

    @classmethod
    def at_rest(cls, q0: ArrayLike, v0: ArrayLike) -> Start:
        """The start with no generalized force (a free run of the model alone)."""
        v = np.asarray(v0, dtype=float)
        return cls.of(q0, v, np.zeros(len(v)))


@dataclass(frozen=True)
class Scheme:
    """A fixed-step integration scheme.

    Attributes:
        integrator: MuJoCo's name for it: "RK4", "Euler", "implicit" or "implicitfast".
        timestep: the step (s).
    """

    integrator: str
    timestep: float
