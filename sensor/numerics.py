"""Numerical helpers shared by the sensor modules."""

from __future__ import annotations


def brentq(f, a: float, b: float, **kwargs) -> float:
    """:func:`scipy.optimize.brentq`, imported on first use.

    ``scipy.optimize`` takes about 0.3 s to import; a run whose tables come from the cache
    (:mod:`piezotip.sensor.cache`) never finds a root, so the command does not pay for it.
    """
    from scipy.optimize import brentq as scipy_brentq

    return scipy_brentq(f, a, b, **kwargs)
