"""piezotip's speed benchmarks: the developers' measuring tools, not installed (README.md here).

Each is run from the repository's root against the installed ``piezotip`` (``python -m
benchmarks.NAME``, or ``python benchmarks/NAME.py``), or against git revisions
(``python -m benchmarks.revisions``).  The product's own ``run_sim.py bench`` reports what a
user trades (real-time factor, overhead over bare mj_step, each preset's cost and error).
"""
