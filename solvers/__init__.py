"""The solver adapter layer: run an MoM engine or load a commercial solver's export,
always returning a :class:`groundplane.beam.Beam`."""
from .loaders import FORMATS, detect_format, load_beam

__all__ = ["FORMATS", "detect_format", "load_beam"]
