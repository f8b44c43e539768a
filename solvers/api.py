"""The solver layer's public functions, reached as ``groundplane.solve`` (through the
``groundplane.api`` entry points: the core never imports this package)."""
from __future__ import annotations

from typing import Any, Mapping, Sequence

from groundplane.beam import Beam
from groundplane.design import Design, FreeSpace, InfinitePEC, Soil
from groundplane.errors import ConfigError, UserInputError
from groundplane.options import build, expect, option_keys
from groundplane.shapes import GroundPlane, as_plane

__all__ = ["solve", "solve_soils", "design_of", "solve_options_from_mapping"]


def solve_options_from_mapping(values: Mapping[str, Any], where: str) -> tuple[Soil, Any, Any]:
    """(soil, solve settings, engine settings) from a sweep file's ``[solver]`` table or the
    API's keywords (strictly typed; unknown keys refused)."""
    from .engines import ENGINES
    from .engines.base import SolveSettings

    engine = values.get("engine", SolveSettings().engine)
    if not isinstance(engine, str) or engine not in ENGINES:
        raise ConfigError(f"{where}engine '{engine}': choose one of {', '.join(ENGINES)}")
    owners = (Soil, SolveSettings, ENGINES[engine].settings_class)
    known = set().union(*(option_keys(c) for c in owners))
    unknown = set(values) - known
    if unknown:
        raise ConfigError(f"{where}unknown key(s) {sorted(unknown)}; expected some of {sorted(known)}")
    soil, solve, model = (build(c, {k: v for k, v in values.items() if k in option_keys(c)}, where) for c in owners)
    return soil, solve, model


def design_of(plane: GroundPlane | str | Design | None, ground: str = "soil", soil: Soil | None = None) -> Design:
    """What one solve is of: a plane (or a preset's name) on ``ground`` ('soil', 'pec' or 'free'),
    or a :class:`~groundplane.design.Design` as it is."""
    if isinstance(plane, Design):
        return plane
    if plane is not None:
        plane = as_plane(plane, "solve()")
    expect(ground, str, "ground", "solve()", "'soil', 'pec' or 'free'")
    if ground == "pec":
        return Design(plane, InfinitePEC())
    if ground == "free":
        return Design(plane, FreeSpace())
    if ground != "soil":
        raise UserInputError(f"ground '{ground}': choose soil, pec or free")
    if plane is None:
        raise UserInputError("a solve over soil needs a ground plane (or ground='pec' for the blade alone)")
    return Design(plane, soil or Soil())


def solve(plane: GroundPlane | str | Design | None, *, ground: str = "soil", progress: bool = False,
          cache: bool = True, **options: Any) -> Beam:
    """The beam of a ground plane (a shape, a preset's name, or a Design), solved by an engine.

    Parameters
    ----------
    plane
        ``groundplane.shapes.preset("square-10")``, ``"square-10"``, any family member, a
        :class:`~groundplane.design.Design`, or None with ``ground="pec"`` (the blade alone).
    ground : str
        'soil' (the default: lossy soil under the plate, ``eps_r`` and ``sigma`` options),
        'pec' (infinite perfect ground) or 'free' (no ground).
    progress : bool
        Print a progress line per frequency.
    cache : bool
        Read and write the content-keyed beam cache (``$GROUNDPLANE_CACHE``).
    **options
        Any solver option by its sweep-file key, type-checked as the command line's: ``engine``
        ('surface' or 'nec'), ``freqs`` ('55:97:2', a list, or 'fit-band'; default 40-100 MHz at
        1 MHz), ``workers``, ``eps_r``, ``sigma``, ``mesh`` (m), ``plate_height``, ``method``,
        ``feed_width``, ``blade_cells``, ... (``groundplane solve --help`` lists them).

    Returns
    -------
    Beam
        Linear power gain [f, theta, phi] and its metadata (the model, the input impedance, ...).

    Examples
    --------
    >>> import groundplane as gp
    >>> beam = gp.solve("square-10", freqs="55:97:21", mesh=1.5, blade_cells=(4, 4))  # doctest: +SKIP
    >>> beam.freqs_mhz.tolist()  # doctest: +SKIP
    [55.0, 76.0, 97.0]
    """
    soil, settings, model = solve_options_from_mapping(options, "solve(): ")
    return solve_with(design_of(plane, ground, soil), settings, model, progress=progress, cache=cache)


def solve_soils(plane: GroundPlane | str, soils: Sequence[Soil | tuple[float, float]], *, progress: bool = False,
                cache: bool = True, **options: Any) -> list[Beam]:
    """The beams of one plane over several soils, in order: solved together, the model and each
    frequency's direct and image terms shared (five soils cost ~2.3 single solves, not 5;
    ``docs/speed.md``), each beam the one :func:`solve` gives and caches for that soil.

    Parameters
    ----------
    plane
        A shape or a preset's name.
    soils
        Each a :class:`~groundplane.design.Soil` or an ``(eps_r, sigma)`` pair (S/m).
    progress, cache, **options
        As :func:`solve` (any solver option but ``eps_r`` and ``sigma``, which ``soils`` gives).

    Examples
    --------
    >>> import groundplane as gp
    >>> dry, mro = gp.solve_soils("square-10", [(2.5, 0.005), (3.5, 0.02)], freqs="55:97:21", mesh=1.5,
    ...                           blade_cells=(4, 4))  # doctest: +SKIP
    >>> dry.freqs_mhz.tolist()  # doctest: +SKIP
    [55.0, 76.0, 97.0]
    """
    plane = as_plane(plane, "solve_soils()")
    given = sorted({"eps_r", "sigma"} & set(options))
    if given:
        raise UserInputError(f"solve_soils(): {' and '.join(given)} come from soils, not from a keyword")
    if isinstance(soils, (str, bytes)) or not isinstance(soils, Sequence) or not soils:
        raise UserInputError("solve_soils(): soils must be a non-empty list of Soil or (eps_r, sigma) pairs")
    grounds = []
    for i, soil in enumerate(soils):
        if isinstance(soil, Soil):
            grounds.append(soil)
            continue
        try:
            eps_r, sigma = soil
        except (TypeError, ValueError):
            raise UserInputError(f"solve_soils(): soils[{i}] = {soil!r} is neither a Soil nor an (eps_r, sigma) "
                                 "pair") from None
        grounds.append(build(Soil, {"eps_r": eps_r, "sigma": sigma}, f"solve_soils(): soils[{i}]: "))
    from .engines import make_solver

    _, settings, model = solve_options_from_mapping(options, "solve_soils(): ")
    solver = make_solver(settings.engine, model, workers=settings.workers, progress=progress, use_cache=cache)
    return solver.solve_many([design_of(plane, "soil", g) for g in grounds], settings.freqs_mhz)


def solve_with(design: Design, settings, model, progress: bool = False, cache: bool = True) -> Beam:
    """One design solved with settings already built (the command line's path and the API's)."""
    from .engines import make_solver

    solver = make_solver(settings.engine, model, workers=settings.workers, progress=progress, use_cache=cache)
    return solver.solve(design, settings.freqs_mhz)
