"""The compiled model a scenario runs, and what a driver outside the loop commands in it: the
house gripper's scene (:mod:`cosim.scene`) or, with ``gripper.mjcf``, that gripper mounted on the
lift (:mod:`cosim.gripper_mount`, which builds on the scene).  Above both, so neither imports
the other's caller.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco

from piezotip.cosim.config import ScenarioConfig
from piezotip.sensor.gel import GelParams

from .gripper_mount import mount_gripper, widest_object_m
from .scene import HOME_OPENING_M, build_house_scene, finger_force_limit_n, gravity_m_s2

__all__ = ["GripperRanges", "build_scene", "gripper_ranges"]


def build_scene(config: ScenarioConfig, gel: GelParams | None = None) -> mujoco.MjModel:
    """The compiled model for ``config``: its object, pad resolution, timestep and integrator;
    with ``gripper.mjcf``, that gripper on the lift (:func:`cosim.gripper_mount.mount_gripper`)."""
    if config.gripper.mjcf is not None:
        return mount_gripper(config, gel).model
    return build_house_scene(config, gel)


@dataclass(frozen=True)
class GripperRanges:
    """What a driver outside the loop (a Gymnasium agent) commands the gripper within.

    Attributes
    ----------
    lift_range_m : the lift servo's set-points, (low, high), m.
    opening_range_m : the fingers' opening set-points, (low, high), m (0 = the unloaded pads
        touching).
    opening_joint_range_m : the openings the fingers reach, (low, high), m.
    finger_force_limit_n : the fingers' force limit, N per finger.
    gravity_m_s2 : the magnitude of gravity, m/s^2.
    widest_object_m : the widest object the gripper takes, m: its open pads less a clearance a
        side (:func:`cosim.gripper_mount.widest_object_m`; the house's 85 mm).
    """

    lift_range_m: tuple[float, float]
    opening_range_m: tuple[float, float]
    opening_joint_range_m: tuple[float, float]
    finger_force_limit_n: float
    gravity_m_s2: float
    widest_object_m: float


def gripper_ranges(config: ScenarioConfig) -> GripperRanges:
    """The gripper's command ranges and force limit for ``config``, as its model has them: the
    house gripper's servos (models/gripper.xml), or a mounted gripper's drive (from its open
    pads down to touching, its rating: cosim.gripper_mount)."""
    if config.gripper.mjcf is not None:
        mounted = mount_gripper(config)
        lift, drive = mounted.model.actuator("lift_actuator"), mounted.drive
        reach = (float(drive.path.opening_m[0]), drive.home_opening_m)
        ranges = (float(lift.ctrlrange[0]), float(lift.ctrlrange[1])), (0.0, drive.home_opening_m), reach
        return GripperRanges(*ranges, drive.rating_n(), gravity_m_s2(mounted.model), widest_object_m(drive.home_opening_m))
    model = build_house_scene(config)
    lift, fingers = model.actuator("lift_actuator"), model.actuator("fingers_actuator")
    joints = [model.joint(f"{side}_finger_joint").range for side in ("left", "right")]
    return GripperRanges(
        (float(lift.ctrlrange[0]), float(lift.ctrlrange[1])),
        (float(fingers.ctrlrange[0]), float(fingers.ctrlrange[1])),
        # The opening is the fingers tendon: the sum of the two finger joints (coef 1 each).
        (float(joints[0][0] + joints[1][0]), float(joints[0][1] + joints[1][1])),
        finger_force_limit_n(model),
        gravity_m_s2(model),
        widest_object_m(HOME_OPENING_M),
    )
