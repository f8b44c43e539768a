"""The core's commands: ``fom``, ``shapes``, ``export``, ``convert``."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from .. import shapes as sh
from ..fom import FomSettings
from ..options import add_options, from_args
from . import CLIError, add_shape_options, command, shape_from_args


def _format_choices() -> list[str]:
    from ..beam import reader_formats

    return reader_formats()


def _add_beam_paths(p: argparse.ArgumentParser, help: str, metavar: str | None = "BEAM") -> None:
    """The beam-file arguments every command that reads beams takes: the paths and --format."""
    p.add_argument("paths", nargs="+", metavar=metavar, help=help)
    p.add_argument("--format", default="auto", choices=_format_choices(), help="beam file format (default: detect)")


@command("fom", "score beam file(s): LST-averaged chromaticity FoM (mK)")
def _setup_fom(p: argparse.ArgumentParser):
    _add_beam_paths(p, "beam file(s); several FEKO quadrant .ffe files make one beam", None)
    add_options(p, FomSettings, "Figure of Merit (defaults: the paper's)")
    p.add_argument("--beam-correction", metavar="MODEL_BEAM",
                   help="divide spectra by the beam-correction factor of this model beam first")
    p.add_argument("--metrics", action="store_true", help="also the secondary chromaticity metrics")
    p.add_argument("--smooth-frequency", type=int, metavar="DEG",
                   help="diagnostic: score the beam after a degree-DEG Chebyshev fit of G(nu) per direction, "
                        "which removes narrow-band solver artefacts (and any real structure that narrow)")
    p.add_argument("--json", action="store_true", help="print a JSON object")
    p.add_argument("--plot", metavar="FILE.png", help="FoM vs LST and residual spectra")
    return _run_fom


def _run_fom(args: argparse.Namespace) -> int:
    from ..beam import Beam
    from ..fom import chromaticity_report, figure_of_merit

    if args.plot:
        from ..plots import check_figure_path

        check_figure_path(args.plot)  # before any work
    beam = Beam.from_file(args.paths, args.format)
    if args.smooth_frequency:
        beam = beam.frequency_smoothed(args.smooth_frequency)
    settings = from_args(FomSettings, args)
    correction = Beam.from_file(args.beam_correction) if args.beam_correction else None
    result = figure_of_merit(beam, settings, correction_beam=correction, progress=True)
    if args.plot:
        from ..plots import fom_figure

        fom_figure([result], [Path(str(args.paths[0])).name], args.plot)
    report = chromaticity_report(beam, settings) if args.metrics else None
    from ..loss import largest_in_band, loss_or_note

    loss, note = loss_or_note(beam)
    if args.json:
        out = result.as_json()
        out["beam"] = dict(beam.meta)
        out["ground_loss"] = None if loss is None else loss.tolist()
        out["max_ground_loss_fit_band"] = (None if loss is None else
                                           largest_in_band(beam.freqs_mhz, loss, settings.fit_band_mhz))
        if note:
            out["ground_loss_note"] = note
        if report is not None:
            out["chromaticity"] = report
        print(json.dumps(out))
        return 0
    src = beam.meta.get("source", args.paths[0])
    print(f"{result.lst_averaged_mk:.2f} mK  LST-averaged FoM of {src}")
    print(f"  FoM min {result.fom.min() * 1e3:.1f} mK at LST {result.lst_hours[result.fom.argmin()]:.1f} h, "
          f"max {result.fom.max() * 1e3:.1f} mK at LST {result.lst_hours[result.fom.argmax()]:.1f} h; "
          f"fit {settings.fit_band_mhz[0]:g}-{settings.fit_band_mhz[1]:g} MHz, {settings.n_terms}-term LinLog"
          + (f", spectra averaged in {settings.lst_bin_hours:g} h LST bins" if settings.lst_bin_hours else ""))
    if beam.meta.get("mesh_note"):
        print(f"  note: {beam.meta['mesh_note']}")
    if args.metrics:
        print("  " + loss_line(beam, loss, note, settings.fit_band_mhz))
        from ..s11 import db, input_impedance, reflection

        z = input_impedance(beam)
        if z is not None:
            s = db(reflection(z))
            print(f"  S11 (50 ohm): {s.min():.2f} to {s.max():.2f} dB over {beam.freqs_mhz.min():g}-"
                  f"{beam.freqs_mhz.max():g} MHz (groundplane s11 for the table and the Touchstone file)")
    for k, v in (report or {}).get("gain_poly3_residuals", {}).items():
        if isinstance(v, dict):
            print(f"  3-term poly residual p-p of G at {k}: {v['peak_to_peak']:.4f}")
    if args.plot:
        print(f"  plot: {args.plot}")
    return 0


def loss_line(beam, loss, note: str | None, band: tuple[float, float]) -> str:
    """One line: the ground loss at the band's ends and middle and its largest in ``band``, or why there is none."""
    from ..loss import largest_in_band

    if loss is None:
        return f"ground loss: none ({note})"
    f = beam.freqs_mhz
    picks = sorted({0, len(f) // 2, len(f) - 1})
    at = ", ".join(f"{100 * loss[i]:.3f} % at {f[i]:g} MHz" for i in picks)
    return f"ground loss: {at}; largest in {band[0]:g}-{band[1]:g} MHz {100 * largest_in_band(f, loss, band):.3f} %"


@command("loss", "ground loss per frequency of beam file(s): 1 - the upper hemisphere's integral of G / 4 pi; "
         "-o writes the two-column table (MHz, fraction) the EDGES pipeline reads")
def _setup_loss(p: argparse.ArgumentParser):
    _add_beam_paths(p, "beam file(s), each one beam")
    p.add_argument("-o", "--output", metavar="FILE.txt", help="write the loss table of the (one) beam here: '#' "
                   "header lines, then frequency (MHz) and loss (fraction) per line")
    p.add_argument("--json", action="store_true", help="print a JSON object")
    return _run_loss


def _run_loss(args: argparse.Namespace) -> int:
    from ..files import check_output
    from ..loss import loss_or_note, write_loss_table
    from . import invocation

    if args.output and len(args.paths) != 1:
        raise CLIError(f"-o writes one beam's table; got {len(args.paths)} beams")
    note_out = check_output(args.output) if args.output else ""
    beams = _beams_of(args.paths, args.format)
    found = [loss_or_note(b) for b in beams]
    labels = _unique_labels(args.paths)
    if all(loss is None for loss, _ in found):  # nothing to print but why
        raise CLIError("; ".join(note for _, note in found))
    if args.output:
        write_loss_table(args.output, beams[0], invocation())
    if args.json:
        print(json.dumps([{"beam": lab, "freqs_mhz": b.freqs_mhz.tolist(), "gain_normalisation": b.gain_normalisation,
                           "ground_loss": None if loss is None else loss.tolist(), "note": note}
                          for lab, b, (loss, note) in zip(labels, beams, found)]))
    else:
        for lab, (loss, note) in zip(labels, found):
            if note:
                print(f"groundplane loss: {lab}: no ground loss: {note}", file=sys.stderr)
        shown = [(lab, b, loss) for lab, b, (loss, _) in zip(labels, beams, found) if loss is not None]
        if shown:
            print("| MHz | " + " | ".join(f"{lab} loss (%)" for lab, _, _ in shown) + " |")
            print("|---|" + "---|" * len(shown))
            freqs = sorted({round(float(f), 6) for _, b, _ in shown for f in b.freqs_mhz})
            for f in freqs:
                cells = []
                for _, b, loss in shown:
                    i = np.flatnonzero(np.isclose(b.freqs_mhz, f, atol=1e-6))
                    cells.append(f"{100 * loss[i[0]]:.4f}" if i.size else "-")
                print(f"| {f:g} | " + " | ".join(cells) + " |")
    if args.output:
        print(f"wrote {args.output}{note_out}", file=sys.stderr)
    return 0


@command("s11", "the antenna's input impedance and reflection coefficient per frequency from solved beam(s); "
         "-o writes a Touchstone one-port file (.s1p)")
def _setup_s11(p: argparse.ArgumentParser):
    _add_beam_paths(p, "beam file(s) carrying the input impedance (our engines' beams, the EDGES FEKO table)")
    p.add_argument("--z0", type=float, default=50.0, help="reference impedance (ohm, default 50)")
    p.add_argument("-o", "--output", metavar="FILE.s1p", help="write the (one) beam's S11 as Touchstone v1")
    p.add_argument("--plot", metavar="FILE.png", help="|S11| (dB) and the impedance against frequency")
    p.add_argument("--json", action="store_true", help="print a JSON object")
    return _run_s11


def _run_s11(args: argparse.Namespace) -> int:
    from ..files import check_output
    from ..s11 import db, input_impedance, reflection, write_touchstone
    from . import invocation

    if args.output and len(args.paths) != 1:
        raise CLIError(f"-o writes one beam's S11; got {len(args.paths)} beams")
    note = check_output(args.output) if args.output else ""
    if args.plot:
        from ..plots import check_figure_path

        check_figure_path(args.plot)
    reflection(np.array([1.0]), args.z0)  # a bad --z0 refused before any reading
    beams = _beams_of(args.paths, args.format)
    labels = _unique_labels(args.paths)
    found = [(lab, b, input_impedance(b)) for lab, b in zip(labels, beams)]
    missing = [lab for lab, _, z in found if z is None]
    if missing:
        raise CLIError(f"{', '.join(missing)}: no input impedance in the beam (solve it with this version's engines, "
                       "or export one that records it)")
    rows = [(lab, b, z, reflection(z, args.z0)) for lab, b, z in found]
    if args.output:
        lab, b, z, s = rows[0]
        write_touchstone(args.output, b.freqs_mhz, s, args.z0,
                         [f"S11 of {b.meta.get('source', lab)}", f"written by: {invocation()}"])
    if args.plot:
        from ..plots import s11_figure

        s11_figure([(lab, b.freqs_mhz, z, s) for lab, b, z, s in rows], args.z0, args.plot)
    if args.json:
        print(json.dumps([{"beam": lab, "freqs_mhz": b.freqs_mhz.tolist(), "z0_ohm": args.z0,
                           "impedance_re": z.real.tolist(), "impedance_im": z.imag.tolist(),
                           "s11_re": s.real.tolist(), "s11_im": s.imag.tolist(), "s11_db": db(s).tolist()}
                          for lab, b, z, s in rows]))
    else:
        for lab, b, z, s in rows:
            print(f"{lab}: Z0 = {args.z0:g} ohm")
            print("| MHz | R (ohm) | X (ohm) | S11 (dB) | S11 phase (deg) |")
            print("|---|---|---|---|---|")
            for f, zi, si in zip(b.freqs_mhz, z, s):
                print(f"| {f:g} | {zi.real:.3f} | {zi.imag:.3f} | {db(np.array([si]))[0]:.3f} | "
                      f"{np.degrees(np.angle(si)):.2f} |")
    if args.output:
        print(f"wrote {args.output}{note}", file=sys.stderr)
    return 0


@command("shapes", "list the design-study presets and the shape families")
def _setup_shapes(p: argparse.ArgumentParser):
    p.add_argument("--json", action="store_true")
    return _run_shapes


def _run_shapes(args: argparse.Namespace) -> int:
    rows = [{"name": n, **s.summary()} for n, s in sh.PRESETS.items()]
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    print(f"{'name':16s} {'shape':9s} {'metal area (m^2)':>16s} {'extent (m)':>10s} {'edges':>5s}  parameters")
    for r in rows:
        params = ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in r["params"].items())
        print(f"{r['name']:16s} {r['shape']:9s} {r['metal_area_m2']:16.2f} {r['extent_m']:10.2f} "
              f"{r['edge_count']:5d}  {params}")
    print("\nfamilies: " + "; ".join(f"{k} ({', '.join(p.name for p in c.parameters())})" for k, c in sh.SHAPES.items()))
    return 0


@command("export", "write a ground plane as STEP, STL, SVG or PNG")
def _setup_export(p: argparse.ArgumentParser):
    add_shape_options(p)
    p.add_argument("-o", "--output", required=True, help="FILE.step | FILE.stl | FILE.svg | FILE.png")
    p.add_argument("--thickness", type=float, default=0.002, help="plate thickness in m (default 0.002)")
    p.add_argument("--with-antenna", action="store_true", help="STEP assembly with the blade panels")
    return _run_export


def _run_export(args: argparse.Namespace) -> int:
    from .. import cad
    from ..files import check_output

    shape = shape_from_args(args)
    assert shape is not None
    note = check_output(args.output)
    out = cad.export(shape, args.output, thickness=args.thickness, with_antenna=args.with_antenna)
    print(f"wrote {out}{note} ({shape.describe()}, metal area {shape.metal_area:.2f} m^2, extent {shape.extent:.2f} m)")
    return 0


@command("convert", "read any supported beam export, write the native .npz or a UVBeam (.fits)")
def _setup_convert(p: argparse.ArgumentParser):
    p.add_argument("paths", nargs="+")
    p.add_argument("--format", default="auto", choices=_format_choices())
    p.add_argument("-o", "--output", required=True,
                   help="beam.npz (native) or beam.fits / beam.beamfits (pyuvdata UVBeam, for pyuvsim, hera_sim, ...)")
    return _run_convert


def _run_convert(args: argparse.Namespace) -> int:
    from ..beam import Beam
    from ..files import check_output

    note = check_output(args.output)
    beam = Beam.from_file(args.paths, args.format)
    out = beam.write(args.output)  # .fits / .beamfits: a UVBeam, through the solver layer's writer
    print(f"wrote {out}{note}: {beam.freqs_mhz.size} frequencies {beam.freqs_mhz.min():g}-{beam.freqs_mhz.max():g} MHz, "
          f"{beam.theta_deg.size} x {beam.phi_deg.size} directions")
    return 0


def _beams_of(paths: list[str], format: str) -> list:
    """Each path one beam (a FEKO quadrant set is converted to one .npz first)."""
    from ..beam import Beam

    return [Beam.from_file(p, format) for p in paths]


@command("plot", "draw the paper's beam figures: gain cuts, dG/dnu maps, 3-term residuals, widths")
def _setup_plot(p: argparse.ArgumentParser):
    p.add_argument("paths", nargs="+", metavar="BEAM", help="beam file(s), drawn on shared axes")
    p.add_argument("-o", "--output", required=True, metavar="FILE.png", help="figure file (.png, .svg or .pdf)")
    p.add_argument("--format", default="auto", choices=_format_choices(), help="beam file format (default: detect)")
    p.add_argument("--panels", action="store_true",
                   help="one file per panel: FILE-cuts, FILE-derivative, FILE-poly3, FILE-widths")
    p.add_argument("--freqs", type=float, nargs="+", metavar="MHZ",
                   help="frequencies of the gain cuts (default: the first beam's lowest, middle and highest)")
    return _run_plot


def _run_plot(args: argparse.Namespace) -> int:
    from ..plots import beam_figures, check_figure_path

    check_figure_path(args.output)  # before any work
    beams = _beams_of(args.paths, args.format)
    for f in args.freqs or []:
        if not any(abs(b.freqs_mhz - f).min() < 1e-6 for b in beams):
            raise CLIError(f"--freqs {f:g}: none of the beams holds {f:g} MHz")
    labels = [Path(x).name for x in args.paths]
    for out in beam_figures(beams, labels, args.output, panels=args.panels, freqs=args.freqs):
        print(f"wrote {out}")
    return 0


@command("compare", "two or more beams on common frequencies: dB differences over the sky, zenith ratio, "
         "widths, efficiency, and their FoMs scored alike")
def _setup_compare(p: argparse.ArgumentParser):
    _add_beam_paths(p, "beam files; each is compared with the first")
    p.add_argument("--elevation-cut", type=float, default=10.0, metavar="DEG",
                   help="compare gains over the sky at least this far above the horizon (default 10 deg)")
    p.add_argument("--json", action="store_true", help="print a JSON object instead of the tables")
    p.add_argument("--plot", metavar="FILE.png", help="difference maps, rms vs frequency, FoM vs LST of each")
    add_options(p, FomSettings, "Figure of Merit (defaults: the paper's; each beam is scored every LST and in "
                "these LST bins, 2 h when --lst-bin is 0)")
    return _run_compare


def _run_compare(args: argparse.Namespace) -> int:
    from ..comparison import compare_beams

    if len(args.paths) < 2:
        raise CLIError("compare needs at least two beam files")
    if args.plot:
        from ..plots import check_figure_path

        check_figure_path(args.plot)
    beams = _beams_of(args.paths, args.format)
    labels = _unique_labels(args.paths)
    result = compare_beams(beams, labels, args.paths, from_args(FomSettings, args), args.elevation_cut, progress=True)
    if args.plot:
        from ..plots import comparison_figure

        comparison_figure(result, args.plot)
    if args.json:
        print(json.dumps(result.as_json()))
        return 0
    print(result.markdown())
    if args.plot:
        print(f"\nplot: {args.plot}")
    return 0


def _unique_labels(paths: list[str]) -> list[str]:
    """File names, or the paths where two files share a name."""
    names = [Path(x).name for x in paths]
    return names if len(set(names)) == len(names) else [str(x) for x in paths]
