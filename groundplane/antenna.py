"""The EDGES low-band blade dipole (SPEC section 1) as data: metres, x = excitation axis."""
from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from typing import Any

from . import paper
from .errors import SettingsError


@dataclass(frozen=True)
class AntennaParts:
    """Parts the paper's antenna model has beside the bare blade (m; None = absent). Only the
    NEC-2 engine models them (as wire grids); the surface engine refuses them.

    ``balun``: the Roberts balun's two outer conductors, joining the panels' inner edges to the
    ground; ``top_plate``: (side, gap above the panels) of a floating square plate over the feed;
    ``shield``: (along x, across y, height) of an open four-walled box around the balun on the
    ground; ``feed_span``: the port spread along the gap (a 1 V source on every gap-crossing wire
    with |y| <= span / 2). SPEC section 1 gives only the balun; the others' sizes are assumptions.
    """

    balun: bool = False
    top_plate: tuple[float, float] | None = None
    shield: tuple[float, float, float] | None = None
    feed_span: float | None = None

    def __post_init__(self) -> None:
        for name, size, n in (("top_plate", self.top_plate, 2), ("shield", self.shield, 3)):
            if size is not None and not (len(size) == n and all(isinstance(v, (int, float)) and v > 0 for v in size)):
                raise SettingsError(f"AntennaParts: {name} must be {n} positive lengths (m), got {size!r}")
        if self.feed_span is not None and not (isinstance(self.feed_span, (int, float)) and self.feed_span > 0):
            raise SettingsError(f"AntennaParts: feed_span must be a positive length (m), got {self.feed_span!r}")

    def label(self) -> str:
        """The parts in words, for a table."""
        out = []
        if self.balun:
            out.append("balun tubes (1 cm, feed edges to ground)")
        if self.top_plate:
            out.append(f"top plate {self.top_plate[0] * 100:g} cm square, {self.top_plate[1] * 100:g} cm above "
                       "(assumed)")
        if self.shield:
            sx, sy, sh = self.shield
            out.append(f"base shield {sx * 100:g} x {sy * 100:g} x {sh * 100:g} cm (assumed)")
        if self.feed_span:
            out.append(f"feed spread over {self.feed_span * 100:g} cm of the gap")
        return " + ".join(out) or "none"


@dataclass(frozen=True)
class BladeDipole:
    """Two rectangular panels fed across a gap, above the ground plane.

    ``panel_length`` runs along the excitation axis (x), ``panel_width`` across it (y);
    the panels span x in [gap/2, gap/2 + length] and its mirror, at z = ``height``.
    """

    # SPEC section 1 (corrected): the 0.964 m side runs along the axis (tip to tip 1.972 m);
    # this orientation gives Table 1's E/H beam widths (72/110 deg at 75 MHz) over PEC.
    panel_length: float = paper.PANEL_ALONG_AXIS_M
    panel_width: float = paper.PANEL_ACROSS_AXIS_M
    gap: float = paper.FEED_GAP_M
    height: float = paper.PANEL_HEIGHT_M
    parts: AntennaParts | None = None  # the bare blade (every engine) unless given

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name != "parts" and not (isinstance(v, (int, float)) and v > 0):
                raise SettingsError(f"BladeDipole: {f.name} must be positive, got {v!r}")
        if self.parts is not None and not isinstance(self.parts, AntennaParts):
            raise SettingsError(f"BladeDipole: parts must be AntennaParts, got {type(self.parts).__name__}")

    @property
    def tip_to_tip(self) -> float:
        return self.gap + 2 * self.panel_length

    def as_dict(self) -> dict[str, Any]:
        """The dimensions (and the parts, when there are any: a bare blade's identity, and so
        every cached beam's key, is what it was before parts existed)."""
        d = asdict(self)
        if self.parts is None:
            del d["parts"]
        return d


EDGES_LOW_BAND = BladeDipole()
