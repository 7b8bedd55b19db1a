#!/usr/bin/env python3
"""piezotip's command line from a checkout: ``python run_sim.py --help``.

The commands live in :mod:`piezotip.cli` (installed as the ``piezotip`` console script too).
"""

import signal
import sys

if __name__ == "__main__":
    # A signal before the command line's own handling begins (while Python imports it) is an
    # interruption as any later one: one line and 130 (Ctrl-C) or 143 (SIGTERM), no traceback.
    def _terminated(signum, frame):
        """SIGTERM until piezotip's own handler is in: an interruption, status 128 + signum."""
        err = KeyboardInterrupt()
        err.exit_status = 128 + signum
        raise err

    try:
        # First, before piezotip's import (tens of milliseconds on a loaded machine): SIGTERM's
        # default action would end the process without a word (status -15).
        signal.signal(signal.SIGTERM, _terminated)
        from piezotip.interrupts import raise_interruption

        signal.signal(signal.SIGTERM, raise_interruption)  # as main() has it
        from piezotip.cli import main

        status = main()
    except KeyboardInterrupt as err:
        print("interrupted", file=sys.stderr)
        status = getattr(err, "exit_status", 130)
    sys.exit(status)
else:  # imported: run_sim.main(argv), as piezotip.cli.main
    from piezotip.cli import main
