"""What the product runs after the physics: the runner behind ``piezotip.run``, the referee, the run's
report and plot, the sweeps (their cluster, journal, rows and output), the experiment command, video
and render (matplotlib lives here and in reports/, not in sensor/).

Nothing here imports the public API above it (``piezotip``, ``piezotip.api``, ``piezotip.cli``), not
even inside a function: the reports that run grasps through ``piezotip.run`` are
:mod:`piezotip.reports`.
"""
