"""A model file is read as `mujoco.MjModel.from_xml_path` reads it (issue 42, item 1): meshdir, assetdir,
texturedir and includes (above the model's folder, nested, with their own compiler) resolved from the
file's own path whatever the working directory; a missing file refused, naming it, only where MuJoCo
refuses it too; keyframes converted with free and ball joints; a URDF read as urdfdom reads it.

Every model is written here into tmp_path (a tetrahedron STL, a 2x2 PNG), and every engine's reading is
compared with MuJoCo's own load of the file's path, so a test fails where the harness reads another model.
"""

from __future__ import annotations

import os
import struct
import zlib
from pathlib import Path

import mujoco
import numpy as np
import pytest
from lagrange_xval.core.errors import HarnessError
from lagrange_xval.model.modelfile import compile_mjcf, mjcf_text, model_file
from lagrange_xval.systems import System

TETRA = [(0.0, 0.0, 0.0), (0.1, 0.0, 0.0), (0.0, 0.2, 0.0), (0.0, 0.0, 0.3)]
FACES = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]


def _stl(path: Path, scale: float = 1.0) -> None:
    """A binary STL of a tetrahedron (its inertia depends on `scale`, so two meshes tell apart)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    out = bytearray(b"\0" * 80) + struct.pack("<I", len(FACES))
    for face in FACES:
        out += struct.pack("<3f", 0, 0, 0)
        for i in face:
            out += struct.pack("<3f", *(scale * x for x in TETRA[i]))
        out += b"\0\0"
    path.write_bytes(bytes(out))


def _png(path: Path) -> None:
    """A 2x2 RGB PNG."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    rows = b"".join(b"\0" + bytes([255, 0, 0] * 2) for _ in range(2))
    header = struct.pack(">IIBBBBB", 2, 2, 8, 2, 0, 0, 0)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(
        b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b"")
    )


ARM = """<mujoco model="arm">
  {compiler}
  <asset>{assets}</asset>
  <worldbody>
    <body name="link" pos="0 0 1">
      <joint name="hinge" axis="0 1 0"/>
      <geom type="mesh" mesh="tet" density="1000"/>
      {inside}
    </body>
  </worldbody>
</mujoco>"""


def _write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def _same_as_mujoco(path: Path, elsewhere: Path, monkeypatch: pytest.MonkeyPatch) -> mujoco.MjModel:
    """The harness's model of `path`, compiled with the working directory elsewhere, whose bodies are
    MuJoCo's own load of the path's (masses, inertias, centres of mass, poses)."""
    expected = mujoco.MjModel.from_xml_path(os.path.abspath(path))
    elsewhere.mkdir(exist_ok=True)
    monkeypatch.chdir(elsewhere)
    model = compile_mjcf(path)
    assert (model.nbody, model.nq, model.nmesh, model.ntex) == (
        expected.nbody,
        expected.nq,
        expected.nmesh,
        expected.ntex,
    )
    for field in ("body_mass", "body_inertia", "body_ipos", "body_pos", "body_quat"):
        np.testing.assert_allclose(getattr(model, field), getattr(expected, field), rtol=1e-12, atol=1e-15)
    assert expected.body_mass[1] > 0  # the mesh was read: its volume gives the link its mass
    return model


def test_a_meshdir_is_read_from_the_models_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _stl(tmp_path / "robot" / "meshes" / "tet.stl")
    path = _write(
        tmp_path / "robot" / "arm.xml",
        ARM.format(compiler='<compiler meshdir="meshes"/>', assets='<mesh name="tet" file="tet.stl"/>', inside=""),
    )
    _same_as_mujoco(path, tmp_path / "elsewhere", monkeypatch)
    assert "meshdir=" not in mjcf_text(path) and str(tmp_path / "robot" / "meshes" / "tet.stl") in mjcf_text(path)


def test_an_assetdir_serves_meshes_and_textures(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _stl(tmp_path / "m" / "assets" / "tet.stl")
    _png(tmp_path / "m" / "assets" / "red.png")
    assets = '<mesh name="tet" file="tet.stl"/><texture name="red" type="2d" file="red.png"/>'
    path = _write(
        tmp_path / "m" / "arm.xml", ARM.format(compiler='<compiler assetdir="assets"/>', assets=assets, inside="")
    )
    model = _same_as_mujoco(path, tmp_path / "elsewhere", monkeypatch)
    assert model.ntex == 1


def test_an_include_above_the_models_folder_and_nested_includes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A scene including ../robots/arm.xml, which includes sub/part.xml (its own folder's), which
    includes a body of a third folder by a path relative to the scene's folder (where MuJoCo looks
    first): MuJoCo loads it, so does the harness, with every body and the included files' meshes."""
    _stl(tmp_path / "robots" / "tet.stl")
    _stl(tmp_path / "robots" / "sub" / "big.stl", scale=2.0)
    _write(
        tmp_path / "robots" / "arm.xml",
        '<mujoco><asset><mesh name="tet" file="tet.stl"/></asset><include file="sub/part.xml"/></mujoco>',
    )
    _write(
        tmp_path / "robots" / "sub" / "part.xml",
        '<mujoco><asset><mesh name="big" file="big.stl"/></asset><worldbody><body name="a" pos="0 0 1">'
        '<joint name="ja" axis="0 1 0"/><geom type="mesh" mesh="tet"/><include file="third/tip.xml"/></body>'
        "</worldbody></mujoco>",
    )
    _write(
        tmp_path / "scenes" / "third" / "tip.xml",
        '<mujoco><body name="tip" pos="0 0 -0.5"><joint name="jt" axis="1 0 0"/><geom type="mesh" mesh="big"/>'
        "</body></mujoco>",
    )
    path = _write(
        tmp_path / "scenes" / "scene.xml", '<mujoco model="scene"><include file="../robots/arm.xml"/></mujoco>'
    )
    model = _same_as_mujoco(path, tmp_path / "elsewhere", monkeypatch)
    assert model.nbody == 3 and model.body_mass[2] > model.body_mass[1]  # the big tetrahedron weighs more
    assert "<include" not in model_file(path)[1]
    system = System.model_only(path)
    assert system.coordinates == ("ja", "jt")


def test_an_include_with_its_own_meshdir_is_read_as_mujoco_reads_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An included file's <compiler meshdir> is MuJoCo's model-wide meshdir, resolved from the model's
    folder: where MuJoCo finds the mesh, the harness reads the same; where it does not, both refuse."""
    _stl(tmp_path / "main" / "meshes" / "tet.stl")
    _write(
        tmp_path / "main" / "parts" / "arm.xml",
        '<mujoco><compiler meshdir="meshes"/><asset><mesh name="tet" file="tet.stl"/></asset></mujoco>',
    )
    path = _write(
        tmp_path / "main" / "scene.xml",
        ARM.format(compiler='<include file="parts/arm.xml"/>', assets="", inside="").replace("<asset></asset>", ""),
    )
    _same_as_mujoco(path, tmp_path / "elsewhere", monkeypatch)


def test_a_missing_file_is_refused_naming_it_where_mujoco_refuses_it(tmp_path: Path) -> None:
    path = _write(tmp_path / "arm.xml", ARM.format(compiler="", assets='<mesh name="tet" file="gone.stl"/>', inside=""))
    with pytest.raises(ValueError, match="gone.stl"):
        mujoco.MjModel.from_xml_path(str(path))
    with pytest.raises(HarnessError, match=r"arm.xml: not a valid MJCF model: .*gone.stl"):
        compile_mjcf(path)
    scene = _write(tmp_path / "scene.xml", '<mujoco><include file="nowhere/arm.xml"/></mujoco>')
    with pytest.raises(HarnessError, match=r'scene.xml: <include file="nowhere/arm.xml">: no such file'):
        compile_mjcf(scene)


def test_an_included_file_is_bounded_as_the_model_is(tmp_path: Path) -> None:
    """An include is allowed wherever MuJoCo reads it, but it must be a regular file without DOCTYPE."""
    _write(tmp_path / "bomb.xml", '<!DOCTYPE mujoco [<!ENTITY a "aaaa">]><mujoco/>')
    path = _write(tmp_path / "m.xml", '<mujoco><include file="bomb.xml"/></mujoco>')
    with pytest.raises(HarnessError, match=r"included bomb.xml\): declares <!DOCTYPE"):
        model_file(path)
    path.write_text('<mujoco><include file="/dev/zero"/></mujoco>')
    with pytest.raises(HarnessError, match="regular file|not a file"):
        model_file(path)


KEYED = """<mujoco model="keyed">
  <default><joint damping="0.1"/></default>
  <worldbody>
    <body name="base" pos="0.1 0.2 0.3" euler="10 20 30">
      <freejoint name="root"/>
      <inertial pos="0.01 0 0" mass="1" diaginertia="0.1 0.2 0.3"/>
      <body name="arm" pos="0 0 0.5">
        <joint name="ball" type="ball" pos="0 0 0.1"/>
        <inertial pos="0 0 0.2" mass="0.5" diaginertia="0.01 0.02 0.03"/>
        <body name="tip" pos="0 0 0.4">
          <joint name="hinge" axis="0 1 0"/>
          <inertial pos="0 0 0.1" mass="0.2" diaginertia="0.001 0.002 0.003"/>
        </body>
      </body>
    </body>
  </worldbody>
  <keyframe>
    <key name="pose" qpos="0.5 -0.2 1.1 0.9 0.1 0.3 -0.2 0.8 0.2 -0.1 0.3 0.4"
         qvel="0.3 -0.1 0.2 0.5 -0.4 0.6 0.2 0.1 -0.3 0.7"/>
    <key name="still" qpos="0 0 1 1 0 0 0 1 0 0 0 0.2"/>
  </keyframe>
</mujoco>"""


def test_keyframes_are_converted_with_free_and_ball_joints(tmp_path: Path) -> None:
    """The converted model's keys put every body where MuJoCo's key puts it, at the same velocity."""
    path = _write(tmp_path / "keyed.xml", KEYED)
    original, converted = mujoco.MjModel.from_xml_path(str(path)), compile_mjcf(path)
    assert (original.nq, converted.nq, converted.nkey) == (12, 10, 2)
    for k in range(2):
        before, after = mujoco.MjData(original), mujoco.MjData(converted)
        mujoco.mj_resetDataKeyframe(original, before, k)
        mujoco.mj_resetDataKeyframe(converted, after, k)
        mujoco.mj_forward(original, before)
        mujoco.mj_forward(converted, after)
        for body in ("base", "arm", "tip"):
            i, j = original.body(body).id, converted.body(body).id
            np.testing.assert_allclose(after.xpos[j], before.xpos[i], atol=1e-12)
            np.testing.assert_allclose(after.xmat[j], before.xmat[i], atol=1e-12)
            np.testing.assert_allclose(after.cvel[j], before.cvel[i], atol=1e-12)
    assert System.model_only(path).nv == 10


URDF = """{lead}<?xml version="1.0"?>
<robot name="r">
  <link name="base"/>
  <link name="l1"><inertial><origin xyz="0 0 -0.2"/><mass value="1.5"/>
    <inertia ixx="0.02" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.01"/></inertial></link>
  <joint name="j1" type="continuous"><parent link="base"/><child link="l1"/><axis xyz="0 1 0"/></joint>
  <transmission name="t1"><type>transmission_interface/SimpleTransmission</type>
    <joint name="j1"><hardwareInterface>EffortJointInterface</hardwareInterface></joint>
    <actuator name="m1"><mechanicalReduction>{reduction}</mechanicalReduction></actuator></transmission>
</robot>
"""


def test_a_urdf_with_whitespace_before_its_declaration_is_read(tmp_path: Path) -> None:
    """urdfdom and MuJoCo read a URDF with blank lines before `<?xml ...?>`; so do the harness's readers."""
    from lagrange_xval.sources.pinocchio import build_model

    path = _write(tmp_path / "lead.urdf", URDF.format(lead="\n\n   \n", reduction="50"))
    system = System.model_only(path)
    assert system.coordinates == ("j1",) and system.view["body/l1/mass"] == 1.5
    assert build_model(system).nv == 1


def test_a_prefix_no_xmlns_declares_is_read_as_tinyxml2_reads_it(tmp_path: Path) -> None:
    """A published URDF's `drake:` attributes and elements with no `xmlns:drake` (MuJoCo and urdfdom read
    them): judged by every reader, not refused as "unbound prefix"; a declared prefix is left as it is."""
    from lagrange_xval.model.bounds import declare_prefixes
    from lagrange_xval.sources.pinocchio import build_model

    text = URDF.format(lead="", reduction="50")
    text = text.replace('<axis xyz="0 1 0"/>', '<axis xyz="0 1 0"/><limit drake:acceleration="2.5"/>', 1)
    text = text.replace('<link name="base"/>', '<link name="base"/><drake:collision_filter_group name="g"/>', 1)
    path = _write(tmp_path / "prefixed.urdf", text)
    mujoco.MjModel.from_xml_path(str(path))  # MuJoCo reads it as written
    system = System.model_only(path)
    assert system.view["body/l1/mass"] == 1.5 and build_model(system).nv == 1
    declared = text.replace('<robot name="r">', '<robot name="r" xmlns:drake="http://drake.mit.edu">', 1)
    assert declare_prefixes(declared) == declared


def test_a_non_numeric_mechanical_reduction_does_not_refuse_the_file(tmp_path: Path) -> None:
    """A field no check uses never refuses the file: the transmission is not read, and said so."""
    path = _write(tmp_path / "gear.urdf", URDF.format(lead="", reduction="${reduction}"))
    system = System.model_only(path)
    assert system.mujoco_model().nu == 0 and system.view["body/l1/mass"] == 1.5
    assert any("transmission 't1' not read: its mechanicalReduction '${reduction}'" in a for a in system.alignments)
    numeric = System.model_only(_write(tmp_path / "numeric.urdf", URDF.format(lead="", reduction="50")))
    assert numeric.mujoco_model().nu == 1 and numeric.mujoco_model().actuator_gear[0, 0] == 50


def test_a_ball_joint_whose_type_is_a_default_class_is_converted(tmp_path: Path) -> None:
    """`<default><joint type="ball"/></default>`: MuJoCo's ball joint, compared in three hinges as one
    whose type it states (it was refused as a ball joint)."""
    path = _write(
        tmp_path / "ball.xml",
        '<mujoco model="ball"><default><default class="swing"><joint type="ball" pos="0 0 0.1"/></default></default>'
        '<worldbody><body name="b" childclass="swing"><joint name="s"/>'
        '<inertial pos="0 0 -0.3" mass="1" diaginertia="0.01 0.02 0.03"/></body></worldbody></mujoco>',
    )
    system = System.model_only(path)
    assert system.coordinates == ("s_rz", "s_ry", "s_rx") and system.nv == 3
    np.testing.assert_allclose(system.mujoco_model().jnt_pos, [[0, 0, 0.1]] * 3)


def test_an_included_worldbody_is_one_with_the_scenes_for_every_reader(tmp_path: Path) -> None:
    """A scene whose floor is in its own <worldbody> and whose robot is in an included file's: MuJoCo
    merges the sections; so does the text every reader gets (Pinocchio's parser read the first twice)."""
    from lagrange_xval.sources.pinocchio import build_model

    _write(
        tmp_path / "robot.xml",
        '<mujoco><default><joint damping="0.2"/></default><worldbody><body name="a"><joint name="j" axis="0 1 0"/>'
        '<inertial pos="0 0 -0.3" mass="1" diaginertia="0.01 0.02 0.03"/></body></worldbody></mujoco>',
    )
    path = _write(
        tmp_path / "scene.xml",
        '<mujoco model="scene"><include file="robot.xml"/><default><geom rgba="1 0 0 1"/></default>'
        '<worldbody><geom name="floor" type="plane" size="1 1 0.1"/></worldbody></mujoco>',
    )
    text = model_file(path)[1]
    assert text.count("<worldbody") == 1 and text.count("<default") == 1
    system = System.model_only(path)
    assert build_model(system).nv == system.nv == 1 and system.mujoco_model().dof_damping[0] == 0.2
