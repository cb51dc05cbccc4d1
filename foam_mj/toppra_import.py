"""Importing ``toppra`` without the plotting and spline modules it loads and foam-mj never uses (see :func:`import_toppra`)."""

from __future__ import annotations

from typing import Any, cast


class _LazyScipyName:
    """Stands for ``scipy.interpolate.<name>`` in toppra's modules: imports scipy.interpolate when used."""

    def __init__(self, name: str) -> None:
        self._name = name

    def _real(self):
        import importlib

        return getattr(importlib.import_module("scipy.interpolate"), self._name)

    def __call__(self, *args, **kwargs):
        return self._real()(*args, **kwargs)

    def __getattr__(self, attr: str):
        return getattr(self._real(), attr)


def _lazy_scipy_interpolate_name(name: str) -> _LazyScipyName:
    if name.startswith("_"):  # module machinery (__path__, __spec__...): the stand-in has none
        raise AttributeError(name)
    return _LazyScipyName(name)


def import_toppra() -> Any:
    """``toppra`` (with its algorithm, constraint and interpolator modules).

    toppra 0.6 imports ``matplotlib.pyplot`` and ``scipy.interpolate`` when it is imported, for plotting
    helpers and spline paths foam-mj never uses (its path is :func:`foam_mj.timing._toppra_law`'s own curve); those imports cost about
    0.5 s and 0.15 s of CPU on every ``plan``. While toppra is imported, a module not loaded yet is replaced
    by a stand-in: empty for ``matplotlib`` and ``matplotlib.pyplot``; for ``scipy.interpolate``, names
    that import the real module when toppra uses them (:class:`_LazyScipyName`). The stand-ins are removed
    right after, so a later import (figures, or anyone's scipy.interpolate) loads the real modules.
    """
    import sys
    import types

    if "toppra.algorithm" in sys.modules:
        import toppra
        import toppra.algorithm  # noqa: F401
        return toppra
    stubs: dict[str, Any] = {}
    if "matplotlib" not in sys.modules:
        stubs["matplotlib"] = types.ModuleType("matplotlib")
        stubs["matplotlib.pyplot"] = types.ModuleType("matplotlib.pyplot")
        stubs["matplotlib"].__path__ = []  # a package, so that "matplotlib.pyplot" resolves to its stand-in
        stubs["matplotlib"].pyplot = stubs["matplotlib.pyplot"]
    if "scipy.interpolate" not in sys.modules:
        stubs["scipy.interpolate"] = interp = cast(Any, types.ModuleType("scipy.interpolate"))
        interp.__getattr__ = _lazy_scipy_interpolate_name  # any name toppra imports from it
    sys.modules.update(stubs)
    try:
        import toppra
        import toppra.algorithm  # noqa: F401
        import toppra.constraint  # noqa: F401
        import toppra.interpolator  # noqa: F401
    finally:
        for name, stub in stubs.items():
            if sys.modules.get(name) is stub:
                del sys.modules[name]
    return toppra
