#!/usr/bin/env python3
"""piezotip's command line from a checkout: ``python run_sim.py --help``.

The commands live in :mod:`piezotip.cli` (installed as the ``piezotip`` console script too).
"""

import sys

if __name__ == "__main__":
    # First and alone, before any heavy import: its SIGTERM handler is in within a millisecond
    # (piezotip/_console.py).
    from piezotip._console import main

    sys.exit(main())
else:  # imported: run_sim.main(argv), as piezotip.cli.main
    from piezotip.cli import main
