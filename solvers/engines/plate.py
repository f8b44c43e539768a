"""The plate and blade model settings every engine shares: one declaration of ``--mesh``,
``--plate-height`` and ``--blade-cells`` (same flags, same meaning, same defaults), which each
engine's settings extend with its own."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any

from groundplane.errors import SettingsError
from groundplane.options import option

MIN_SPACING_M, MAX_SPACING_M = 0.05, 5.0
MAX_PLATE_HEIGHT_M = 5.0  # the plate lies on the soil (5 mm); a few metres is the most any model study raises it
MAX_BLADE_CELLS = 100


@dataclass(frozen=True)
class PlateModel:
    """The plate cell size, its height above the ground and the blade panels' cells (metres).
    The plate height defaults to 5 mm: the real plate lies on the soil, and the FoM of a sheet on
    soil falls as the gap closes (``results/soil_surface.md``)."""

    spacing: float = option(0.5, "plate mesh spacing (m): NEC wire-grid cell, surface-engine triangle size",
                            flag="--mesh", metavar="SPACING")
    plate_height: float = option(0.005, "plate height above the ground (m)")
    blade_cells: tuple[int, int] = option((12, 10), "blade panel grid cells along and across the axis",
                                          metavar=("NX", "NY"))

    def __post_init__(self) -> None:
        """The checks every engine's plate model shares (each engine adds its own)."""
        if not (isinstance(self.spacing, (int, float)) and math.isfinite(self.spacing)
                and MIN_SPACING_M <= self.spacing <= MAX_SPACING_M):
            raise SettingsError(f"mesh spacing must be {MIN_SPACING_M:g}-{MAX_SPACING_M:g} m, got {self.spacing}: "
                                "finer has millions of unknowns on any plane (the memory is checked before any work "
                                "too), coarser does not resolve the plane at 100 MHz")
        if not (math.isfinite(self.plate_height) and 0 < self.plate_height <= MAX_PLATE_HEIGHT_M):
            raise SettingsError(f"plate height must be > 0 and at most {MAX_PLATE_HEIGHT_M:g} m above the ground, got "
                                f"{self.plate_height}")
        nx, ny = self.blade_cells
        if not (isinstance(nx, int) and isinstance(ny, int) and 2 <= nx <= MAX_BLADE_CELLS and 2 <= ny <= MAX_BLADE_CELLS):
            raise SettingsError(f"blade_cells {self.blade_cells}: 2-{MAX_BLADE_CELLS} cells each way (1 cm cells on the "
                                "96 cm panel at most; 1000 x 1000 ran NEC to 4 GB)")

    def as_dict(self) -> dict[str, Any]:
        """Every field, tuples as lists (JSON's form): what a cache key and a report's model are. An
        option declared ``keyed_at_default=False`` is left out at its default (older keys stay valid)."""
        quiet = {f.name for f in fields(self) if not f.metadata.get("option", {}).get("keyed_at_default", True)
                 and getattr(self, f.name) == f.default}
        return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items() if k not in quiet}
