"""The surface-current engine: RWG Method of Moments on solid plates and panels over
infinite PEC ground (``rwg`` the physics, ``mesh`` the triangles, ``solver`` the cached
solve). An independent check of NEC's wire-grid answers (``groundplane study cross-engine``)."""
from .mesh import SurfaceSettings, build_mesh
from .solver import MODEL_VERSION, SurfaceSolver

__all__ = ["MODEL_VERSION", "SurfaceSettings", "SurfaceSolver", "build_mesh"]
