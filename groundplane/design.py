"""A candidate: ground-plane shape + antenna + soil, hashable with a canonical JSON form
(the solver cache key is built from it), and where the antenna points on the sky."""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from typing import Any

from . import paper
from .antenna import EDGES_LOW_BAND, BladeDipole
from .errors import SettingsError
from .options import option
from .shapes import GroundPlane, to_dict

EXCITATION_AZIMUTH_DEG = paper.EXCITATION_AZIMUTH_DEG
"""The antenna's excitation axis on the site, from North through East (deg). It does not
change the beam in the antenna frame, only where the sky is: the FoM takes it from here."""


@dataclass(frozen=True)
class Soil:
    """A lossy half-space (SPEC section 2: MRO soil eps_r 3.5, sigma 0.02 S/m).

    >>> Soil(eps_r=2.5, sigma=0.005)
    Soil(eps_r=2.5, sigma=0.005)
    """

    eps_r: float = option(paper.MRO_EPS_R, "soil relative permittivity")
    sigma: float = option(paper.MRO_SIGMA_S_PER_M, "soil conductivity (S/m)")

    def __post_init__(self) -> None:
        if not (self.eps_r >= 1.0):
            raise SettingsError(f"Soil: eps_r must be >= 1, got {self.eps_r}")
        if not (self.sigma >= 0.0):
            raise SettingsError(f"Soil: sigma must be >= 0 S/m, got {self.sigma}")


@dataclass(frozen=True)
class InfinitePEC:
    """Infinite perfectly conducting ground (the paper's reference case; no plate).

    >>> Design(None, InfinitePEC()).label()
    'blade dipole over infinite PEC ground'
    """


@dataclass(frozen=True)
class FreeSpace:
    """No ground at all: a plate (or the blade) alone in space. Not a site; the case in
    which two engines can compare their models of a finite plate without a ground model.

    >>> from groundplane.shapes import Square
    >>> Design(Square(10.0), FreeSpace()).label()
    'Square(side=10.0) in free space'
    """


@dataclass(frozen=True)
class Design:
    """What one EM solve is of. ``plane`` is None over infinite PEC ground.

    >>> from groundplane.shapes import Square
    >>> Design(Square(10.0), Soil(3.5, 0.02)).plane.metal_area
    100.0
    """

    plane: GroundPlane | None
    ground: Soil | InfinitePEC | FreeSpace = field(default_factory=Soil)
    antenna: BladeDipole = EDGES_LOW_BAND

    def __post_init__(self) -> None:
        if self.plane is None and isinstance(self.ground, Soil):
            raise SettingsError("a design over soil needs a ground-plane shape (or use ground=InfinitePEC())")

    def as_dict(self) -> dict[str, Any]:
        g = {"type": self.ground_kind} if not isinstance(self.ground, Soil) else {"type": "soil", **asdict(self.ground)}
        return {
            "plane": None if self.plane is None else to_dict(self.plane),
            "ground": g,
            "antenna": self.antenna.as_dict(),
        }

    @property
    def ground_kind(self) -> str:
        """'soil', 'pec' or 'free' (what an engine must be able to put under the design)."""
        return {Soil: "soil", InfinitePEC: "pec", FreeSpace: "free"}[type(self.ground)]

    def canonical(self) -> str:
        return json.dumps(self.as_dict(), sort_keys=True, default=float)

    def label(self) -> str:
        where = {"pec": "over infinite PEC ground", "free": "in free space"}
        if self.plane is None:
            return f"blade dipole {where.get(self.ground_kind, '')}"
        p = self.plane.describe()
        if isinstance(self.ground, Soil):
            return f"{p} over soil eps_r={self.ground.eps_r} sigma={self.ground.sigma}"
        return f"{p} {where[self.ground_kind]}"
