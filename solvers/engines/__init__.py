"""MoM engines behind one protocol (:class:`~solvers.engines.base.Solver`). Each engine is
a sub-package that registers its solver class with :func:`register_engine`; every
sub-package here is imported, so a second engine is a new folder and nothing else."""
from __future__ import annotations

import importlib
import pkgutil

from .base import (
    DEFAULT_FREQS_MHZ,
    ENGINES,
    FrequencySolver,
    Plan,
    Solver,
    make_solver,
    register_engine,
)
from .cache import BeamCache

__all__ = ["DEFAULT_FREQS_MHZ", "ENGINES", "BeamCache", "FrequencySolver", "Plan", "Solver", "make_solver",
           "register_engine"]

for _m in pkgutil.iter_modules(__path__):
    if _m.ispkg:
        importlib.import_module(f"{__name__}.{_m.name}")
