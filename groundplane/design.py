"""A candidate: ground-plane shape + antenna + soil, hashable with a canonical JSON form
(the solver cache key is built from it)."""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from typing import Any

from .antenna import EDGES_LOW_BAND, BladeDipole
from .shapes import GroundPlane, to_dict


@dataclass(frozen=True)
class Soil:
    """A lossy half-space (SPEC section 2: MRO soil eps_r 3.5, sigma 0.02 S/m)."""

    eps_r: float = 3.5
    sigma: float = 0.02

    def __post_init__(self) -> None:
        if not (self.eps_r >= 1.0):
            raise ValueError(f"Soil: eps_r must be >= 1, got {self.eps_r}")
        if not (self.sigma >= 0.0):
            raise ValueError(f"Soil: sigma must be >= 0 S/m, got {self.sigma}")


@dataclass(frozen=True)
class InfinitePEC:
    """Infinite perfectly conducting ground (the paper's reference case; no plate)."""


@dataclass(frozen=True)
class Design:
    """What one EM solve is of. ``plane`` is None over infinite PEC ground."""

    plane: GroundPlane | None
    ground: Soil | InfinitePEC = field(default_factory=Soil)
    antenna: BladeDipole = EDGES_LOW_BAND

    def __post_init__(self) -> None:
        if self.plane is None and not isinstance(self.ground, InfinitePEC):
            raise ValueError("a design over soil needs a ground-plane shape (or use ground=InfinitePEC())")

    def as_dict(self) -> dict[str, Any]:
        g = {"type": "pec"} if isinstance(self.ground, InfinitePEC) else {"type": "soil", **asdict(self.ground)}
        return {
            "plane": None if self.plane is None else to_dict(self.plane),
            "ground": g,
            "antenna": self.antenna.as_dict(),
        }

    def canonical(self) -> str:
        return json.dumps(self.as_dict(), sort_keys=True, default=float)

    def label(self) -> str:
        if self.plane is None:
            return "blade dipole over infinite PEC ground"
        p = self.plane.describe()
        g = "PEC" if isinstance(self.ground, InfinitePEC) else f"soil eps_r={self.ground.eps_r} sigma={self.ground.sigma}"
        return f"{p} over {g}"
