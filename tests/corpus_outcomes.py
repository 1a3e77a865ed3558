"""Each corpus model's expected outcome (tests/corpus.py, tests/e2e/test_corpus.py): the outcome of
`check --model FILE` (pass, FAIL or refused) and phrases its last line must hold: for a FAIL the reader's
misreading or the file's defect it opens with and its known cause; for a pass the reader set aside, if any; for a
refusal its reason. Written from `python -m tests.corpus --jsonl FILE` and read line by line: a change of outcome
is a change of this table, in the same commit as the code that makes it."""

from __future__ import annotations

EXPECTED: dict[str, tuple[str, tuple[str, ...]]] = {
    "dm_control/composer/arena.xml": ("pass", ("no joint moves", "no equations of motion to compare")),
    "dm_control/entities/props/duplo/duplo2x4.xml": ("pass", ("no joint moves", "no equations of motion to compare")),
    "dm_control/locomotion/soccer/assets/boxhead/boxhead.xml": (
        "pass",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "agree on the model and its dynamics",
        ),
    ),
    "dm_control/locomotion/walkers/assets/build_fruitfly/assets/drosophila.xml": (
        "refused",
        ("not a valid MJCF model: Error: Error opening file",),
    ),
    "dm_control/locomotion/walkers/assets/build_fruitfly/assets/drosophila_defaults.xml": (
        "pass",
        ("no joint moves", "no equations of motion to compare"),
    ),
    "dm_control/locomotion/walkers/assets/build_fruitfly/assets/drosophila_fused.xml": (
        "FAIL",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "mesh inertia and the 1 kg default",
            "pointwise M",
        ),
    ),
    "dm_control/locomotion/walkers/assets/build_fruitfly/floor.xml": (
        "refused",
        ("not a valid MJCF model: Error: Error opening file",),
    ),
    "dm_control/locomotion/walkers/assets/build_fruitfly/fruitfly.xml": (
        "refused",
        ("not a valid MJCF model: Error: Error opening file",),
    ),
    "dm_control/locomotion/walkers/assets/dog_v2/dog.xml": (
        "FAIL",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "mesh inertia and the 1 kg default",
            "pointwise M",
        ),
    ),
    "dm_control/locomotion/walkers/assets/dog_v2/dog_base.xml": (
        "pass",
        ("no joint moves", "no equations of motion to compare"),
    ),
    "dm_control/locomotion/walkers/assets/dog_v2/scene.xml": (
        "refused",
        ("not a valid MJCF model: XML Error: Error: repeated name",),
    ),
    "dm_control/locomotion/walkers/assets/fruitfly_v2/floor.xml": (
        "FAIL",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "mesh inertia and the 1 kg default",
            "pointwise M",
        ),
    ),
    "dm_control/locomotion/walkers/assets/fruitfly_v2/fruitfly.xml": (
        "FAIL",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "mesh inertia and the 1 kg default",
            "pointwise M",
        ),
    ),
    "dm_control/locomotion/walkers/assets/humanoid_CMU_V2019.xml": (
        "pass",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "agree on the model and its dynamics",
        ),
    ),
    "dm_control/locomotion/walkers/assets/humanoid_CMU_V2020.xml": (
        "pass",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "agree on the model and its dynamics",
        ),
    ),
    "dm_control/locomotion/walkers/assets/jumping_ball/jumping_ball_with_head.xml": (
        "pass",
        ("Drake misreads camera_height's axis", "several joints in one body", "agree on the model and its dynamics"),
    ),
    "dm_control/locomotion/walkers/assets/rodent.xml": (
        "FAIL",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "collision-free geoms",
            "pointwise M",
        ),
    ),
    "dm_control/mjcf/test_assets/arena.xml": ("pass", ("no joint moves", "no equations of motion to compare")),
    "dm_control/mjcf/test_assets/included.xml": ("refused", ("fewer than two readers can read it",)),
    "dm_control/mjcf/test_assets/included_with_invalid_filenames.xml": (
        "refused",
        ("not a valid MJCF model: Error: Error opening file",),
    ),
    "dm_control/mjcf/test_assets/lego_brick.xml": ("pass", ("no joint moves", "no equations of motion to compare")),
    "dm_control/mjcf/test_assets/model_with_assetdir.xml": ("refused", ("fewer than two readers can read it",)),
    "dm_control/mjcf/test_assets/model_with_assets.xml": ("refused", ("fewer than two readers can read it",)),
    "dm_control/mjcf/test_assets/model_with_include.xml": ("refused", ("fewer than two readers can read it",)),
    "dm_control/mjcf/test_assets/model_with_invalid_filenames.xml": (
        "refused",
        ('<include file="invalid_included_name.xml">: no such file',),
    ),
    "dm_control/mjcf/test_assets/model_with_nameless_assets.xml": ("refused", ("fewer than two readers can read it",)),
    "dm_control/mjcf/test_assets/model_with_separators.xml": ("refused", ("fewer than two readers can read it",)),
    "dm_control/mjcf/test_assets/robot_arm.xml": (
        "pass",
        ("Pinocchio misreads b_1's com", "collision-free geoms", "agree on the model and its dynamics"),
    ),
    "dm_control/mjcf/test_assets/test_model.xml": (
        "refused",
        ("not a valid MJCF model: Error: unknown transmission target",),
    ),
    "dm_control/mujoco/testing/assets/arm.xml": (
        "pass",
        ("Pinocchio misreads b_1's com", "a fixed root's pose", "agree on the model and its dynamics"),
    ),
    "dm_control/mujoco/testing/assets/cartpole.xml": ("pass", ("agree on the model and its dynamics",)),
    "dm_control/mujoco/testing/assets/cartpole_no_names.xml": ("pass", ("agree on the model and its dynamics",)),
    "dm_control/mujoco/testing/assets/humanoid.xml": (
        "pass",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "agree on the model and its dynamics",
        ),
    ),
    "dm_control/mujoco/testing/assets/model_with_assets.xml": (
        "refused",
        ('<include file="included.xml">: no such file',),
    ),
    "dm_control/mujoco/testing/assets/model_with_ball_joints.xml": (
        "pass",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "agree on the model and its dynamics",
        ),
    ),
    "dm_control/mujoco/testing/assets/model_with_third_order_actuators.xml": (
        "pass",
        ("agree on the model and its dynamics",),
    ),
    "dm_control/mujoco/testing/assets/sphere.xml": ("pass", ("no joint moves", "no equations of motion to compare")),
    "dm_control/suite/acrobot.xml": (
        "pass",
        (
            "Pinocchio misreads upper_arm's mass",
            "geom mass from a default class",
            "agree on the model and its dynamics",
        ),
    ),
    "dm_control/suite/ball_in_cup.xml": ("pass", ("agree on the model and its dynamics",)),
    "dm_control/suite/cartpole.xml": (
        "pass",
        ("Pinocchio misreads pole_1's mass", "geom mass from a default class", "agree on the model and its dynamics"),
    ),
    "dm_control/suite/cheetah.xml": ("FAIL", ("Pinocchio misreads torso's mass", "settotalmass", "pointwise M")),
    "dm_control/suite/common/materials.xml": ("pass", ("no joint moves", "no equations of motion to compare")),
    "dm_control/suite/common/skybox.xml": ("pass", ("no joint moves", "no equations of motion to compare")),
    "dm_control/suite/common/visual.xml": ("pass", ("no joint moves", "no equations of motion to compare")),
    "dm_control/suite/dog.xml": (
        "FAIL",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "mesh inertia and the 1 kg default",
            "pointwise M",
        ),
    ),
    "dm_control/suite/finger.xml": (
        "pass",
        ("Pinocchio misreads distal's mass", "collision-free geoms", "agree on the model and its dynamics"),
    ),
    "dm_control/suite/fish.xml": (
        "pass",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "agree on the model and its dynamics",
        ),
    ),
    "dm_control/suite/hopper.xml": ("pass", ("agree on the model and its dynamics",)),
    "dm_control/suite/humanoid.xml": (
        "pass",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "agree on the model and its dynamics",
        ),
    ),
    "dm_control/suite/humanoid_CMU.xml": (
        "pass",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "agree on the model and its dynamics",
        ),
    ),
    "dm_control/suite/lqr.xml": ("pass", ("no joint moves", "no equations of motion to compare")),
    "dm_control/suite/manipulator.xml": (
        "pass",
        ("Pinocchio misreads ball's com", "collision-free geoms", "agree on the model and its dynamics"),
    ),
    "dm_control/suite/pendulum.xml": ("pass", ("agree on the model and its dynamics",)),
    "dm_control/suite/point_mass.xml": ("pass", ("agree on the model and its dynamics",)),
    "dm_control/suite/quadruped.xml": ("refused", ("fewer than two readers can read it",)),
    "dm_control/suite/reacher.xml": ("pass", ("agree on the model and its dynamics",)),
    "dm_control/suite/stacker.xml": (
        "pass",
        ("Pinocchio misreads box0's com", "collision-free geoms", "agree on the model and its dynamics"),
    ),
    "dm_control/suite/swimmer.xml": (
        "pass",
        ("Pinocchio misreads head's mass", "geom mass from a default class", "agree on the model and its dynamics"),
    ),
    "dm_control/suite/walker.xml": ("pass", ("agree on the model and its dynamics",)),
    "dm_control/third_party/ant/ant.xml": (
        "pass",
        ("Pinocchio misreads front_left_aux's com", "a fixed root's pose", "agree on the model and its dynamics"),
    ),
    "dm_control/third_party/kinova/common.xml": ("pass", ("no joint moves", "no equations of motion to compare")),
    "dm_control/third_party/kinova/jaco_arm.xml": ("refused", ("fewer than two readers can read it",)),
    "dm_control/third_party/kinova/jaco_hand.xml": ("refused", ("fewer than two readers can read it",)),
    "gymnasium_robotics/envs/assets/adroit_hand/adroit_door.xml": ("refused", ("fewer than two readers can read it",)),
    "gymnasium_robotics/envs/assets/adroit_hand/adroit_hammer.xml": (
        "FAIL",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "a <compiler> after the bodies",
            "pointwise V",
        ),
    ),
    "gymnasium_robotics/envs/assets/adroit_hand/adroit_pen.xml": ("refused", ("fewer than two readers can read it",)),
    "gymnasium_robotics/envs/assets/adroit_hand/adroit_relocate.xml": (
        "refused",
        ("fewer than two readers can read it",),
    ),
    "gymnasium_robotics/envs/assets/fetch/pick_and_place.xml": (
        "pass",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "agree on the model and its dynamics",
        ),
    ),
    "gymnasium_robotics/envs/assets/fetch/push.xml": (
        "pass",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "agree on the model and its dynamics",
        ),
    ),
    "gymnasium_robotics/envs/assets/fetch/reach.xml": (
        "pass",
        ("Drake's MJCF parser cannot read it", "agree on the model and its dynamics"),
    ),
    "gymnasium_robotics/envs/assets/fetch/robot.xml": ("refused", ("fewer than two readers can read it",)),
    "gymnasium_robotics/envs/assets/fetch/shared.xml": (
        "refused",
        ("not a valid MJCF model: Error: Error opening file",),
    ),
    "gymnasium_robotics/envs/assets/fetch/slide.xml": (
        "pass",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "agree on the model and its dynamics",
        ),
    ),
    "gymnasium_robotics/envs/assets/hand/manipulate_block.xml": (
        "FAIL",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "collision-free geoms",
            "pointwise M",
        ),
    ),
    "gymnasium_robotics/envs/assets/hand/manipulate_block_touch_sensors.xml": (
        "FAIL",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "collision-free geoms",
            "pointwise M",
        ),
    ),
    "gymnasium_robotics/envs/assets/hand/manipulate_egg.xml": (
        "FAIL",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "collision-free geoms",
            "pointwise M",
        ),
    ),
    "gymnasium_robotics/envs/assets/hand/manipulate_egg_touch_sensors.xml": (
        "FAIL",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "collision-free geoms",
            "pointwise M",
        ),
    ),
    "gymnasium_robotics/envs/assets/hand/manipulate_pen.xml": (
        "FAIL",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "collision-free geoms",
            "pointwise M",
        ),
    ),
    "gymnasium_robotics/envs/assets/hand/manipulate_pen_touch_sensors.xml": (
        "FAIL",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "collision-free geoms",
            "pointwise M",
        ),
    ),
    "gymnasium_robotics/envs/assets/hand/reach.xml": (
        "pass",
        ("Drake's MJCF parser cannot read it", "agree on the model and its dynamics"),
    ),
    "gymnasium_robotics/envs/assets/hand/robot.xml": ("refused", ("fewer than two readers can read it",)),
    "gymnasium_robotics/envs/assets/hand/robot_touch_sensors_92.xml": (
        "refused",
        ("fewer than two readers can read it",),
    ),
    "gymnasium_robotics/envs/assets/hand/shared.xml": ("refused", ("not a valid MJCF model: Error: geom",)),
    "gymnasium_robotics/envs/assets/hand/shared_asset.xml": (
        "refused",
        ("not a valid MJCF model: XML Error: Schema violation: unrecognized element",),
    ),
    "gymnasium_robotics/envs/assets/hand/shared_touch_sensors_92.xml": (
        "refused",
        ("not a valid MJCF model: Error: unrecognized name",),
    ),
    "gymnasium_robotics/envs/assets/kitchen_franka/kitchen_assets/kitchen_env_model.xml": (
        "refused",
        ("fewer than two readers can read it",),
    ),
    "gymnasium_robotics/envs/assets/point/point.xml": ("pass", ("agree on the model and its dynamics",)),
    "gymnasium_robotics/envs/mujoco/assets/ant.xml": (
        "pass",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "agree on the model and its dynamics",
        ),
    ),
    "gymnasium_robotics/envs/mujoco/assets/half_cheetah.xml": (
        "FAIL",
        ("Pinocchio misreads torso's mass", "settotalmass", "pointwise M"),
    ),
    "gymnasium_robotics/envs/mujoco/assets/hopper.xml": ("pass", ("agree on the model and its dynamics",)),
    "gymnasium_robotics/envs/mujoco/assets/humanoid.xml": (
        "pass",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "agree on the model and its dynamics",
        ),
    ),
    "gymnasium_robotics/envs/mujoco/assets/humanoidstandup.xml": (
        "pass",
        (
            "Drake's MJCF parser composes several hinges in one body otherwise than MuJoCo",
            "agree on the model and its dynamics",
        ),
    ),
    "gymnasium_robotics/envs/mujoco/assets/inverted_double_pendulum.xml": (
        "pass",
        ("agree on the model and its dynamics",),
    ),
    "gymnasium_robotics/envs/mujoco/assets/inverted_pendulum.xml": ("pass", ("agree on the model and its dynamics",)),
    "gymnasium_robotics/envs/mujoco/assets/point.xml": ("pass", ("agree on the model and its dynamics",)),
    "gymnasium_robotics/envs/mujoco/assets/pusher.xml": (
        "pass",
        (
            "Pinocchio misreads r_shoulder_pan_link's mass",
            "collision-free geoms",
            "agree on the model and its dynamics",
        ),
    ),
    "gymnasium_robotics/envs/mujoco/assets/reacher.xml": (
        "pass",
        ("Pinocchio misreads target's mass", "collision-free geoms", "agree on the model and its dynamics"),
    ),
    "gymnasium_robotics/envs/mujoco/assets/swimmer.xml": (
        "pass",
        ("Pinocchio misreads torso's mass", "collision-free geoms", "agree on the model and its dynamics"),
    ),
    "gymnasium_robotics/envs/mujoco/assets/walker2d.xml": ("pass", ("agree on the model and its dynamics",)),
    "gymnasium_robotics/envs/multiagent_mujoco/assets/coupled_half_cheetah.xml": (
        "FAIL",
        ("Pinocchio misreads torso0's mass", "settotalmass", "pointwise M"),
    ),
    "rtbdata/xacro/abb_irb140_description/urdf/irb140.urdf": ("pass", ("agree on the model and its dynamics",)),
    "rtbdata/xacro/abb_irb140_description/urdf/irb140QT.urdf": ("pass", ("agree on the model and its dynamics",)),
    "rtbdata/xacro/kuka_description/kuka_kr120/urdf/kr120r2500pro.urdf": (
        "pass",
        ("agree on the model and its dynamics",),
    ),
    "rtbdata/xacro/kuka_description/kuka_kr16/urdf/kr16_2.urdf": ("pass", ("agree on the model and its dynamics",)),
    "rtbdata/xacro/kuka_description/kuka_kr210/urdf/kr210l150.urdf": ("pass", ("agree on the model and its dynamics",)),
    "rtbdata/xacro/kuka_description/kuka_lbr_iiwa/urdf/lbr_iiwa_14_r820.urdf": (
        "pass",
        ("agree on the model and its dynamics",),
    ),
    "rtbdata/xacro/lynxmotion_al5d_description/urdf/al5d_robot.urdf": (
        "pass",
        ("agree on the model and its dynamics",),
    ),
    "rtbdata/xacro/unimation_puma560_description/urdf/puma560_robot.urdf": (
        "pass",
        ("agree on the model and its dynamics",),
    ),
}
