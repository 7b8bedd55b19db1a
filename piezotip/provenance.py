"""``piezotip.provenance``: the public name of :mod:`piezotip.runtime.provenance` (its one source; every name of it here)."""

import sys

from piezotip.runtime import provenance as _module

# The public name is the module itself (one module object: its classes, caches and state are one).
sys.modules[__name__] = _module
