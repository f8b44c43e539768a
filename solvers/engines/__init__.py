"""MoM engines behind one abstract base (:class:`~solvers.engines.base.Solver`). Each engine is
a sub-package that registers its solver class with :func:`register_engine`; the registry
(``ENGINES``) imports every sub-package here on first use, so a second engine is a new
folder and nothing else, and importing this package costs no engine's imports."""
from __future__ import annotations

from .base import (
    DEFAULT_FREQS_MHZ,
    ENGINES,
    Plan,
    Solver,
    make_solver,
    register_engine,
)
from .cache import BeamCache

__all__ = ["DEFAULT_FREQS_MHZ", "ENGINES", "BeamCache", "Plan", "Solver", "make_solver", "register_engine"]
