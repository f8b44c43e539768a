"""The EDGES low-band blade dipole (SPEC section 1) as data: metres, x = excitation axis."""
from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

from . import paper
from .errors import SettingsError


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

    def __post_init__(self) -> None:
        for k, v in asdict(self).items():
            if not (isinstance(v, (int, float)) and v > 0):
                raise SettingsError(f"BladeDipole: {k} must be positive, got {v!r}")

    @property
    def tip_to_tip(self) -> float:
        return self.gap + 2 * self.panel_length

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


EDGES_LOW_BAND = BladeDipole()
