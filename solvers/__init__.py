"""The solver adapter layer: beams in. ``solvers.io`` reads commercial solvers' exports,
``solvers.engines`` runs MoM engines; both return a :class:`groundplane.beam.Beam`."""
from .io import FORMATS, detect_format, load_beam

__all__ = ["FORMATS", "detect_format", "load_beam"]
