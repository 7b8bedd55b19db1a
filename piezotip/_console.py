"""The command line's entry, for the ``piezotip`` console script and ``python run_sim.py``.

A signal before the command line's own handling begins (while Python imports it) is an
interruption as any later one: one line and 130 (Ctrl-C) or 143 (SIGTERM), no traceback.  So
this module is imported first and alone (``import piezotip`` costs about a millisecond: no
numpy, no MuJoCo), and sets a bare SIGTERM handler before the heavy imports begin: pip's own
wrapper, ``from piezotip.cli import main``, ended by SIGTERM's default action (status -15, no
line) or printed a Ctrl-C's traceback in the import's first tens of milliseconds.
"""

from __future__ import annotations

import signal
import sys


def _terminated(signum, frame):
    """SIGTERM until piezotip's own handler is in: an interruption, status 128 + signum."""
    err = KeyboardInterrupt()
    err.exit_status = 128 + signum  # type: ignore[attr-defined]
    raise err


def main() -> int:
    """Run the command line on ``sys.argv``; its exit status."""
    try:
        signal.signal(signal.SIGTERM, _terminated)
        from piezotip.interrupts import raise_interruption

        signal.signal(signal.SIGTERM, raise_interruption)  # as the command line's main() has it
        from piezotip.cli import main as command_line

        return command_line()
    except KeyboardInterrupt as err:
        print("interrupted", file=sys.stderr)
        return getattr(err, "exit_status", 130)
