"""The ``groundplane`` command: one entry point, one subcommand per job.

Heavy modules (cadquery, PyNEC, nlopt) are imported inside the subcommands that need
them, so ``groundplane fom`` starts fast.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any, Sequence

from . import shapes as sh


class CLIError(Exception):
    """A user error: printed as one line, exit status 2."""


# ----------------------------------------------------------------- shape options
def add_shape_arguments(p: argparse.ArgumentParser, required: bool = True) -> None:
    """``--preset NAME`` or ``SHAPE --param ...`` (shared by export, solve, optimise)."""
    p.add_argument("shape", nargs="?", choices=sorted(sh.SHAPES), help="shape family (or use --preset)")
    p.add_argument("--preset", choices=sorted(sh.PRESETS), help="a design-study preset")
    g = p.add_argument_group("shape parameters (metres)")
    g.add_argument("--side", type=float)
    g.add_argument("--arm", type=float)
    g.add_argument("--teeth-per-side", type=int)
    g.add_argument("--tooth-base", type=float)
    g.add_argument("--tooth-height", type=float)
    g.add_argument("--n-sides", type=int)
    g.add_argument("--radius", type=float)
    g.add_argument("--rotation-deg", type=float)
    g.add_argument("--n-points", type=int)
    g.add_argument("--outer-radius", type=float)
    g.add_argument("--inner-radius", type=float)
    g.add_argument("--vertices", help="polygon vertices 'x,y;x,y;...' in metres")
    p.set_defaults(_shape_required=required)


_PARAM_OPTS = {
    "square": ["side"],
    "plus": ["arm"],
    "sawtooth": ["side", "teeth_per_side", "tooth_base", "tooth_height"],
    "polygon-n": ["n_sides", "radius", "rotation_deg"],
    "star": ["n_points", "outer_radius", "inner_radius"],
    "polygon": ["vertices"],
}


def shape_from_args(args: argparse.Namespace) -> sh.GroundPlane | None:
    if args.preset and args.shape:
        raise CLIError("give either --preset or a shape with its parameters, not both")
    if args.preset:
        return sh.preset(args.preset)
    if not args.shape:
        if args._shape_required:
            raise CLIError("no ground plane: give --preset NAME or a shape (e.g. 'square --side 10')")
        return None
    params: dict[str, Any] = {"shape": args.shape}
    for name in _PARAM_OPTS[args.shape]:
        v = getattr(args, name)
        if v is None:
            if name == "rotation_deg":
                continue
            raise CLIError(f"{args.shape} needs --{name.replace('_', '-')}")
        if name == "vertices":
            try:
                v = [tuple(float(c) for c in pt.split(",")) for pt in v.split(";") if pt.strip()]
            except ValueError:
                raise CLIError(f"--vertices: expected 'x,y;x,y;...', got '{v}'") from None
        params[name] = v
    used = {n for names in _PARAM_OPTS.values() for n in names}
    extra = [n for n in used if n not in _PARAM_OPTS[args.shape] and getattr(args, n) is not None]
    if extra:
        raise CLIError(f"{args.shape} does not take {', '.join('--' + e.replace('_', '-') for e in extra)}")
    return sh.from_dict(params)


# ---------------------------------------------------------------------- commands
def cmd_shapes(args: argparse.Namespace) -> int:
    rows = [{"name": n, **s.summary()} for n, s in sh.PRESETS.items()]
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    print(f"{'name':16s} {'shape':9s} {'metal area (m^2)':>16s} {'extent (m)':>10s} {'edges':>5s}  parameters")
    for r in rows:
        params = ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in r["params"].items())
        print(f"{r['name']:16s} {r['shape']:9s} {r['metal_area_m2']:16.2f} {r['extent_m']:10.2f} "
              f"{r['edge_count']:5d}  {params}")
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    from . import cad

    shape = shape_from_args(args)
    assert shape is not None
    out = cad.export(shape, args.output, thickness=args.thickness, with_antenna=args.with_antenna)
    print(f"wrote {out} ({shape.describe()}, metal area {shape.metal_area:.2f} m^2, extent {shape.extent:.2f} m)")
    return 0


def _fom_settings(args: argparse.Namespace):
    from .fom import Absorption, FomSettings

    return FomSettings(
        beta=args.beta,
        fit_band_mhz=tuple(args.fit_band),
        nu0_mhz=args.nu0,
        n_terms=args.terms,
        antenna_azimuth_deg=args.antenna_azimuth,
        n_lst=args.n_lst,
        normalise=args.normalise,
        subtract_cmb=args.subtract_cmb,
        absorption=Absorption() if args.absorption else None,
    )


def add_fom_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("Figure of Merit (defaults: the paper's)")
    g.add_argument("--antenna-azimuth", type=float, default=-7.0, metavar="DEG",
                   help="excitation axis azimuth from North through East (default -7)")
    g.add_argument("--beta", type=float, default=2.55, help="sky spectral index (default 2.55)")
    g.add_argument("--fit-band", type=float, nargs=2, default=(55.0, 97.0), metavar=("LO", "HI"),
                   help="LinLog fit band in MHz (default 55 97)")
    g.add_argument("--nu0", type=float, default=75.0, help="LinLog reference frequency, MHz (default 75)")
    g.add_argument("--terms", type=int, default=5, help="LinLog terms (default 5)")
    g.add_argument("--n-lst", type=int, default=360, help="LST bins over 24 h (default 360)")
    g.add_argument("--normalise", action="store_true", help="divide by the beam integral (EDGES pipeline)")
    g.add_argument("--subtract-cmb", action="store_true", help="remove 2.725 K before scaling the map")
    g.add_argument("--absorption", action="store_true", help="add the Bowman et al. 2018 absorption feature")


def cmd_fom(args: argparse.Namespace) -> int:
    from solvers import load_beam

    from .fom import chromaticity_report, figure_of_merit

    beam = load_beam(args.paths, args.format)
    if args.smooth_frequency:
        beam = beam.frequency_smoothed(args.smooth_frequency)
    settings = _fom_settings(args)
    correction = load_beam(args.beam_correction, "auto") if args.beam_correction else None
    result = figure_of_merit(beam, settings, correction_beam=correction, progress=sys.stderr.isatty())
    if args.plot:
        from .plots import fom_figure

        fom_figure([result], [Path(str(args.paths[0])).name], args.plot)
    if args.json:
        out = result.as_json()
        out["beam"] = {k: v for k, v in beam.meta.items()}
        if args.metrics:
            out["chromaticity"] = chromaticity_report(beam, settings)
        print(json.dumps(out))
    else:
        src = beam.meta.get("source", args.paths[0])
        print(f"{result.lst_averaged_fom_mk:.2f} mK  LST-averaged FoM of {src}")
        print(f"  FoM min {result.fom.min() * 1e3:.1f} mK at LST {result.lst_hours[result.fom.argmin()]:.1f} h, "
              f"max {result.fom.max() * 1e3:.1f} mK at LST {result.lst_hours[result.fom.argmax()]:.1f} h; "
              f"fit {settings.fit_band_mhz[0]:g}-{settings.fit_band_mhz[1]:g} MHz, {settings.n_terms}-term LinLog")
        if args.metrics:
            rep = chromaticity_report(beam, settings)
            for k, v in rep.get("gain_poly3_residuals", {}).items():
                if isinstance(v, dict):
                    print(f"  3-term poly residual p-p of G at {k}: {v['peak_to_peak']:.4f}")
        if args.plot:
            print(f"  plot: {args.plot}")
    return 0


def cmd_convert(args: argparse.Namespace) -> int:
    from solvers import load_beam

    beam = load_beam(args.paths, args.format)
    out = beam.save(args.output)
    print(f"wrote {out}: {beam.freqs_mhz.size} frequencies {beam.freqs_mhz.min():g}-{beam.freqs_mhz.max():g} MHz, "
          f"{beam.theta_deg.size} x {beam.phi_deg.size} directions")
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="groundplane", description=__doc__.splitlines()[0] if __doc__ else None)
    sub = p.add_subparsers(dest="command", required=True)

    f = sub.add_parser("fom", help="score beam file(s): LST-averaged chromaticity FoM (mK)")
    f.add_argument("paths", nargs="+", help="beam file(s); several FEKO quadrant .ffe files make one beam")
    f.add_argument("--format", default="auto", choices=["auto", "feko-ffe", "edges-table", "cst", "hfss", "npz"])
    add_fom_arguments(f)
    f.add_argument("--beam-correction", metavar="MODEL_BEAM",
                   help="divide spectra by the beam-correction factor of this model beam first")
    f.add_argument("--metrics", action="store_true", help="also the secondary chromaticity metrics")
    f.add_argument("--smooth-frequency", type=int, metavar="DEG",
                   help="diagnostic: score the beam after a degree-DEG Chebyshev fit of G(nu) per direction, "
                        "which removes narrow-band solver artefacts (and any real structure that narrow)")
    f.add_argument("--json", action="store_true", help="print a JSON object")
    f.add_argument("--plot", metavar="FILE.png", help="FoM vs LST and residual spectra")
    f.set_defaults(func=cmd_fom)

    s = sub.add_parser("shapes", help="list the design-study presets")
    s.add_argument("--json", action="store_true")
    s.set_defaults(func=cmd_shapes)

    e = sub.add_parser("export", help="write a ground plane as STEP, STL, SVG or PNG")
    add_shape_arguments(e)
    e.add_argument("-o", "--output", required=True, help="FILE.step | FILE.stl | FILE.svg | FILE.png")
    e.add_argument("--thickness", type=float, default=0.002, help="plate thickness in m (default 0.002)")
    e.add_argument("--with-antenna", action="store_true", help="STEP assembly with the blade panels")
    e.set_defaults(func=cmd_export)

    c = sub.add_parser("convert", help="read any supported beam export, write the native .npz")
    c.add_argument("paths", nargs="+")
    c.add_argument("--format", default="auto", choices=["auto", "feko-ffe", "edges-table", "cst", "hfss", "npz"])
    c.add_argument("-o", "--output", required=True)
    c.set_defaults(func=cmd_convert)

    _register_optional(sub)
    return p


def _register_optional(sub: Any) -> None:
    """Subcommands whose code lives in the solvers/optimise packages."""
    try:
        from solvers.cli import register as register_solve
    except ImportError:  # pragma: no cover - the distribution always ships solvers
        register_solve = None
    if register_solve:
        register_solve(sub)
    try:
        from optimise.cli import register as register_optimise
    except ImportError:
        register_optimise = None
    if register_optimise:
        register_optimise(sub)


def main(argv: Sequence[str] | None = None) -> int:
    from .beam import BeamFormatError

    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except (CLIError, sh.ShapeError, BeamFormatError, FileNotFoundError, ValueError, RuntimeError) as exc:
        print(f"groundplane {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"groundplane {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
