"""Reports built on the product (installed as ``piezotip.reports``): the benchmark and its fidelity
Pareto, the readout's coverage, the creep table, the paper's figures, the dynamic range, the
skin's price, the touch's trade and the third-party grippers' tables (matplotlib lives here and
in :mod:`piezotip.analysis`, not in sensor/).

This package sits above the public API: a report may run grasps through ``piezotip.run`` and
read :mod:`piezotip.analysis` (the runner, the referee, the sweeps, the plots); nothing beneath
it imports it, only the command line (:mod:`piezotip.cli`) does.
"""
