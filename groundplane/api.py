"""The core's public functions, re-exported at the package top (``groundplane.fom``,
``groundplane.compare``, ``groundplane.fabrication_plan``), and the finder of the functions the
higher layers add there (``groundplane.solve``, ``score``, ``optimise``, ``sweep``): those are
registered as ``groundplane.api`` entry points, so the core never imports them."""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Callable

from .beam import Beam
from .errors import ArgumentError, UserInputError
from .fom import FomResult, FomSettings, figure_of_merit
from .options import build, expect
from .shapes import GroundPlane, as_plane

API_GROUP = "groundplane.api"
__all__ = ["fom", "compare", "export", "fabrication_plan", "fom_settings", "higher_layer"]


def fom_settings(**settings: Any) -> FomSettings:
    """FoM settings from options by their sweep-file keys (``fit_band=(55, 97)``, ``n_lst=24``,
    ``lst_bin=0``, ``sky="gsm2008"``, ``site="KAROO"``, ...), type-checked as the command line's;
    none given: the paper's."""
    return build(FomSettings, settings, "fom settings: ")


def fom(beam: Beam | str | os.PathLike, *, correction_beam: Beam | None = None, **settings: Any) -> FomResult:
    """The chromaticity Figure of Merit of a beam (a Beam or any beam file): the LST-averaged FoM
    (``.lst_averaged_mk``), the FoM per LST (``.fom``, K), the LinLog residuals and the spectra,
    and the beam's ground loss per frequency (``.ground_loss``, None when its gain is not
    normalised to input power).

    Parameters
    ----------
    beam
        A :class:`~groundplane.beam.Beam`, or a path to any supported beam file.
    correction_beam : Beam, optional
        Divide the spectra by this model beam's beam-correction factor first.
    **settings
        FoM options by their sweep-file keys (see :func:`fom_settings`).

    Examples
    --------
    >>> import groundplane as gp
    >>> result = gp.fom("examples/lowband_square10_nec.npz", n_lst=24)
    >>> round(result.lst_averaged_mk, 1)
    221.7
    """
    from .loss import loss_or_note

    if not isinstance(beam, Beam):
        beam = Beam.from_file(_beam_path(beam, "fom()", "beam"))
    if correction_beam is not None:
        expect(correction_beam, Beam, "correction_beam", "fom()", "a Beam or None")
    result = figure_of_merit(beam, fom_settings(**settings), correction_beam=correction_beam)
    result.ground_loss = loss_or_note(beam)[0]
    return result


Beam.fom = fom  # beam.fom(...): attached here, the layer that owns the FoM (beam.py stays below it)


def compare(*beams: Beam | str | os.PathLike, labels: list[str] | None = None, elevation_cut_deg: float = 10.0,
            **settings: Any):
    """Every beam against the first on their common frequencies and directions: dB differences
    over the sky, zenith ratio, widths, ground loss, and the FoM of each scored alike (the
    ``groundplane compare`` command's :class:`~groundplane.comparison.Comparison`).

    Examples
    --------
    >>> import groundplane as gp
    >>> c = gp.compare("examples/lowband_square10_nec.npz", "examples/lowband_square10_nec.npz", n_lst=24)
    >>> float(c.pairs[0].rms_db.max())
    0.0
    """
    from .comparison import compare_beams

    if not beams:
        raise UserInputError("compare(): give at least one beam")
    loaded = [b if isinstance(b, Beam) else Beam.from_file(_beam_path(b, "compare()", f"beam {i + 1}"))
              for i, b in enumerate(beams)]
    if labels is not None and (not isinstance(labels, (list, tuple)) or len(labels) != len(beams)
                               or not all(isinstance(x, str) for x in labels)):
        raise ArgumentError(f"compare(): labels must be a list of {len(beams)} strings (one a beam), got {labels!r}"[:200])
    names = labels or [str(b) if not isinstance(b, Beam) else str(b.meta.get("source", f"beam {i}"))
                       for i, b in enumerate(beams)]
    return compare_beams(loaded, names, names, fom_settings(**settings), elevation_cut_deg)


def fabrication_plan(plane: GroundPlane | str, out_dir: str | os.PathLike | None = None, **sheet: Any):
    """The plane cut from stock welded-mesh sheets (``groundplane fabricate``): the plan's
    summary (sheets bought, whole and cut, waste, seams, cuts, mass); with ``out_dir`` also its
    DXF outline, drawings, cut list and ``plan.json`` there. ``sheet``: ``size=(2.4, 6.0)``,
    ``overlap``, ``grid``, ``wire_diameter`` (m).

    Examples
    --------
    >>> import groundplane as gp
    >>> gp.fabrication_plan("extended")["sheets_bought"]
    48
    """
    from .fabricate import MeshSheet, plan_sheets, write_plan

    p = as_plane(plane, "fabrication_plan()")
    if out_dir is not None:
        expect(out_dir, (str, os.PathLike), "out_dir", "fabrication_plan()", "a folder's path or None")
    plan = plan_sheets(p, build(MeshSheet, sheet, "sheet: "))
    if out_dir is None:
        return plan.summary()
    return write_plan(plan, Path(out_dir), "groundplane.fabrication_plan()")


def export(plane: GroundPlane | str, path: str | os.PathLike, *, thickness: float = 0.002,
           with_antenna: bool = False) -> Path:
    """Write the plane (or a preset's) for fabrication or a commercial solver, in the format the
    suffix names: ``.step`` (cadquery; ``with_antenna`` adds the blade), ``.stl`` (trimesh),
    ``.svg`` / ``.png`` (a dimensioned outline). Written atomically (``groundplane export``).

    Examples
    --------
    >>> import groundplane as gp, tempfile, os, trimesh
    >>> path = gp.export("square-10", os.path.join(tempfile.mkdtemp(), "square-10.stl"))
    >>> float(round(trimesh.load(path).extents[0], 3))
    10.0
    """
    from .cad import export as write

    plane = as_plane(plane, "export()")
    expect(path, (str, os.PathLike), "path", "export()", "a file's path (.step, .stl, .svg or .png)")
    expect(thickness, (int, float), "thickness", "export()", "a number of metres")
    return write(plane, path, thickness=thickness, with_antenna=bool(expect(with_antenna, bool, "with_antenna",
                                                                            "export()", "True or False")))


def _beam_path(beam: Any, where: str, name: str) -> Any:
    """A beam argument that is not a Beam: a path, or a list of paths (FEKO quadrant files)."""
    paths = beam if isinstance(beam, (list, tuple)) and beam else [beam]
    for p in paths:
        expect(p, (str, os.PathLike), name, where, "a Beam or a beam file's path")
    return beam


def higher_layer(name: str) -> Callable[..., Any]:
    """A public function a higher layer registers under ``groundplane.api`` (``solve``,
    ``score``, ``optimise``, ``sweep``), loaded on first use."""
    from importlib.metadata import entry_points

    for ep in entry_points(group=API_GROUP):
        if ep.name == name:
            return ep.load()
    raise AttributeError(f"module 'groundplane' has no attribute '{name}' (is the groundplane distribution, with "
                         "its solvers and optimise packages, installed?)")
