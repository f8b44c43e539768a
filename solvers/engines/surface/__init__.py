"""The surface-current engine: RWG Method of Moments on solid plates and panels over soil,
infinite PEC ground or in free space; the default engine, and an independent check of NEC's
wire-grid answers (``groundplane study cross-engine``).

The mixed-potential EFIE on flat horizontal metal
(plates, panels) with Rao-Wilton-Glisson (RWG) basis functions, Galerkin testing, in free
space or over infinite perfect ground (image theory), a delta-gap feed, and the far field.

Written here rather than taken from ``bempp-cl``: bempp offers no half-space kernel (PEC
image or Sommerfeld), which every solve over ground needs (how the two compared on the blade
in free space: docs/surface-engine.md). Everything below is numpy/scipy, vectorised over
triangle pairs (the fast solve's two innermost loops are compiled: ``_compiled.py``):

* Matrix: Z = jw mu/(4 pi) <f_m, A f_n> - j/(4 pi w eps) <div f_m, Phi div f_n> with the
  kernel G = exp(-jkR)/R (minus its image over PEC). Per triangle pair the integrals reduce
  to a few moments (the scalar, the first moments on either side and the cross moment of G
  over the pair); Z is then gathers of those with the RWG coefficients (each basis lives on
  two triangles), so nothing is looped in Python per element.
* Distant pairs: 3-point rules (degree 2) on both triangles. Near pairs (centroids closer
  than ``near_factor`` times the larger triangle, images included): 7-point outer rule
  (Dunavant, degree 5; on 16 sub-triangles for close pairs); the inner 1/R and rho'/R
  integrals in closed form (Wilton et al. 1984, IEEE TAP 32, 276; no library provides them
  for numpy arrays), the smooth rest (exp(-jkR) - 1)/R by the 7-point rule.
* Only horizontal triangles (every structure we model is flat and level): currents are
  horizontal, so a PEC image is the same current reversed at -z, for both potentials.
* Designs symmetric about both axes are solved in the driven symmetry class only
  (:class:`MirrorSymmetry`): exact, a quarter of the fill.
* Gain = 4 pi U / P_in with P_in = 1/2 Re(V I*) at the gap: a lossless model must radiate
  what it takes in (mean gain 2 over the upper hemisphere over PEC, 1 over the sphere in
  free space), which the tests check (no calibration).

Laid out as bempp-cl lays out its library: ``grid.py`` (triangles and quadrature), ``space.py``
(the RWG basis and the mirror-symmetry class), ``operators.py`` (the kernels over a ground, their
pair integrals, the :class:`Problem`), two interchangeable assemblers with their solves
(``dense.py``: every entry, LU; ``pfft.py``: precorrected FFT, GMRES), ``excitation.py`` (the
delta gap and its solution) and ``farfield.py`` (the gain); ``halfspace.py`` the Sommerfeld
kernels, ``mesh.py`` a design's triangles, ``solver.py`` the engine.
"""
from .mesh import SurfaceSettings, build_mesh
from .solver import MODEL_VERSION, SurfaceSolver

__all__ = ["MODEL_VERSION", "SurfaceSettings", "SurfaceSolver", "build_mesh"]
