"""The EDGES low-band blade dipole (SPEC section 1) as data: metres, x = excitation axis."""
from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any


@dataclass(frozen=True)
class BladeDipole:
    """Two rectangular panels fed across a gap, above the ground plane.

    ``panel_length`` runs along the excitation axis (x), ``panel_width`` across it (y);
    the panels span x in [gap/2, gap/2 + length] and its mirror, at z = ``height``.
    """

    panel_length: float = 1.252
    panel_width: float = 0.964
    gap: float = 0.044
    height: float = 1.04
    azimuth_deg: float = -7.0  # excitation axis, from North through East

    def __post_init__(self) -> None:
        for k, v in asdict(self).items():
            if k != "azimuth_deg" and not (isinstance(v, (int, float)) and v > 0):
                raise ValueError(f"BladeDipole: {k} must be positive, got {v!r}")

    @property
    def tip_to_tip(self) -> float:
        return self.gap + 2 * self.panel_length

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


EDGES_LOW_BAND = BladeDipole()
