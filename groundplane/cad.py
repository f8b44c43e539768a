"""CAD of ground planes: cadquery solids and STEP files (in metres) for workshops and
commercial solvers, trimesh STL, and a dimensioned drawing of the outline.

cadquery (OpenCascade) works in millimetres by default; the STEP writer and reader are
set here to metres so a 10 m plate is 10 m in FEKO/CST and after re-import.
cadquery is imported lazily: it is heavy and only export needs it.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from .antenna import EDGES_LOW_BAND, BladeDipole
from .errors import UserInputError
from .shapes import GroundPlane

DEFAULT_THICKNESS_M = 0.002


def _metres_in_step() -> None:
    """Tell OpenCascade's STEP translator that model units and file units are metres."""
    from OCP.Interface import Interface_Static
    from OCP.STEPControl import STEPControl_Controller

    STEPControl_Controller.Init_s()
    Interface_Static.SetCVal_s("xstep.cascade.unit", "M")
    Interface_Static.SetCVal_s("write.step.unit", "M")


MAX_THICKNESS_M = 0.1  # a mesh or sheet plate is millimetres thick; 1e9 m wrote a STEP


def _check_thickness(thickness: float) -> None:
    if not (np.isfinite(thickness) and 0 < thickness <= MAX_THICKNESS_M):
        raise UserInputError(f"plate thickness must be a positive number of metres up to {MAX_THICKNESS_M:g}, got "
                             f"{thickness:g}")


def plate_solid(shape: GroundPlane, thickness: float = DEFAULT_THICKNESS_M):
    """The ground plane as a cadquery Workplane solid: the outline extruded downward
    from z = 0 by ``thickness`` (top face at z = 0, the feed above the origin)."""
    import cadquery as cq

    _check_thickness(thickness)
    pts = [tuple(p) for p in np.asarray(shape.outline().exterior.coords)[:-1]]
    return cq.Workplane("XY").workplane(offset=-thickness).polyline(pts).close().extrude(thickness)


def blade_solids(antenna: BladeDipole = EDGES_LOW_BAND, thickness: float = 0.003):
    """The two blade panels as cadquery solids at their height above the plate."""
    import cadquery as cq

    x0 = antenna.gap / 2
    panels = []
    for sign in (1, -1):
        cx = sign * (x0 + antenna.panel_length / 2)
        panels.append(
            cq.Workplane("XY").workplane(offset=antenna.height)
            .center(cx, 0).rect(antenna.panel_length, antenna.panel_width).extrude(thickness)
        )
    return panels


def export_step(
    shape: GroundPlane,
    path: str | Path,
    thickness: float = DEFAULT_THICKNESS_M,
    with_antenna: bool = False,
    antenna: BladeDipole = EDGES_LOW_BAND,
) -> Path:
    """STEP (AP214) in metres. With ``with_antenna``, an assembly with named parts
    ``ground_plane``, ``blade_pos``, ``blade_neg``."""
    import cadquery as cq

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    _metres_in_step()
    plate = plate_solid(shape, thickness)
    if not with_antenna:
        from OCP.IFSelect import IFSelect_RetDone
        from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

        writer = STEPControl_Writer()
        writer.Transfer(plate.val().wrapped, STEPControl_AsIs)
        if writer.Write(str(path)) != IFSelect_RetDone:  # OCCT says no more than that: look at the folder
            import errno
            import shutil

            if shutil.disk_usage(path.parent).free < 16 * 2**20:
                raise OSError(errno.ENOSPC, "no space left on the device")
            raise OSError(errno.EIO, "the STEP writer failed (a full or read-only folder?)")
        return path
    assy = cq.Assembly(name="groundplane_antenna")
    assy.add(plate, name="ground_plane", color=cq.Color(0.7, 0.7, 0.7))
    pos, neg = blade_solids(antenna)
    assy.add(pos, name="blade_pos", color=cq.Color(0.8, 0.5, 0.2))
    assy.add(neg, name="blade_neg", color=cq.Color(0.8, 0.5, 0.2))
    from cadquery.occ_impl.exporters.assembly import exportAssembly

    exportAssembly(assy, str(path), unit="M")  # model values are metres; so is the file
    return path


def import_step_volume(path: str | Path) -> float:
    """Volume (m^3) of all solids in a STEP file read back in metres (for round-trip checks)."""
    import cadquery as cq

    shape = cq.importers.importStep(str(path), unit="M")
    return float(sum(s.Volume() for s in shape.solids().vals()))


def plate_mesh(shape: GroundPlane, thickness: float = DEFAULT_THICKNESS_M):
    """A watertight trimesh of the plate (metres), top face at z = 0."""
    import trimesh

    _check_thickness(thickness)
    mesh = trimesh.creation.extrude_polygon(shape.outline(), thickness)
    mesh.apply_translation([0.0, 0.0, -thickness])
    if not mesh.is_watertight:  # pragma: no cover - extrude_polygon of a valid polygon is closed
        raise RuntimeError(f"{shape.describe()}: extruded mesh is not watertight")
    return mesh


def export_stl(shape: GroundPlane, path: str | Path, thickness: float = DEFAULT_THICKNESS_M) -> Path:
    """Binary STL in metres."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    plate_mesh(shape, thickness).export(str(path), file_type="stl")
    return path


def draw_outline(shape: GroundPlane, path: str | Path, title: str | None = None) -> Path:
    """A dimensioned drawing (SVG or PNG by suffix): outline, overall size, metal area."""
    from .plots import finish_figure, pyplot

    fig, ax = pyplot().subplots(figsize=(6, 6))
    plot_outline(shape, ax)
    dimension(ax, shape.outline().bounds)
    ax.set_title(title or f"{shape.describe()}\nmetal area {shape.metal_area:.2f} m$^2$, "
                 f"{shape.edge_count} edges", fontsize=9)
    return finish_figure(fig, path, dpi=120)


def dimension(ax: Any, bounds: tuple[float, float, float, float], pad_fraction: float = 0.08) -> None:
    """Overall width and height arrows, in metres, outside ``bounds`` (x0, y0, x1, y1)."""
    x0, y0, x1, y1 = bounds
    pad = pad_fraction * max(x1 - x0, y1 - y0)
    ax.annotate("", xy=(x0, y0 - pad), xytext=(x1, y0 - pad), arrowprops=dict(arrowstyle="<->", lw=0.8))
    ax.text((x0 + x1) / 2, y0 - 1.6 * pad, f"{x1 - x0:.2f} m", ha="center", va="top")
    ax.annotate("", xy=(x1 + pad, y0), xytext=(x1 + pad, y1), arrowprops=dict(arrowstyle="<->", lw=0.8))
    ax.text(x1 + 1.3 * pad, (y0 + y1) / 2, f"{y1 - y0:.2f} m", rotation=90, va="center", ha="left")
    ax.set_xlim(x0 - 2 * pad, x1 + 2.5 * pad)
    ax.set_ylim(y0 - 2.5 * pad, y1 + 2 * pad)


def plot_outline(shape: GroundPlane, ax: Any, antenna: BladeDipole | None = EDGES_LOW_BAND, **kw: Any) -> None:
    """Draw the outline (and the blade footprint) on a matplotlib Axes, in metres."""
    xy = np.asarray(shape.outline().exterior.coords)
    ax.fill(xy[:, 0], xy[:, 1], color=kw.pop("color", "0.75"), ec="k", lw=0.8, **kw)
    if antenna is not None:
        for s in (1, -1):
            x = s * (antenna.gap / 2 + np.array([0, antenna.panel_length, antenna.panel_length, 0, 0]))
            y = antenna.panel_width / 2 * np.array([-1, -1, 1, 1, -1])
            ax.plot(x, y, color="tab:orange", lw=0.8)
    ax.plot(0, 0, "k+")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m, excitation axis)")
    ax.set_ylabel("y (m)")


def export(shape: GroundPlane, path: str | Path, thickness: float = DEFAULT_THICKNESS_M,
           with_antenna: bool = False) -> Path:
    """Write ``path`` in the format its suffix names: .step/.stp, .stl, .svg, .png. The file
    is written beside it and renamed into place, so an interrupted export never leaves a
    truncated file where a good one was (and a symlink at ``path`` is replaced, not followed)."""
    from .files import atomic_path

    suffix = Path(path).suffix.lower()
    if suffix in (".step", ".stp"):
        writer = lambda tmp: export_step(shape, tmp, thickness, with_antenna)  # noqa: E731
    elif with_antenna:
        raise UserInputError(f"--with-antenna is only for STEP output, not {suffix}")
    elif suffix == ".stl":
        writer = lambda tmp: export_stl(shape, tmp, thickness)  # noqa: E731
    elif suffix in (".svg", ".png"):
        writer = lambda tmp: draw_outline(shape, tmp)  # noqa: E731
    else:
        raise UserInputError(f"{path}: unknown output format '{suffix}'; use .step, .stl, .svg or .png")
    with atomic_path(path, suffix=".tmp" + suffix) as tmp:
        writer(tmp)
    return Path(path)
