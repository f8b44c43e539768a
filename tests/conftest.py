import os
import tempfile
from pathlib import Path

import pytest

# One horizon-sky cache for the whole test session, never the user's.
os.environ.setdefault("GROUNDPLANE_CACHE", tempfile.mkdtemp(prefix="groundplane-test-cache-"))

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"
SHARED_BEAMS = SHARED / "data" / "beams"
EXAMPLE_BEAM = ROOT / "examples" / "edges_highband_feko.npz"
DATA = ROOT / "tests" / "data"
QUADRANTS = ["0-90", "91-180", "181-270", "271-360"]


def shared_file(name: str) -> Path:
    p = SHARED_BEAMS / name
    if not p.exists():
        pytest.skip(f"optional shared sample {p} not present")
    return p


def quadrant_paths() -> list[Path]:
    """The four FEKO low-band quadrant files in ../shared (skip when absent)."""
    return [shared_file(f"feko_lowband_soil_40MHz_{q}.ffe") for q in QUADRANTS]
