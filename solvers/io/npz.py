"""The native ``.npz`` beam file (see :mod:`groundplane.beam`)."""
from __future__ import annotations

from groundplane.beam import Beam

from . import BeamFormat, register_format

register_format(BeamFormat(
    "npz", sniff=lambda head: head[:2] == b"PK", read=lambda paths: Beam.load(paths[0]),
    description="native groundplane beam (arrays + JSON meta)",
))


