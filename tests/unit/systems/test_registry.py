"""The layout lint: pairs, names, parameters in sync, zero MuJoCo warnings."""

from __future__ import annotations

import re

import mujoco
import numpy as np
import pytest
from lagrange_xval import systems
from lagrange_xval.sources import make_source
from lagrange_xval.verdict import modelsync


def test_every_model_has_equations_and_every_equations_module_a_model():
    """A file without its partner is a half-added system."""
    assert systems.unpaired() == {"models without equations": [], "equations without model": []}


def test_at_least_the_notes_first_system_is_discovered():
    assert "double_pendulum_point" in systems.system_names()


def test_every_mjcf_element_that_matters_is_named(system):
    """Engines are mapped by MJCF names, never by index."""
    m = system.mujoco_model()
    for obj, count in (
        (mujoco.mjtObj.mjOBJ_BODY, m.nbody),
        (mujoco.mjtObj.mjOBJ_JOINT, m.njnt),
        (mujoco.mjtObj.mjOBJ_ACTUATOR, m.nu),
    ):
        for i in range(1 if obj == mujoco.mjtObj.mjOBJ_BODY else 0, count):
            assert mujoco.mj_id2name(m, obj, i), f"{system.mjcf.name}: unnamed {obj.name} {i}"


def test_mjcf_habits(system):
    """Explicit inertials and radians, as the menagerie asks."""
    text = system.mjcf.read_text()
    assert text.lstrip().startswith("<!--"), "a comment at the top says what the model is"
    assert 'angle="radian"' in text
    assert text.count("<inertial") == system.mujoco_model().nbody - 1, "every body needs an explicit <inertial>"


def test_steps_one_second_without_mujoco_warnings(system):
    m = system.mujoco_model()
    d = mujoco.MjData(m)
    d.qpos[:] = 0.3
    d.qvel[:] = 1.0
    mujoco.mj_step(m, d, nstep=round(1.0 / m.opt.timestep))
    warnings = {mujoco.mjtWarning(i).name: int(w.number) for i, w in enumerate(d.warning) if w.number}
    assert not warnings, f"MuJoCo warned: {warnings}"
    assert np.all(np.isfinite(d.qpos))


def test_equations_state_every_parameter_of_the_compiled_model(system):
    """The MJCF is the one source of numbers: what the equations assume must be what MuJoCo compiled."""
    bad = [r for r in modelsync.equations_vs_model(system) if not r["passed"]]
    assert not bad, "\n".join(
        f"{r['key']}: equations assume {r['expected']}, MJCF has {r['actual']} ({r['why']})" for r in bad
    )


def test_pinocchio_compiles_the_same_bodies_as_mujoco(system):
    bad = [r for r in modelsync.pinocchio_vs_mujoco(system, make_source(system, "pinocchio")) if not r["passed"]]
    assert not bad, "\n".join(f"{r['key']}: MuJoCo {r['expected']}, Pinocchio {r['actual']}" for r in bad)


def test_printed_literals_match_the_compiled_model(system):
    """Matlab functions hard-code parameters; they must be the MJCF's."""
    for variant in system.variants:
        for field, printed in getattr(variant, "printed_parameters", {}).items():
            compiled = getattr(system.params, field)
            assert printed == pytest.approx(compiled, rel=1e-12, abs=0.0), (
                f"{variant.name} hard-codes {field} = {printed}; the MJCF compiles {compiled}"
            )


def test_equations_modules_import_no_engine():
    """equations/ is numpy only: the hand derivation must not borrow an engine's numbers."""
    for name in systems.system_names():
        text = (systems.PACKAGE_ROOT / "equations" / f"{name}.py").read_text()
        for engine in ("mujoco", "pinocchio", "scipy"):
            assert f"import {engine}" not in text and f"from {engine}" not in text, f"{name}.py imports {engine}"
        # of the harness, only the contract's helpers (lagrange_xval.forms)
        assert not re.search(r"(from|import) lagrange_xval(?!\.forms\b)", text), f"{name}.py imports the harness"


def test_a_changed_parameter_is_caught_by_the_sync_check(tmp_path):
    """The sync check can fail: a model whose second bob sits off the rod is not the notes' pendulum."""
    s = systems.load("double_pendulum_point")
    text = s.mjcf.read_text().replace('<inertial pos="0 -1 0" mass="1"', '<inertial pos="0.1 -1 0" mass="1"', 1)
    path = tmp_path / "double_pendulum_point.xml"
    path.write_text(text)
    moved = systems.System(name=s.name, mjcf=path, equations=s.equations)
    bad = {r["key"] for r in modelsync.equations_vs_model(moved) if not r["passed"]}
    assert "body/link1/com" in bad


def test_mujoco_computes_only_what_the_scene_uses(system):
    """Disable flags match USES: nothing the scene does not need is computed."""
    from lagrange_xval.stages.pipeline import NEVER_USED, OPTIONAL

    m = system.mujoco_model()
    bits = {
        name: getattr(mujoco.mjtDisableBit, name) for name in dir(mujoco.mjtDisableBit) if name.startswith("mjDSBL_")
    }
    off = {name.removeprefix("mjDSBL_").lower() for name, bit in bits.items() if m.opt.disableflags & int(bit)}
    assert set(NEVER_USED) <= off, f"{system.name} computes {set(NEVER_USED) - off}"
    for use, flag in OPTIONAL.items():
        assert (flag in off) == (use not in system.uses), f"{system.name}: {flag} flag vs USES {sorted(system.uses)}"
