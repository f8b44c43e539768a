"""The plate and blade model settings every engine shares: one declaration of ``--mesh``,
``--plate-height`` and ``--blade-cells`` (same flags, same meaning, same defaults), which each
engine's settings extend with its own."""
from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

from groundplane.options import option


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

    def as_dict(self) -> dict[str, Any]:
        """Every field, tuples as lists (JSON's form): what a cache key and a report's model are."""
        return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}
