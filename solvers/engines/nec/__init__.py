"""The NEC-2 engine (pynec-accel): ``mesh`` builds the wire model and the deck (pure
geometry), ``engine`` checks and runs the engine, ``solver`` is the cached solve."""
from .mesh import NecModel, NecSettings, build_model, check_wire_grid, plate_edges
from .solver import MODEL_VERSION, NecSolver

__all__ = ["MODEL_VERSION", "NecModel", "NecSettings", "NecSolver", "build_model", "check_wire_grid", "plate_edges"]
