"""Drake's own free run: its integrator on its continuous plant (sources/drake.py `free_run`), in the
equations' coordinates, as a Trajectory."""

from __future__ import annotations

from typing import TypedDict

import numpy as np

from ..model.start import Start
from ..sources.base import Source, engine_of
from ..systems import System
from .integrate import Trajectory


# Drake's free run in `run`: its error-controlled RK3. Measured over 10 s (max error against the
# reference, wall): double_pendulum_point 2.8e-7 rad in 0.21 s at 1e-8, 3.4e-9 in 0.92 s at 1e-10;
# simple_pendulum 4.2e-7 in 0.09 s; gimbal 2.0e-9 in 0.03 s. At 1e-8 the run and its check run (1e-9,
# dynamics/estimate.py) cost under a second, and its threshold stays far below what wrong equations do.
class DrakeOptions(TypedDict):
    """A Drake free run: its integration scheme, target accuracy and largest step (s)."""

    scheme: str
    accuracy: float
    max_step: float


DRAKE_DEFAULT: DrakeOptions = {"scheme": "runge_kutta3", "accuracy": 1e-8, "max_step": 0.01}


def drake_method(scheme: str, accuracy: float | None, max_step: float) -> str:
    """A Drake run's method string, e.g. "Drake runge_kutta3 accuracy 1e-10"."""
    return f"Drake {scheme} " + (f"accuracy {accuracy:g}" if accuracy is not None else f"dt {max_step:g}")


def drake_trajectory(
    system: System,
    source: Source,
    start: Start,
    t: np.ndarray,
    *,
    scheme: str = DRAKE_DEFAULT["scheme"],
    accuracy: float | None = DRAKE_DEFAULT["accuracy"],
    max_step: float = DRAKE_DEFAULT["max_step"],
) -> Trajectory:
    """Drake's own free run of its continuous plant (sources/drake.py `free_run`) on the grid `t`, in the
    equations' coordinates (a JOINT_MAP applied outside Drake). Never raises for what Drake's integrator
    meets: stats["status"] and ["reason"] say where it stopped, the samples after are NaN."""
    q0, v0, tau = start.q0, start.v0, start.tau
    A = system.joint_map
    if A is not None:  # q_notes = A q_joint; the inputs' work: tau_joint = A^T tau_notes
        q0, v0, tau = np.linalg.solve(A, q0), np.linalg.solve(A, v0), A.T @ tau
    from ..sources.drake import DrakeSource

    inner = engine_of(source, DrakeSource)  # a MappedSource's engine: the map is applied here
    q, v, stats = inner.free_run(q0, v0, tau, t, scheme=scheme, accuracy=accuracy, max_step=max_step)
    if A is not None:
        q, v = q @ A.T, v @ A.T
    return Trajectory("drake", drake_method(scheme, accuracy, max_step), np.array(t, dtype=float), q, v, {**stats})
