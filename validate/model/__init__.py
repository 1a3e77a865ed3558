"""A model file as every reader sees it: read, bounded, compiled, and its numbers in one keyed view.

modelfile    the file's format and text, and the MJCF every reader parses (compile_model, model_view)
modelview    a plain-numpy snapshot of the compiled model keyed by MJCF names ("body/<name>/mass")
scope        what is compared: constraints left out, MuJoCo-only forces, inputs that are motors
floating     free and ball joints as slides and hinges every source shares
urdf         a URDF read by each engine's own parser; inertia: its defects found and repaired
bounds       what a file may hold before it is compiled, and what its numbers must be
overrides, set_values   parameters written into the MJCF text at full precision
meaning      what the format means, field by field, in one frame (the audit's yardstick)
start        Start(q0, v0, tau) and Scheme(integrator, timestep): where a run starts, how it is stepped
"""

__all__ = [
    "bounds",
    "floating",
    "inertia",
    "meaning",
    "modelfile",
    "modelview",
    "overrides",
    "scope",
    "set_values",
    "start",
    "urdf",
]
