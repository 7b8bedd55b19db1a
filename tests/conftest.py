"""Fixtures shared by the test modules."""

from __future__ import annotations

import pytest

from piezotip.cosim import mjhooks


@pytest.fixture(params=["c", "python"])
def dispatch(request):
    """MuJoCo's callbacks dispatched in C (cosim/_mjcallbacks.pyx, which takes a step that samples
    nothing itself; skipped where not built) or by mjhooks' Python dispatchers, for the models
    bound in the test (the hooks run the same either way)."""
    compiled = request.param == "c"
    if compiled and mjhooks._C is None:
        pytest.skip("the C dispatchers are not in use (not built, or PIEZOTIP_PURE_PYTHON)")
    before = mjhooks.compiled_dispatch()
    mjhooks.use_compiled(compiled)
    yield request.param
    mjhooks.use_compiled(before)
