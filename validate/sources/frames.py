"""MuJoCo's own reading of the compared joints at q = 0, from its kinematics (verdict/modelsync.py
compares Pinocchio's with it)."""

from __future__ import annotations

import numpy as np

from ..systems import System


def mujoco_joint_frames(system: System) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """MuJoCo's reading of the same (`PinocchioSource.joint_frames`) at q = 0, from its own kinematics
    (a joint's `ref` moves the frames MuJoCo compiles: at q = 0 they are where every reader puts them)."""
    import mujoco

    model = system.mujoco_model()
    data = mujoco.MjData(model)
    data.qpos[:] = 0.0
    mujoco.mj_kinematics(model, data)
    out = {}
    for j in system.joints:
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j)
        axis = np.array(data.xaxis[jid], dtype=float)
        axis = axis / np.linalg.norm(axis)
        zero = np.zeros(3)
        motion = np.concatenate([zero, axis] if str(system.view[f"joint/{j}/type"]) == "hinge" else [axis, zero])
        out[j] = (np.array(data.xanchor[jid], dtype=float), motion)
    return out
