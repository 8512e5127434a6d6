"""The first-order recursion y[n] = a y[n-1] + b0 x[n] of ``scipy.signal.lfilter`` without
importing ``scipy.signal`` (which imports ``scipy.stats`` and most of scipy: 0.35-0.45 s of CPU,
a tenth of a diagnosis, for one recursion numpy cannot run). One loader for the transducer's
low pass of the diagnosis (``cyclo_fmu.diagnosis.replay.first_order``) and the housing's heat
balance (``model_core.thermal.housing_path``)."""
from __future__ import annotations

import numpy as np

__all__ = ["linear_filter"]

_KERNEL = []


def linear_filter():
    """``(b, a, x, axis, zi) -> (y, zf)`` of ``scipy.signal.lfilter`` (a denominator of two or
    more coefficients): the compiled kernel lfilter hands its arrays to
    (``scipy.signal._sigtools._linear_filter``), loaded from its file without the package.
    Importing scipy.signal imports scipy.stats and most of scipy (0.35-0.45 s of CPU, a tenth
    of a diagnosis) for this one recursion, which numpy cannot run. The kernel is checked once
    against the recursion written out; where it is not found or differs (another scipy),
    scipy.signal.lfilter itself."""
    if not _KERNEL:
        _KERNEL.append(_sigtools_kernel() or _public_lfilter)
    return _KERNEL[0]


def _public_lfilter(b, a, x, axis, zi):
    from scipy.signal import lfilter
    return lfilter(b, a, x, axis=axis, zi=zi)


def _sigtools_kernel():
    import importlib.machinery
    import importlib.util
    import os
    import sys
    name = "scipy.signal._sigtools"
    if "scipy.signal" in sys.modules:            # imported anyway: nothing to save
        return None
    try:
        mod = sys.modules.get(name)
        if mod is None:
            import scipy
            folder = os.path.join(os.path.dirname(scipy.__file__), "signal")
            path = next(os.path.join(folder, "_sigtools" + sfx)
                        for sfx in importlib.machinery.EXTENSION_SUFFIXES
                        if os.path.exists(os.path.join(folder, "_sigtools" + sfx)))
            loader = importlib.machinery.ExtensionFileLoader(name, path)
            mod = importlib.util.module_from_spec(
                importlib.util.spec_from_file_location(name, path, loader=loader))
            loader.exec_module(mod)
        kernel = mod._linear_filter
        # y[n] = a y[n-1] + b0 x[n] from y[-1] = zi / a, in floats as the kernel adds them
        c = 0.3
        x = np.array([[1.0, -2.0], [0.5, 4.0], [-3.0, 0.25], [2.0, 1.0]])
        y, z = np.empty_like(x), c * x[0]
        for i in range(len(x)):
            y[i] = z + (1 - c) * x[i]
            z = c * y[i]
        got, zf = kernel(np.atleast_1d([1 - c]), np.atleast_1d([1, -c]), x, 0, c * x[:1])
        if not (np.array_equal(got, y) and np.array_equal(zf, z[None])):
            return None
        return kernel
    except (ImportError, OSError, StopIteration, AttributeError, TypeError, ValueError):
        return None
