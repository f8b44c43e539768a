"""groundplane: design ground planes for low-frequency radio antennas.

The domain core: ground-plane shapes, CAD export, the Beam object, the sky model and
the chromaticity Figure of Merit. Solvers live in ``solvers``; optimisation in ``optimise``.
"""
from .beam import Beam, BeamFormatError

__all__ = ["Beam", "BeamFormatError"]
__version__ = "0.1.0"
