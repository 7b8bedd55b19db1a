"""Grasp controllers: the interface the loop calls, the phases, and the controllers.

- :mod:`.interface`: :class:`Observation` (what a controller may see), :class:`Command`,
  :class:`Event`, :class:`RobotLimits` (the gripper's own design) and the :class:`Controller`
  protocol the co-simulation loop calls.
- :mod:`.phases`: :class:`Phase`, the grasp's phases (recorded as their codes).
- :mod:`.selector`: the per-fingertip mode selector and touch detector.
- :mod:`.scripted`: :class:`ScriptedGrasp`, fixed targets, no sensing.
- :mod:`.multimode`: :class:`MultimodeGrasp`, the fingertip-driven controller.
- :mod:`.gentle`: :class:`GentleGrasp`, the multimode controller finding the grip that holds
  with a friction probe instead of assuming the friction.
- :mod:`.registry`: the controller registry (public name :mod:`piezotip.controllers`).

Each controller registers itself (:func:`.registry.register`, :func:`piezotip.controllers.register`)
with its config class (cosim/control/config.py) under its ``controller.kind``: importing this package
registers them.
"""

from ._control import make_command, make_observation, make_pad_signal
from .gentle import GentleGrasp
from .interface import (
    Command,
    Controller,
    Event,
    Observation,
    PadSignal,
    RobotLimits,
    Why,
    pad_names,
)
from .multimode import MultimodeGrasp, grip_floor_n
from .phases import PHASES, Phase, phase_index
from .scripted import ScriptedGrasp
from .selector import ModeSelector, TouchDetector

__all__ = [
    "PHASES",
    "Command",
    "Controller",
    "Event",
    "GentleGrasp",
    "ModeSelector",
    "MultimodeGrasp",
    "Observation",
    "PadSignal",
    "Phase",
    "RobotLimits",
    "ScriptedGrasp",
    "TouchDetector",
    "Why",
    "grip_floor_n",
    "make_command",
    "make_observation",
    "make_pad_signal",
    "pad_names",
    "phase_index",
]
