#!/usr/bin/env python3
"""piezotip's command line from a checkout: ``python run_sim.py --help``.

The commands live in :mod:`piezotip.cli` (installed as the ``piezotip`` console script too).
"""

import sys

from piezotip.cli import main

if __name__ == "__main__":
    sys.exit(main())
