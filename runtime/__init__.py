"""What every run needs below the analysis and the command line (installed as ``piezotip.runtime``):
``interrupts`` (a run stopped by a signal, what is written kept) and ``provenance`` (the versions,
seeds and configuration an output records).  Their public names are ``piezotip.interrupts`` and
``piezotip.provenance``, as before; living here, no package below the top one imports it."""
