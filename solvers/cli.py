"""``groundplane solve``, and the solver options every command that solves shares."""
from __future__ import annotations

import argparse
from typing import TYPE_CHECKING, Any

from groundplane.cli import CLIError, add_shape_options, command, shape_from_args
from groundplane.design import Soil
from groundplane.files import atomic_path, check_output
from groundplane.options import add_options, from_args

if TYPE_CHECKING:
    from .engines.base import SolveSettings


def solve_option_groups() -> list[tuple[str, type]]:
    """(title, settings dataclass) for every option of a command that solves: soil, the solve,
    the plate model every engine shares, then each engine's own model settings."""
    from .engines import ENGINES  # here, not at import: `groundplane fom` never loads an engine
    from .engines.base import SolveSettings
    from .engines.plate import PlateModel

    return [("soil (MRO by default)", Soil), ("solver", SolveSettings), ("plate model (every engine)", PlateModel),
            # by name: the registry's order is whichever engine was imported first (a test module importing
            # the surface engine directly reordered the generated options table)
            *((f"{name} model (--engine {name})", cls.settings_class) for name, cls in sorted(ENGINES.items()))]


def add_solve_options(p: argparse.ArgumentParser) -> None:
    """Soil, engine, frequencies and every engine's model options (generated from their
    settings dataclasses, so each command that solves takes the same flags)."""
    for title, cls in solve_option_groups():
        add_options(p, cls, title)


def solve_options(args: argparse.Namespace) -> tuple[Soil, SolveSettings, Any]:
    """(soil, solve settings, engine settings) from the parsed command line."""
    from .engines import ENGINES
    from .engines.base import SolveSettings

    solve = from_args(SolveSettings, args)
    if solve.engine not in ENGINES:
        raise CLIError(f"--engine {solve.engine}: choose one of {', '.join(ENGINES)}")
    return from_args(Soil, args), solve, from_args(ENGINES[solve.engine].settings_class, args)


@command("solve", "solve a candidate with an EM engine (the surface engine by default) and write the native beam file")
def _setup_solve(p: argparse.ArgumentParser):
    add_shape_options(p, required=False)
    p.add_argument("--ground", choices=["soil", "pec", "free"], default="soil",
                   help="lossy soil under the plate (default); infinite PEC ground: the blade alone, or above a "
                        "plate at --plate-height when a shape is given; free: no ground at all (the engines' "
                        "common cases)")
    add_solve_options(p)
    p.add_argument("--no-cache", action="store_true", help="neither read nor write the beam cache")
    p.add_argument("--deck", metavar="FILE", help="also write the engine's own input deck (NEC-2: a .nec card deck)")
    p.add_argument("-o", "--output", required=True, help="beam.npz")
    return _run_solve


def _run_solve(args: argparse.Namespace) -> int:
    from .api import design_of, solve_with
    from .engines import make_solver

    plane = shape_from_args(args)
    soil, solve, model_settings = solve_options(args)
    if args.ground == "soil" and plane is None:
        raise CLIError("a solve over soil needs a ground plane: --preset NAME or a shape (or use --ground pec)")
    design = design_of(plane, args.ground, soil)
    solver = make_solver(solve.engine, model_settings, workers=solve.workers, progress=True,
                         use_cache=not args.no_cache)
    if args.deck:
        deck = solver.input_deck(design, solve.freqs_mhz)
        note = check_output(args.deck)
        with atomic_path(args.deck, suffix=".deck.tmp") as tmp:
            tmp.write_text(deck)
        print(f"wrote {args.deck}{note} (the {solve.engine} engine's input deck)")
    note = check_output(args.output)  # before the solve, not after it
    beam = solve_with(design, solve, model_settings, progress=True, cache=not args.no_cache)  # the API's path
    out = beam.save(args.output)
    secs = sum(beam.meta.get("seconds_per_frequency", []))
    size = solver.model_size(beam.meta)
    print(f"wrote {out}{note}: {design.label()}, {size}, {len(solve.freqs_mhz)} "
          f"frequencies ({secs:.0f} s of solver time; cache key {beam.meta['cache_key']})")
    return 0
