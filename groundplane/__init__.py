"""groundplane: design ground planes for low-frequency radio antennas.

The public Python API, in the domain's words (every name has a docstring with an example; the
API reference is ``docs/api``). From the core: :class:`Beam` (any solver's beam, any file),
:mod:`shapes` (the families, ``preset``, ``from_file``), :class:`Soil` and the grounds,
:func:`fom` (the chromaticity Figure of Merit), :func:`compare`, :func:`export` (STEP/STL) and
:func:`fabrication_plan`.
Added by the higher layers (through entry points: the core never imports them): :func:`solve`
(a plane's beam, by an engine), :func:`solve_soils` (one plane over several soils, solved
together), :func:`score` (a design on a scenario set), :func:`optimise` and
:func:`sweep`. Everything else is internal and may change::

    import groundplane as gp
    beam = gp.solve(gp.shapes.preset("square-10"), freqs="55:97:6", mesh=1.0)
    print(gp.fom(beam).lst_averaged_mk)
"""
from typing import Any

from . import shapes
from .api import compare, export, fabrication_plan, fom
from .beam import Beam, BeamFormatError
from .design import Design, FreeSpace, InfinitePEC, Soil
from .errors import ArgumentError, GroundplaneError, SolverError, UserInputError
from .fom import FomResult, FomSettings
from .shapes import from_file, preset

__all__ = ["ArgumentError", "Beam", "BeamFormatError", "Design", "FomResult", "FomSettings", "FreeSpace", "GroundplaneError",
           "InfinitePEC", "Soil", "SolverError", "UserInputError", "compare", "export", "fabrication_plan", "fom", "from_file",
           "optimise", "preset", "score", "shapes", "solve", "solve_soils", "sweep"]
__version__ = "0.1.0"

_HIGHER = ("solve", "solve_soils", "score", "optimise", "sweep")


def __getattr__(name: str) -> Any:
    """``solve``, ``score``, ``optimise`` and ``sweep``: the higher layers' functions, found
    through the ``groundplane.api`` entry points on first use."""
    if name in _HIGHER:
        from .api import higher_layer

        fn = higher_layer(name)
        globals()[name] = fn
        return fn
    raise AttributeError(f"module 'groundplane' has no attribute '{name}'")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_HIGHER))
