"""The optimisation layer's public functions, reached as ``groundplane.score``,
``groundplane.optimise`` and ``groundplane.sweep`` (through the ``groundplane.api`` entry
points: the core never imports this package)."""
from __future__ import annotations

from pathlib import Path
from typing import Any

from groundplane.fom import FomSettings
from groundplane.options import expect, option_keys
from groundplane.shapes import GroundPlane, as_plane

from .evaluate import Candidate, EvalSettings
from .sweep import settings_from_tables

__all__ = ["score", "optimise", "sweep", "eval_settings"]


def eval_settings(**options: Any) -> EvalSettings:
    """How designs are solved and scored, from options by their sweep-file keys (solver, plate
    model and FoM options alike: ``mesh=0.7, freqs="55:97:3", n_lst=24``), type-checked as the
    command line's."""
    fom_keys = option_keys(FomSettings)
    return settings_from_tables({k: v for k, v in options.items() if k not in fom_keys},
                                {k: v for k, v in options.items() if k in fom_keys}, "")


PATH = (str, Path)
NUMBER = (int, float)


def _common(where: str, scenarios: Any, aggregate: Any, max_loss: Any, max_loss_spread: Any, progress: Any) -> None:
    """The arguments score and optimise share, type-checked (:class:`ArgumentError`)."""
    expect(scenarios, PATH, "scenarios", where, "a scenario set's name or a TOML file's path")
    expect(aggregate, (str, type(None)), "aggregate", where, "'mean', 'worst', 'worst-K' or None")
    expect(max_loss, (*NUMBER, type(None)), "max_loss", where, "a fraction or None")
    expect(max_loss_spread, (*NUMBER, type(None)), "max_loss_spread", where, "a fraction or None")
    expect(progress, bool, "progress", where, "True or False")


def score(plane: GroundPlane | str, *, scenarios: str = "soil", aggregate: str | None = None,
          max_loss: float | None = 0.005, max_loss_spread: float | None = None, progress: bool = False,
          **options: Any) -> dict[str, Any]:
    """A design solved on every member of a scenario set and scored: its aggregate FoM, each
    member's FoM and ground loss, and the constraints (the ``groundplane score`` command).

    Parameters
    ----------
    plane
        A shape or a preset's name.
    scenarios : str
        'nominal', 'soil' (default), 'model', 'as-built', 'field', or a TOML file of members.
    aggregate : str, optional
        'mean', 'worst' or 'worst-K' (default: the set's own).
    max_loss, max_loss_spread : float or None
        The loss constraints (fractions); None for no limit.
    **options
        Solver, model and FoM options by their sweep-file keys.

    Returns
    -------
    dict
        The row: ``lst_averaged_fom_mk`` (the aggregate), ``worst_fom_mk``, ``mean_fom_mk``,
        ``max_loss``, ``feasible``, ``violations`` and ``members`` (each member's FoM and loss).

    Examples
    --------
    >>> import groundplane as gp
    >>> row = gp.score("square-10", scenarios="nominal", max_loss=None, mesh=1.5)  # doctest: +SKIP
    >>> round(row["lst_averaged_fom_mk"])  # doctest: +SKIP
    234
    """
    from .scenarios import Constraints, check_set, evaluate_scenarios, scenario_set

    p = as_plane(plane, "score()")
    _common("score()", scenarios, aggregate, max_loss, max_loss_spread, progress)
    settings = eval_settings(**options)
    settings.check_scorable()
    members = scenario_set(str(scenarios), aggregate)  # a set's name, or a file's path as a Path too
    check_set(members, settings, p)
    name = plane if isinstance(plane, str) else p.kind
    row = evaluate_scenarios(Candidate(name, plane=p), settings, members, Constraints(max_loss, max_loss_spread),
                             progress)
    if row["status"] != "ok":
        from groundplane.errors import SolveError

        raise SolveError(row.get("error", "the design could not be scored"))
    return row


def optimise(shape: str, max_area: float, out_dir: str | Path, *, budget: int = 30, max_budget: int | None = None,
             scenarios: str = "soil", aggregate: str | None = None, max_loss: float | None = 0.005,
             max_loss_spread: float | None = None, strategy: str = "global", progress: bool = False,
             **options: Any):
    """Search a shape family under a metal budget (m^2) for the lowest FoM on a scenario set
    under the loss constraints (the ``groundplane optimise --max-area`` command): every
    evaluation in ``out_dir/history.jsonl``, resumable.

    Returns
    -------
    OptimiseResult
        ``best`` (the answer's row, None if nothing feasible), ``history``, ``closest`` (with no
        feasible design) and ``stopping`` (where the best was found, flat over the last half).

    Examples
    --------
    >>> import groundplane as gp
    >>> res = gp.optimise("square", 200.0, "out/opt", budget=4, scenarios="nominal", max_loss=None,
    ...                   mesh=1.5, freqs="55:97:4")  # doctest: +SKIP
    >>> res.best["params"]  # doctest: +SKIP
    {'side': 14.1}
    """
    from .scenarios import Constraints, check_set, scenario_set
    from .search import optimise as search

    expect(shape, str, "shape", "optimise()", "a shape family's name")
    expect(max_area, NUMBER, "max_area", "optimise()", "a metal budget in m^2")
    expect(out_dir, PATH, "out_dir", "optimise()", "a folder's path")
    expect(budget, int, "budget", "optimise()", "a whole number of solves")
    expect(max_budget, (int, type(None)), "max_budget", "optimise()", "a whole number of solves or None")
    expect(strategy, str, "strategy", "optimise()", "'global' or 'local'")
    _common("optimise()", scenarios, aggregate, max_loss, max_loss_spread, progress)
    settings = eval_settings(**options)
    members = scenario_set(str(scenarios), aggregate)  # a set's name, or a file's path as a Path too
    check_set(members, settings)
    return search(shape, max_area, settings, out_dir, budget=budget, max_budget=max_budget, scenarios=members,
                  constraints=Constraints(max_loss, max_loss_spread), strategy=strategy, progress=progress)


def sweep(config: str | Path, out_dir: str | Path, *, progress: bool = False) -> list[dict[str, Any]]:
    """Solve, score and rank the candidates of a sweep file (the ``groundplane sweep`` command):
    the result rows, each also appended to ``out_dir/results.jsonl`` (resumable).

    Examples
    --------
    >>> import groundplane as gp
    >>> rows = gp.sweep("examples/sweep.toml", "out/sweep")  # doctest: +SKIP
    """
    from .sweep import load_config, load_scenarios, run_sweep

    expect(config, PATH, "config", "sweep()", "a sweep file's path")
    expect(out_dir, PATH, "out_dir", "sweep()", "a folder's path")
    expect(progress, bool, "progress", "sweep()", "True or False")
    candidates, invalid, settings = load_config(config)
    opts = load_scenarios(config)
    if opts is None:
        return run_sweep(candidates, settings, out_dir, invalid=invalid, progress=progress)
    return run_sweep(candidates, settings, out_dir, invalid=invalid, progress=progress, scenarios=opts.set(),
                     constraints=opts.constraints())
