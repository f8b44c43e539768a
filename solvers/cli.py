"""``groundplane solve``: run the NEC-2 adapter on one candidate and write a beam file."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path


def register(sub) -> None:
    from groundplane.cli import add_shape_arguments

    s = sub.add_parser("solve", help="solve a candidate with NEC-2 and write the native beam file")
    add_shape_arguments(s, required=False)
    s.add_argument("--ground", choices=["soil", "pec"], default="soil",
                   help="lossy soil under the plate (default) or infinite PEC ground with no plate")
    s.add_argument("--eps-r", type=float, default=3.5, help="soil relative permittivity (default 3.5)")
    s.add_argument("--sigma", type=float, default=0.02, help="soil conductivity S/m (default 0.02)")
    s.add_argument("--freqs", default="40:100:1", help="MHz: LO:HI:STEP (inclusive) or a list (default 40:100:1)")
    s.add_argument("--mesh", type=float, default=0.5, metavar="SPACING", help="plate wire-grid spacing m (default 0.5)")
    s.add_argument("--wire-radius", type=float, default=0.01, help="plate wire radius m (default 0.01)")
    s.add_argument("--plate-height", type=float, default=0.05, help="plate height above soil m (default 0.05)")
    s.add_argument("--refine-centre", type=float, nargs=2, metavar=("HALF_WIDTH", "FACTOR"),
                   help="a grid FACTOR times finer inside |x|,|y| <= HALF_WIDTH m (where the near field is)")
    s.add_argument("--blade-cells", type=int, nargs=2, default=(12, 10), metavar=("NX", "NY"))
    s.add_argument("--no-gain-calibration", action="store_true",
                   help="use NEC's input power as is (see solvers/nec.py for why the default calibrates)")
    s.add_argument("--workers", type=int, default=2, help="parallel processes (default 2)")
    s.add_argument("--no-cache", action="store_true", help="neither read nor write the beam cache")
    s.add_argument("--deck", metavar="FILE.nec", help="also write the NEC-2 input deck")
    s.add_argument("-o", "--output", required=True, help="beam.npz")
    s.set_defaults(func=cmd_solve)


def cmd_solve(args: argparse.Namespace) -> int:
    from groundplane.cli import CLIError, shape_from_args
    from groundplane.design import Design, InfinitePEC, Soil

    from .nec import MeshSettings, NecSolver, build_model, parse_freqs

    plane = shape_from_args(args)
    if args.ground == "pec":
        if plane is not None:
            raise CLIError("--ground pec solves the blade over infinite perfect ground: give no shape")
        design = Design(None, InfinitePEC())
    else:
        if plane is None:
            raise CLIError("a solve over soil needs a ground plane: --preset NAME or a shape (or use --ground pec)")
        design = Design(plane, Soil(args.eps_r, args.sigma))
    mesh = MeshSettings(
        spacing=args.mesh, plate_wire_radius=args.wire_radius, plate_height=args.plate_height,
        blade_cells=tuple(args.blade_cells),
        gain_calibration="none" if args.no_gain_calibration else "pec",
        **_refine(args.refine_centre),
    )
    freqs = parse_freqs(args.freqs)
    if args.deck:
        model = build_model(design, mesh)
        Path(args.deck).write_text(model.to_deck(freqs, design.label()))
        print(f"wrote {args.deck} ({model.n_segments} segments)")
    solver = NecSolver(mesh=mesh, workers=args.workers, progress=sys.stderr.isatty(), use_cache=not args.no_cache)
    beam = solver.solve(design, freqs)
    out = beam.save(args.output)
    secs = sum(beam.meta.get("seconds_per_frequency", []))
    print(f"wrote {out}: {design.label()}, {beam.meta['n_segments']} segments, {freqs.size} frequencies "
          f"({secs:.0f} s of solver time; cache key {beam.meta['cache_key']})")
    return 0


def _refine(values) -> dict:
    """--refine-centre HALF_WIDTH FACTOR as MeshSettings fields (FACTOR must be whole)."""
    if not values:
        return {}
    half, factor = values
    if factor != int(factor):
        from groundplane.cli import CLIError

        raise CLIError(f"--refine-centre: FACTOR must be a whole number, got {factor:g}")
    return {"refine_half_width": float(half), "refine_factor": int(factor)}
