"""The FDTD referee (gprMax, run as its own process): ``model`` puts a design on the Yee grid
and writes gprMax's input (pure geometry), ``run`` runs gprMax and reads its output, ``solver``
is the cached solve."""
from .model import FdtdModel, FdtdSettings, build_model, panel_cells
from .solver import MODEL_VERSION, FdtdSolver

__all__ = ["MODEL_VERSION", "FdtdModel", "FdtdSettings", "FdtdSolver", "build_model", "panel_cells"]
