"""The grasp phases, in order; a phase is recorded as its integer value (``phase`` column)."""

from __future__ import annotations

from enum import IntEnum


class Phase(IntEnum):
    """Where a grasp controller is.  The values are the recorded codes (keep them stable)."""

    APPROACH = 0  # learn the unloaded baseline, check the element
    CLOSE = 1  # close the fingers until the fingertips feel the touch
    SQUEEZE = 2  # settle at the gentlest grip the fingertips can measure
    LIFT = 3  # move the weight from the table onto the pads, then raise
    HOLD = 4  # hold at the top, watching for slip
    PLACE = 5  # lower until the table takes the weight
    RELEASE = 6  # open the fingers at the gripper's speed until the pads are off the object
    DONE = 7  # finished (a success or a reasoned give-up); the fingers open on home
    FAULT = 8  # refused to grasp (self-test) or a sensor fault

    @property
    def label(self) -> str:
        return self.name.lower()


#: The phases a controller has finished in (a tuple: ``phase in FINISHED`` compares by identity
#: first, where an enum's hash is a Python function).
FINISHED = (Phase.DONE, Phase.FAULT)

#: Phase names in code order (the recording's ``phase_codes``).
PHASES: tuple[str, ...] = tuple(p.label for p in Phase)


def phase_index(phase: str | Phase) -> int:
    """The recorded code of ``phase`` (a Phase or its name)."""
    return int(phase) if isinstance(phase, Phase) else PHASES.index(phase)
