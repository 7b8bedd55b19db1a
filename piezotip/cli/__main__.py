"""``python -m piezotip.cli``: the command line, as the console script runs it (:func:`piezotip.cli.main`).

The command line is a subpackage of its own, on top: it imports the reports
(:mod:`piezotip.reports`), which sit above the API they call, and nothing below imports it.
"""

import sys

from piezotip.cli import main

sys.exit(main())
