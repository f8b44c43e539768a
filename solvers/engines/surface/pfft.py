"""The surface engine's fast solve: the precorrected-FFT method (pFFT; Phillips & White 1997,
IEEE TCAD 16, 1059), iterated by GMRES, never forming the dense matrix.

Why pFFT: every metal part we model is flat and level at a few heights, and every kernel the
engine uses (free space, PEC image, the soil's K_q image and tabulated Sommerfeld parts)
depends only on the horizontal separation for a given pair of heights, so the interactions
between distant triangles are 2-D convolutions. The pFFT keeps the engine's own quadrature
and near-pair integrals exactly (the dense fill is ``Z = Z_3pt + corrections``; the pFFT is
``Z = Z_grid + (Z_3pt - Z_grid)_near + corrections``), which a fast multipole method or
discrete complex images would not: the fast solve converges to the dense one, not to another
model. Time per iteration O(G log G) for a grid of G nodes, memory O(N) (the near pairs).

* Projection: each triangle's 3-point currents and charges are spread onto a regular grid
  (one layer per metal height) by a separable cubic (4 x 4) Lagrange stencil; the potentials
  are interpolated back by the transpose (Galerkin).
* Convolution: per (observation height, source height) the kernel sampled on grid offsets,
  zero-padded 2-D FFTs (scipy.fft).
* Precorrection: for every triangle pair closer than a few grid cells (and every pair the
  engine integrates accurately), the grid's value is replaced by the fill's 3-point value and
  the engine's near-pair corrections (the same routines as the dense fill).
* Solve: GMRES preconditioned by the sparse LU of the near matrix (scipy ``splu``); on mirror-
  symmetric designs the driven symmetry class only (the same reduction as the dense solve).

Everything that does not change with frequency (basis, symmetry, grid and projection, the
precorrection pairs) is built once per design (:func:`fast_model`) and reused by a worker
for each frequency it solves.
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from .excitation import Solution, feed_signs
from .grid import Q3, Q7, Q7_TOUCHING, quadrature_points
from .halfspace import C0, EPS0, MU0
from .operators import CLOSE_FACTOR, Problem, near_geometry
from .space import MirrorSymmetry, rwg_basis

GRID_FRACTION = 0.3  # grid spacing as a fraction of the plate's typical triangle size
GRID_MAX = 0.25  # m: never coarser (the soil's reflected kernels vary on ~ its wavelength / 2 pi)
PRECORRECT_CELLS = 5.0  # grid cells: point pairs closer than this are precorrected (stencil reach 1.5 cells)
FAR_REACH_CELLS = 8  # the soil's tables reach this many grid cells past the metal (the grid's offsets reach 5)
GMRES_RTOL = 1e-5
GMRES_RESTART = 200


def _lagrange(t: np.ndarray) -> np.ndarray:
    """Cubic Lagrange weights [..., 4] at nodes 0..3 for local coordinates t in [1, 2)."""
    return np.stack([-(t - 1) * (t - 2) * (t - 3) / 6, t * (t - 2) * (t - 3) / 2,
                     -t * (t - 1) * (t - 3) / 2, t * (t - 1) * (t - 2) / 6], axis=-1)


@dataclass
class Grid:
    """A regular grid of spacing ``h`` over the metal, one layer per height ``levels``."""

    x0: float
    y0: float
    h: float
    nx: int
    ny: int
    levels: np.ndarray

    @classmethod
    def around(cls, xy: np.ndarray, levels: np.ndarray, h: float) -> "Grid":
        lo, hi = xy.min(axis=0), xy.max(axis=0)
        x0, y0 = lo - 2 * h
        nx, ny = (np.ceil((hi - lo) / h).astype(int) + 5)
        return cls(float(x0), float(y0), h, int(nx), int(ny), levels)

    def stencil(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Base node indices (ix, iy) and separable weights (wx, wy) [..., 4] of points ``xy``."""
        u = (xy[..., 0] - self.x0) / self.h
        v = (xy[..., 1] - self.y0) / self.h
        ix, iy = np.floor(u).astype(np.int64) - 1, np.floor(v).astype(np.int64) - 1
        return ix, iy, _lagrange(u - ix), _lagrange(v - iy)


@dataclass
class FastModel:
    """The frequency-independent part of a fast solve of one design."""

    prob: Problem
    symmetry: MirrorSymmetry | None
    rows: np.ndarray  # the testing functions solved for (representatives, or all)
    u: sp.csr_matrix  # N x len(rows): currents of the solved class from its unknowns
    grid: Grid
    level: np.ndarray  # [T] layer of each triangle
    project: sp.csr_matrix  # [n_levels * nx * ny, 3T]: point sources -> grid nodes
    points: tuple[np.ndarray, np.ndarray]  # 3-point rule [T, 3, 3], weights [T, 3]
    stencils: tuple[np.ndarray, ...]  # each point's base nodes ix, iy [T, 3] and weights wx, wy [T, 3, 4]
    pairs: np.ndarray  # [P, 2] (obs, src) triangle pairs to precorrect (obs in the rows' triangles)
    _series: "NearSeries | None" = None
    _assembly: "StaticAssembly | None" = None
    _rows_of_level: "list[slice] | None" = None
    _project_t: "sp.csr_matrix | None" = None
    _testing: "tuple[sp.csr_matrix, sp.csr_matrix] | None" = None

    def series(self, k: float) -> "NearSeries":
        """The engine's near moments as a series in k, (re)built when ``k`` is beyond it."""
        if self._series is None or k > self._series.k_max:
            self._series = NearSeries(self.prob, row_triangles(self.prob, self.rows), k)
        return self._series

    def assembly(self) -> "StaticAssembly":
        """The near matrices' sparsity over the precorrection pairs and the series' direct and
        image near pairs (in its order; a rebuilt series keeps it), built once."""
        if self._assembly is None:
            if self._series is None:
                raise RuntimeError("FastModel.assembly: build the series first")
            self._assembly = StaticAssembly(self.prob, self.rows, [self.pairs, self.near_pairs(False),
                                                                   self.near_pairs(True)])
        return self._assembly

    def near_pairs(self, image: bool) -> np.ndarray:
        """The series' direct (or image) near pairs, in its order (the assembly's lists 1, 2)."""
        groups = [g[1] for g in self._series.groups if g[0] == image] if self._series is not None else []
        return np.concatenate(groups) if groups else np.zeros((0, 2), int)

    @property
    def shape(self) -> tuple[int, int]:
        """Zero-padded FFT size (linear, not circular, convolution)."""
        import scipy.fft

        return scipy.fft.next_fast_len(2 * self.grid.nx), scipy.fft.next_fast_len(2 * self.grid.ny)

    @property
    def testing(self) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        """(C1^T, -Cx^T, -Cy^T stacked: each triangle's linear current J = alpha rho + beta, div J =
        2 alpha, from the currents in one product; C1, Cx, Cy side by side: the solved rows'
        testing of the potentials), made once for every soil and frequency."""
        if self._testing is None:
            prob, rows = self.prob, self.rows
            self._testing = (sp.vstack([prob.c1.T, -prob.cv[0].T, -prob.cv[1].T]).tocsr(),
                             sp.hstack([prob.c1[rows], prob.cv[0][rows], prob.cv[1][rows]]).tocsr())
        return self._testing

    @property
    def project_t(self) -> sp.csr_matrix:
        """The projection's transpose in rows (grid nodes -> points), made once: a product with the
        CSC transpose of ``project`` was the slowest sparse product of a matvec."""
        if self._project_t is None:
            self._project_t = self.project.T.tocsr()
        return self._project_t

    @property
    def rows_of_level(self) -> list[slice]:
        """The grid rows (x) each level's points reach through their stencils: a level's
        sources and potentials are zero, and unused, outside them (the blade's level spans a few
        rows of a grid sized for the plate)."""
        if self._rows_of_level is None:
            ix = self.stencils[0]
            self._rows_of_level = [slice(int(ix[self.level == lv].min()), int(ix[self.level == lv].max()) + 4)
                                   if np.any(self.level == lv) else slice(0, 0) for lv in range(len(self.grid.levels))]
        return self._rows_of_level

    def spectrum(self, src: np.ndarray) -> np.ndarray:
        """The zero-padded 2-D FFT [..., n_lev, sx, sy] of grid sources [..., n_lev, nx, ny]: along y
        only on the rows a level's sources occupy (the others are zero), then along x. Equal to
        ``fft2`` of the padded array; written out because no FFT library prunes zero rows."""
        import scipy.fft

        sx, sy = self.shape
        half = np.zeros(src.shape[:-1] + (sy,), complex)
        for lv, rows in enumerate(self.rows_of_level):
            half[..., lv, rows, :] = scipy.fft.fft(src[..., lv, rows, :], n=sy, axis=-1, workers=1)
        return scipy.fft.fft(half, n=sx, axis=-2, workers=1, overwrite_x=True)

    def potentials(self, spectrum: np.ndarray) -> np.ndarray:
        """The grid potentials [..., n_lev, nx, ny] of a spectrum [..., n_lev, sx, sy]: the inverse
        of :meth:`spectrum`, along x, then along y only on the rows a level's points read (zero
        elsewhere). Equal to ``ifft2`` cut to the grid there."""
        import scipy.fft

        g = self.grid
        half = scipy.fft.ifft(spectrum, axis=-2, workers=1)
        out = np.zeros(spectrum.shape[:-2] + (g.nx, g.ny), complex)
        for lv, rows in enumerate(self.rows_of_level):
            out[..., lv, rows, :] = scipy.fft.ifft(half[..., lv, rows, :], axis=-1, workers=1)[..., :g.ny]
        return out


def row_triangles(prob: Problem, rows: np.ndarray) -> np.ndarray:
    """Mask [T] of the triangles that carry the testing functions ``rows``."""
    obs = np.zeros(len(prob.mesh.tris), bool)
    obs[prob.rwg.plus[rows]] = True
    obs[prob.rwg.minus[rows]] = True
    return obs


def grid_spacing(prob: Problem) -> float:
    """Grid spacing set by the plate (the largest triangles), not by the blade's fine cells,
    whose pairs lie within the precorrection reach anyway."""
    size, area = prob.mesh.sizes, prob.mesh.areas
    order = np.argsort(size)
    median = size[order][np.searchsorted(np.cumsum(area[order]), 0.5 * area.sum())]  # area-weighted
    return min(GRID_MAX, GRID_FRACTION * float(median))


def build_fast_model(prob: Problem, symmetry: MirrorSymmetry | None, h: float | None = None) -> FastModel:
    """Grid, projection and precorrection pairs of ``prob`` (once per design)."""
    mesh = prob.mesh
    h = grid_spacing(prob) if h is None else h
    zt = mesh.nodes[mesh.tris[:, 0], 2]
    levels, level = np.unique(np.round(zt, 9), return_inverse=True)
    grid = Grid.around(mesh.nodes[:, :2], levels, h)
    pts, w = quadrature_points(mesh, Q3)
    ix, iy, wx, wy = grid.stencil(pts[..., :2])  # [T, 3], [T, 3, 4]
    t, q = len(mesh.tris), 3
    a = np.arange(4)
    node = ((level[:, None, None, None] * grid.nx + ix[..., None, None] + a[:, None]) * grid.ny
            + iy[..., None, None] + a[None, :])  # [T, 3, 4, 4]
    vals = wx[..., :, None] * wy[..., None, :]
    cols = np.broadcast_to(np.arange(t * q).reshape(t, q, 1, 1), node.shape)
    project = sp.csr_matrix((vals.ravel(), (node.ravel(), cols.ravel())),
                            shape=(len(levels) * grid.nx * grid.ny, t * q))
    if symmetry is not None:
        rows, u = symmetry.reps, symmetry.u
    else:
        rows, u = np.arange(prob.n), sp.identity(prob.n, format="csr")
    pairs = _precorrection_pairs(mesh.centroids, mesh.sizes, row_triangles(prob, rows), prob.near_factor, h)
    return FastModel(prob, symmetry, np.asarray(rows), u.tocsr(), grid, level, project, (pts, w), (ix, iy, wx, wy),
                     pairs)


def _precorrection_pairs(cen: np.ndarray, size: np.ndarray, obs: np.ndarray, near_factor: float,
                         h: float) -> np.ndarray:
    """Triangle pairs (obs, src), obs in ``obs``, whose interaction the grid does not
    represent to the engine's accuracy: centroids (3-D, direct) closer than the engine's near
    criterion or than the precorrection reach plus the triangles' half sizes. Image pairs are
    never closer than direct ones (every level is above the ground), so this covers them."""
    reach = PRECORRECT_CELLS * h
    radius = max(near_factor * size.max(), reach + size.max())
    o_idx = np.flatnonzero(obs)
    found = cKDTree(cen).query_ball_point(cen[o_idx], radius)
    lens = np.fromiter((len(x) for x in found), int, len(found))
    o = np.repeat(o_idx, lens)
    s = np.fromiter((j for x in found for j in x), int, int(lens.sum()))
    dist = np.linalg.norm(cen[o] - cen[s], axis=1)
    keep = (dist < near_factor * np.maximum(size[o], size[s])) | (dist < reach + 0.5 * (size[o] + size[s]))
    return np.stack([o[keep], s[keep]], axis=1)


BYTES_PER_PAIR = 1600  # peak bytes per precorrection or series pair beyond the series itself (see memory_estimate)
BASE_BYTES = 400 * 2**20  # interpreter, numpy/scipy and chunk temporaries of one worker


def memory_estimate(prob: Problem, symmetry: MirrorSymmetry | None) -> int:
    """Peak bytes of one worker's fast solve of ``prob``, before any: the power series of the
    engine's near moments (8 B x terms x moments per near pair), the sparse near matrices and
    their structure (per pair), the grid's kernels and the fixed base. ``BYTES_PER_PAIR`` was
    set on one measured peak (one worker, ``sawtooth-20-16`` at 0.5 m over soil: 1.56 GiB) and
    overestimates another (``square-30`` at 0.5 m: 2.14 GiB per worker estimated, a 3.30 GiB
    peak for two workers and the parent measured)."""
    model = build_fast_model(prob, symmetry)
    obs = row_triangles(prob, model.rows)
    near = [int(obs[p[:, 0]].sum()) for p in prob.near]
    terms = 32  # typical at 100 MHz on these meshes
    series = 8 * terms * (6 * near[0] + (sum(near[1:]) * (1 if prob.ground == "soil" else 6)))
    nl = len(model.grid.levels)
    sx, sy = model.shape
    grid = 16 * sx * sy * (2 * nl * nl + 9 * nl) + 16 * (2 * model.grid.nx) * (2 * model.grid.ny) * 2 * nl * nl
    return int(BASE_BYTES + series + BYTES_PER_PAIR * (len(model.pairs) + sum(near)) + grid)


_CACHE: dict[str, FastModel] = {}


def _model_key(prob: Problem, symmetric: bool) -> str:
    """The geometry a fast model depends on: the mesh, the ground's kind (not the soil's
    values: every soil of one design shares the model) and the near rule."""
    mesh = prob.mesh
    return hashlib.sha256(b"".join([mesh.nodes.tobytes(), mesh.tris.tobytes(), mesh.feed_edges.tobytes(),
                                    repr((prob.ground, prob.near_factor, symmetric)).encode()])).hexdigest()


def fast_model(prob: Problem, symmetric: bool) -> FastModel:
    """:func:`build_fast_model` for this design, reused across the frequencies and soils a
    worker process solves (keyed by the geometry; one design kept, and what it built with it)."""
    key = _model_key(prob, symmetric)
    if key not in _CACHE:
        # a worker is kept from one design to the next (``workers.shared_pool``): let go of everything
        # the last design held (its frequency's terms, LU and currents reference its model) before
        # building this one, so that a worker never holds two designs' models at once
        for kept in (_CACHE, _TERMS, _LU, _START, _SOIL_NEAR):
            kept.clear()
        symmetry = MirrorSymmetry.of(prob.mesh, prob.rwg) if symmetric else None
        _CACHE[key] = build_fast_model(prob, symmetry)
    return _CACHE[key]


def problem_of(mesh, ground: str, near_factor: float, soil) -> Problem:
    """The engine's :class:`Problem` on ``soil``: the cached model's basis and near lists
    (geometry only) when the mesh is the same, else built."""
    import copy

    for model in _CACHE.values():
        p = model.prob
        if (p.ground == ground and p.near_factor == near_factor
                and np.array_equal(p.mesh.tris, mesh.tris) and np.array_equal(p.mesh.nodes, mesh.nodes)):
            if p.soil == soil:
                return p
            other = copy.copy(p)  # the same basis, coefficients and near lists on another soil
            other.soil = soil
            return other
    return Problem(mesh, rwg_basis(mesh), ground, near_factor, soil)


# ------------------------------------------------------------------ per frequency
def _offset_tables(model: FastModel, k: float, image: bool) -> np.ndarray:
    """The direct kernel exp(-jkR)/R (and, with ``image``, its image below z = 0) on grid
    offsets, [n_lev, n_lev, 1 or 2, 2nx-1, 2ny-1] (observation level, source level)."""
    g = model.grid
    i = np.arange(-(g.nx - 1), g.nx)
    j = np.arange(-(g.ny - 1), g.ny)
    rho = g.h * np.hypot(i[:, None], j[None, :])
    nl = len(g.levels)
    table = np.empty((nl, nl, 2 if image else 1, len(i), len(j)), complex)
    for lo, zo in enumerate(g.levels):
        for ls, zs in enumerate(g.levels):
            r = np.sqrt(rho ** 2 + (zo - zs) ** 2)
            with np.errstate(divide="ignore", invalid="ignore"):
                table[lo, ls, 0] = np.where(r > 1e-9, np.exp(-1j * k * r) / r, 0.0)
            if image:
                ri = np.sqrt(rho ** 2 + (zo + zs) ** 2)
                table[lo, ls, 1] = np.exp(-1j * k * ri) / ri
    return table


def _reflected_tables(model: FastModel, kernels) -> np.ndarray:
    """The soil's smooth reflected kernels S(R_TE), S(R_q - K_q) on grid offsets,
    [n_lev, n_lev, 2, 2nx-1, 2ny-1]."""
    g = model.grid
    i = np.arange(-(g.nx - 1), g.nx)
    j = np.arange(-(g.ny - 1), g.ny)
    rho = g.h * np.hypot(i[:, None], j[None, :])
    nl = len(g.levels)
    table = np.empty((nl, nl, 2, len(i), len(j)), complex)
    for lo, zo in enumerate(g.levels):
        for ls, zs in enumerate(g.levels):
            table[lo, ls, 0], table[lo, ls, 1] = kernels.lookup(rho, np.full_like(rho, zo + zs))
    return table


def _spectra(model: FastModel, table: np.ndarray) -> np.ndarray:
    """FFTs of offset tables [..., 2nx-1, 2ny-1] by circulant embedding (offset d sits at
    index d mod S), zero-padded to the model's FFT size."""
    import scipy.fft

    g = model.grid
    sx, sy = model.shape
    circ = np.zeros(table.shape[:-2] + (sx, sy), complex)
    ii, jj = np.arange(-(g.nx - 1), g.nx) % sx, np.arange(-(g.ny - 1), g.ny) % sy
    circ[..., ii[:, None], jj[None, :]] = table
    return scipy.fft.fft2(circ, axes=(-2, -1), workers=1)


def grid_moments(model: FastModel, table: np.ndarray, pairs: np.ndarray, n_full: int | None = None) -> np.ndarray:
    """What the grid puts in for triangle pairs: the six moments [C, 6, P] of each kernel
    channel of ``table`` (offsets, as :func:`_offset_tables`) over their 3 x 3 point pairs; the
    channels from ``n_full`` on (a scalar potential's kernel) get S0 alone, the rest left 0."""
    from ._compiled import grid_pair_moments

    g = model.grid
    ix, iy, wx, wy = model.stencils  # [T, 3], [T, 3, 4]
    pts, w = model.points
    return grid_pair_moments(np.ascontiguousarray(table), np.ascontiguousarray(pairs, dtype=np.int64), ix, iy, wx,
                             wy, model.level.astype(np.int64), g.nx, g.ny, pts, w,
                             table.shape[2] if n_full is None else n_full)


def rule_moments(mesh, pairs: np.ndarray, k: float, rule, direct: bool = True, image: bool = False) -> np.ndarray:
    """The fill's product-rule moments of exp(-jkR)/R (direct rows 0-5, then image) for
    triangle pairs, both triangles on ``rule`` (``operators.product_rule``'s sums, compiled)."""
    from ._compiled import rule_moments as compiled

    p, w = quadrature_points(mesh, rule)
    return compiled(p, w, p, w, np.ascontiguousarray(pairs, dtype=np.int64), k, direct, image)


def _rule_points(mesh, near: bool) -> list:
    """(points, weights, sign) of each rule of the soil's reflected terms: the fill's 3 x 3 points, or
    (``near``) the near pairs' correction, 7 x 7 minus 3 x 3 (``operators.reflected_near``'s)."""
    return [(*quadrature_points(mesh, rule), sign) for rule, sign in (((Q7, 1.0), (Q3, -1.0)) if near else ((Q3, 1.0),))]


def _stacked_tables(kernels: list) -> tuple:
    """The soils' tables as the compiled loop reads them: (height sums, [n_zeta, n, S, 4] real, steps, sizes)."""
    zetas = kernels[0].zetas
    if any(not np.array_equal(k.zetas, zetas) for k in kernels):
        raise ValueError("reflected_near: the soils' tables are for different height sums")
    sizes = np.array([k.tables.shape[2] for k in kernels], np.int64)
    tables = np.zeros((len(zetas), int(sizes.max()), len(kernels), 2), complex)  # padded: steps differ by soil
    for i, k in enumerate(kernels):
        tables[:, :sizes[i], i, :] = k.tables.transpose(0, 2, 1)
    return zetas, tables.view(float), np.array([k.step for k in kernels]), sizes  # Re, Im of each kernel


def _reflected_block(rules: list, pairs: np.ndarray, stacked: tuple) -> tuple[np.ndarray, np.ndarray]:
    """Each soil's reflected kernels over triangle pairs, every soil in one pass over the point pairs:
    (six moments of S(R_TE) [S, 6, P], S0 of S(R_q - K_q) [S, P])."""
    from ._compiled import reflected_rule_moments

    n_soils = len(stacked[2])
    out_a = np.zeros((n_soils, 6, len(pairs)), complex)
    out_q = np.zeros((n_soils, len(pairs)), complex)
    pairs = np.ascontiguousarray(pairs, dtype=np.int64)
    for p, w, sign in rules:
        reflected_rule_moments(p, w, p, w, pairs, *stacked, sign, out_a, out_q)
    return out_a, out_q


REFLECTED_BLOCK = 32768  # triangle pairs a block: bounds the moments held for five soils (~10 MB)
SOILS_TOGETHER = True  # a design's soils' reflected near terms in one pass over the point pairs (False: one a pass)
_SOIL_NEAR: dict[tuple[int, float], tuple] = {}


def reflected_near(model: FastModel, terms: "FrequencyTerms", soils: list[tuple[float, float]]) -> list[np.ndarray]:
    """Each soil's reflected kernels' share of the near matrix (CSR values over the model's
    assembly) at the terms' frequency: the precorrection pairs by the fill's 3 x 3 points, the
    image near pairs' 7 x 7 - 3 x 3 corrections. The soils are computed in one pass over the
    point pairs (their geometry is the common cost: ``benchmarks/bench_soil_passes.py``) and
    kept for the design's next soils at that frequency; a soil found kept is handed over
    (and let go)."""
    key = (id(model), float(terms.freq_hz))
    if _SOIL_NEAR.get(key, (None,))[0] is not model:  # the entry holds its model, so its id is never another's
        _SOIL_NEAR.clear()
        _SOIL_NEAR[key] = (model, {})
    kept = _SOIL_NEAR[key][1]
    soils = [(float(e), float(s)) for e, s in soils]
    todo = [s for s in dict.fromkeys(soils) if s not in kept]
    if todo:
        prob = model.prob
        kernels = prob.reflected_kernels_many(terms.freq_hz, todo, FAR_REACH_CELLS * model.grid.h)
        asm, c_q = model.assembly(), 4 * terms.c_phi
        passes = [list(range(len(todo)))] if SOILS_TOGETHER else [[i] for i in range(len(todo))]
        stacked = [_stacked_tables([kernels[i] for i in group]) for group in passes]
        values = [np.zeros(asm.nnz, complex) for _ in todo]
        for which, pairs, near in ((0, model.pairs, False), (2, model.near_pairs(True), True)):
            rules = _rule_points(prob.mesh, near)
            for start in range(0, len(pairs), REFLECTED_BLOCK):
                block = pairs[start:start + REFLECTED_BLOCK]
                for group, tables in zip(passes, stacked):
                    ma, mq = _reflected_block(rules, block, tables)
                    for i, a, q in zip(group, ma, mq):
                        asm.add(values[i], which, a, q, terms.c_a, c_q, start)
        kept.update(zip(todo, values))
    return [kept.pop(s) if len(soils) == 1 else kept[s] for s in soils]


class _BasisAssembler:
    """Each triangle's (up to 3) basis functions, for sparse basis-pair matrices from
    triangle-pair moments: Z_mn = c_m c_n [c_a (Srr - v_n.So - v_m.Ss + v_m.v_n S0) +
    4 c_phi S0q] summed over the pairs of their triangles (the dense fill's gather formula)."""

    def __init__(self, prob: Problem, rows: np.ndarray) -> None:
        mesh, rwg = prob.mesh, prob.rwg
        t = len(mesh.tris)
        area = mesh.areas
        # each triangle's (up to 3) basis functions: index, coefficient, free vertex
        tri = np.concatenate([rwg.plus, rwg.minus])
        fn = np.concatenate([np.arange(rwg.n)] * 2)
        coef = np.concatenate([rwg.length, -rwg.length]) / (2 * area[tri])
        free = mesh.nodes[mesh.tris[tri, np.concatenate([rwg.plus_free, rwg.minus_free])], :2]
        order = np.argsort(tri, kind="stable")
        tri, fn, coef, free = tri[order], fn[order], coef[order], free[order]
        slot = np.arange(len(tri)) - np.searchsorted(tri, tri)
        self.fn = -np.ones((t, 3), int)
        self.coef = np.zeros((t, 3))
        self.free = np.zeros((t, 3, 2))
        self.fn[tri, slot], self.coef[tri, slot], self.free[tri, slot] = fn, coef, free
        row_of = -np.ones(rwg.n, int)
        row_of[rows] = np.arange(len(rows))
        self.row_of = row_of
        self.shape = (len(rows), rwg.n)


class StaticAssembly:
    """The near matrices' sparsity, built once per design: each (triangle pair, basis pair)
    entry's place in a CSR matrix, so each frequency only computes values and adds them in
    place (:func:`_compiled.scatter_values`). Lists: 0 the precorrection pairs, 1 the direct
    near pairs, 2 the image near pairs (the series' order)."""

    def __init__(self, prob: Problem, rows: np.ndarray, pair_lists: list[np.ndarray]) -> None:
        a = _BasisAssembler(prob, rows)
        self.lists = []
        lins, keeps = [], []
        for pairs in pair_lists:
            o, s = pairs[:, 0], pairs[:, 1]
            fo, fs = a.fn[o], a.fn[s]
            r = np.where(fo >= 0, a.row_of[np.maximum(fo, 0)], -1)[:, :, None] + np.zeros((1, 1, 3), int)
            keep = (r >= 0) & (fs[:, None, :] >= 0)
            cc = a.coef[o][:, :, None] * a.coef[s][:, None, :] * keep  # 0 where no entry
            self.lists.append([cc, np.ascontiguousarray(a.free[o]), np.ascontiguousarray(a.free[s])])
            keeps.append(keep)
            lins.append(r[keep].astype(np.int64) * a.shape[1] + np.broadcast_to(fs[:, None, :], keep.shape)[keep])
        uniq, slot = np.unique(np.concatenate(lins), return_inverse=True)
        bounds = np.cumsum([0] + [len(x) for x in lins])
        for i, keep in enumerate(keeps):
            full = -np.ones(keep.shape, np.int64)  # [P, 3, 3]: the entry's place in the CSR data, -1 for none
            full[keep] = slot[bounds[i]:bounds[i + 1]]
            self.lists[i].insert(0, full)
        self.sizes = [len(p) for p in pair_lists]
        self.shape = a.shape
        self.nnz = len(uniq)
        self.indices = (uniq % a.shape[1]).astype(np.int32)
        self.indptr = np.searchsorted(uniq // a.shape[1], np.arange(a.shape[0] + 1)).astype(np.int32)

    def add(self, data: np.ndarray, which: int, ma: np.ndarray | None, mq: np.ndarray | None, c_a: complex,
            c_q: complex, start: int = 0) -> None:
        """Add list ``which``'s basis-pair values of triangle-pair moments (vector ``ma``
        [6, P] times ``c_a``, scalar ``mq`` [P] times ``c_q``; either may be None) into ``data``;
        the moments are of the list's pairs from ``start`` on (a block of them)."""
        from ._compiled import scatter_values

        none = np.zeros(0, complex)
        n = (ma if ma is not None else mq).shape[-1]
        slot, cc, free_o, free_s = (x[start:start + n] for x in self.lists[which])
        scatter_values(data, slot, cc, free_o, free_s, none.reshape(0, 0) if ma is None else np.ascontiguousarray(ma),
                       none if mq is None else np.ascontiguousarray(mq), complex(c_a), complex(c_q))

    def matrix(self, data: np.ndarray) -> sp.csr_matrix:
        return sp.csr_matrix((data, self.indices, self.indptr), shape=self.shape)


class FrequencyTerms:
    """The part of one frequency's fast operator that does not depend on the soil: the direct
    kernel's and its image's grid spectra and their near and grid values in the CSR layout of
    the near matrices (each kernel apart, so every soil of a design, or PEC, weights and adds
    them: :class:`FastOperator`). Over soil the image enters the scalar potential only."""

    def __init__(self, model: FastModel, freq_hz: float) -> None:
        prob = model.prob
        mesh = prob.mesh
        self.freq_hz = freq_hz
        self.k = k = 2 * np.pi * freq_hz / C0
        omega = 2 * np.pi * freq_hz
        self.c_a = c_a = 1j * omega * MU0 / (4 * np.pi)
        self.c_phi = c_phi = -1j / (4 * np.pi * omega * EPS0)
        c_q = 4 * c_phi  # div f = 2c on each triangle
        imaged = prob.ground != "free"
        vector_image = prob.ground == "pec"  # over soil the vector potential's image is the tabulated S(R_TE)
        table = _offset_tables(model, k, imaged)
        self.spectra = _spectra(model, table)  # [nl, nl, 1 or 2, sx, sy]
        grid = grid_moments(model, table, model.pairs, 2 if vector_image else 1)  # [1 or 2, 6, P]
        fill = rule_moments(mesh, model.pairs, k, Q3, True, imaged)  # [6 or 12, P]
        groups = list(model.series(k).moments(k))
        asm = model.assembly()
        nnz = asm.nnz
        self.near = {"direct": np.zeros(nnz, complex)}
        self.grid = {"direct": np.zeros(nnz, complex)}
        asm.add(self.near["direct"], 0, fill[:6], fill[0], c_a, c_q)
        asm.add(self.grid["direct"], 0, grid[0], grid[0, 0], c_a, c_q)
        corr = {img: [acc - rule_moments(mesh, pairs, k, Q3, not img, img) for i, pairs, acc in groups if i == img]
                for img in (False, True)}
        asm.add(self.near["direct"], 1, _joined(corr[False]), _joined(corr[False])[0], c_a, c_q)
        if imaged:
            image_corr = _joined(corr[True])
            self.near["image_q"] = np.zeros(nnz, complex)
            self.grid["image_q"] = np.zeros(nnz, complex)
            asm.add(self.near["image_q"], 0, None, fill[6], 0.0, c_q)
            asm.add(self.near["image_q"], 2, None, image_corr[0], 0.0, c_q)
            asm.add(self.grid["image_q"], 0, None, grid[1, 0], 0.0, c_q)
            if vector_image:
                self.near["image_a"] = np.zeros(nnz, complex)
                self.grid["image_a"] = np.zeros(nnz, complex)
                asm.add(self.near["image_a"], 0, fill[6:], None, c_a, 0.0)
                asm.add(self.near["image_a"], 2, image_corr, None, c_a, 0.0)
                asm.add(self.grid["image_a"], 0, grid[1], None, c_a, 0.0)


def _joined(parts: list[np.ndarray]) -> np.ndarray:
    return np.concatenate(parts, axis=1) if parts else np.zeros((6, 0), complex)


SERIES_TOL = 1e-13  # last term of the smooth part's power series, relative to 1
SERIES_HEADROOM = 1.6  # a series built at k holds to 1.6 k (a worker's later, higher frequencies)
SERIES_FLOOR_HZ = 100e6  # and at least to 100 MHz: one build covers the low band
SERIES_MAX_KR = 200.0  # near pairs span a few wavelengths at most; e^200 is still a finite float


class NearSeries:
    """The engine's accurate near-pair moments (``operators.near_moments``) for every frequency at
    the cost of a few: each is the closed-form 1/R part (static) plus the smooth kernel
    (exp(-jkR) - 1)/R = sum_n (-jk)^n R^(n-1) / n! integrated by the same rules, so the
    moments of R^(n-1) are computed once per design and each frequency is a weighted sum.
    Written here because the per-pair rules are the engine's own (no library has them)."""

    def __init__(self, prob: Problem, obs: np.ndarray, k: float) -> None:
        self.k_max = max(SERIES_HEADROOM * k, 2 * np.pi * SERIES_FLOOR_HZ / C0)
        # over soil the image enters the scalar potential only (vector weight 0): keep S0 alone
        self.scalar_images = prob.ground == "soil"
        mesh = prob.mesh
        cen, size = mesh.centroids, mesh.sizes
        self.groups: list[tuple[bool, np.ndarray, np.ndarray, np.ndarray]] = []  # (image, pairs, sing, terms)
        self.rules: list[tuple[np.ndarray, np.ndarray]] = []  # each group's outer rule
        for img, pairs in zip((False, True), prob.near):
            pairs = pairs[obs[pairs[:, 0]]]
            src = cen[pairs[:, 1]] * (np.array([1, 1, -1]) if img else 1)
            gap = np.linalg.norm(cen[pairs[:, 0]] - src, axis=1)
            close = gap < CLOSE_FACTOR * np.maximum(size[pairs[:, 0]], size[pairs[:, 1]])
            for sel, rule in ((~close, Q7), (close, Q7_TOUCHING)):
                # nearest first, so each block's series is as short as its farthest pair allows
                ordered = pairs[sel][np.argsort(gap[sel], kind="stable")]
                for start in range(0, len(ordered), 20000 if rule is Q7 else 4000):
                    pr = ordered[start:start + (20000 if rule is Q7 else 4000)]
                    sing, terms = self._terms(mesh, pr, img, rule, scalar=img and self.scalar_images)
                    self.groups.append((img, pr, sing, terms))
                    self.rules.append(rule)

    def _n_terms(self, r_max: float) -> int:
        """Terms of the series until x^n / n! < SERIES_TOL, x = k_max R_max."""
        x = self.k_max * r_max
        if not x < SERIES_MAX_KR:  # past it x^n / n! overflows to inf on the way and the loop never ends
            raise ValueError(f"NearSeries: near pairs {r_max:.3g} m apart at k = {self.k_max:.3g} rad/m "
                             f"(k R = {x:.3g}) are beyond the series' reach ({SERIES_MAX_KR:g})")
        n_terms, size = 1, x
        while size > SERIES_TOL:
            n_terms += 1
            size *= x / n_terms
        return n_terms

    def _terms(self, mesh, pairs: np.ndarray, image: bool, rule, scalar: bool) -> tuple[np.ndarray, np.ndarray]:
        """Static singular moments and the series' terms [n_terms, 6 (1 if ``scalar``: S0
        only), n] of one group: the terms of :func:`operators.smooth_moments` of ws R^(n-1), taken
        all at once (the six moments are linear in the kernel samples, so each point pair is
        weighted once by its factors and every power of R is one matrix product), in blocks
        that each stop at their own last term."""
        sing, r, wo, ws, rho, ps = near_geometry(mesh, pairs, image, rule)
        w = wo[:, :, None] * ws[:, None, :]  # [n, Qo, 7]
        if scalar:
            factors = w[..., None]
        else:  # 1, rho, rho . rho', rho' (smooth_moments' order)
            factors = np.stack([w, w * rho[..., 0, None], w * rho[..., 1, None],
                                w * np.einsum("nqk,nik->nqi", rho, ps), w * ps[:, None, :, 0], w * ps[:, None, :, 1]],
                               axis=-1)
        n = len(pairs)
        factors = factors.reshape(n, -1, factors.shape[-1])  # [n, M, F]
        r = r.reshape(n, -1)
        terms = np.zeros((self._n_terms(float(r.max(initial=0.0))), factors.shape[-1], n))
        block = max(1, 2_000_000 // (len(terms) * r.shape[1]))  # ~16 MB of powers
        for lo in range(0, n, block):
            rb = r[lo:lo + block]
            n_terms = self._n_terms(float(rb.max(initial=0.0)))
            powers = np.empty((len(rb), n_terms, rb.shape[1]))
            powers[:, 0] = 1.0
            for m in range(1, n_terms):
                np.multiply(powers[:, m - 1], rb, out=powers[:, m])
            terms[:n_terms, :, lo:lo + block] = np.matmul(powers, factors[lo:lo + block]).transpose(1, 2, 0)
        return (sing[:1] if scalar else sing), terms

    def moments(self, k: float):
        """(image, pairs, accurate moments [6, n]) per group at wavenumber ``k``."""
        if k > self.k_max * (1 + 1e-12):
            raise ValueError("NearSeries: built for a lower frequency")
        for img, pairs, sing, terms in self.groups:
            n = np.arange(1, len(terms) + 1)
            coef = np.cumprod(np.full(len(n), -1j * k) / n)  # (-jk)^n / n!
            moments = sing + np.tensordot(coef, terms, axes=(0, 0))
            if len(moments) == 1:  # scalar-only image group: the vector moments are never used (weight 0)
                moments = np.concatenate([moments, np.zeros((5, moments.shape[1]), complex)])
            yield img, pairs, moments


class FastOperator:
    """Z x at one frequency on one ground (the rows of the solved class) without forming Z:
    the frequency's soil-independent :class:`FrequencyTerms` weighted for the ground (the image
    reversed over PEC, the charge image K_q over soil) plus, over soil, the tabulated reflected
    kernels of ``soil`` (default: the problem's)."""

    def __init__(self, model: FastModel, freq_hz: float, soil: tuple[float, float] | None = None,
                 terms: FrequencyTerms | None = None) -> None:
        prob = model.prob
        self.model = model
        terms = terms if terms is not None and terms.freq_hz == freq_hz else FrequencyTerms(model, freq_hz)
        self.k, self.c_a, self.c_phi = terms.k, terms.c_a, terms.c_phi
        soil = prob.soil if soil is None else soil
        near, grid = terms.near["direct"].copy(), terms.grid["direct"].copy()
        spectra = terms.spectra
        kernel_fft = np.repeat(spectra[:, :, :1], 2, axis=2)  # [nl, nl, 2 (vector, scalar), sx, sy]
        weights = prob.image_weights(freq_hz, soil)
        if weights is not None:
            wa, wq = weights
            near += wq * terms.near["image_q"]
            grid += wq * terms.grid["image_q"]
            kernel_fft[:, :, 1] += wq * spectra[:, :, 1]
            if wa != 0:
                near += wa * terms.near["image_a"]
                grid += wa * terms.grid["image_a"]
                kernel_fft[:, :, 0] += wa * spectra[:, :, 1]
        if prob.ground == "soil":
            g = model.grid
            kernels = prob.reflected_kernels(freq_hz, FAR_REACH_CELLS * g.h, soil)
            table = _reflected_tables(model, kernels)
            kernel_fft += _spectra(model, table)
            asm, c_q = model.assembly(), 4 * self.c_phi
            gm = grid_moments(model, table, model.pairs, 1)  # S(R_q - K_q) enters the scalar potential alone
            asm.add(grid, 0, gm[0], gm[1, 0], self.c_a, c_q)
            near += reflected_near(model, terms, [soil])[0]
        self.kernel_fft = kernel_fft
        asm = model.assembly()
        self.pre, self.near = asm.matrix(near - grid), asm.matrix(near)

    def matvec(self, x: np.ndarray) -> np.ndarray:
        """Z[rows] @ x for a full current vector x [N]."""
        from ._compiled import kernel_products

        m = self.model
        g = m.grid
        pts, w = m.points
        coefficients, testing = m.testing
        alpha, bx, by = (coefficients @ x).reshape(3, -1)
        vals = np.empty(pts.shape[:2] + (3,), complex)  # [T, 3 points, Jx Jy charge], the grid's source columns
        vals[..., 0] = w * (alpha[:, None] * pts[..., 0] + bx[:, None])
        vals[..., 1] = w * (alpha[:, None] * pts[..., 1] + by[:, None])
        vals[..., 2] = w * (2 * alpha[:, None])
        nl = len(g.levels)
        src = np.ascontiguousarray((m.project @ vals.reshape(-1, 3)).T).reshape(3, nl, g.nx, g.ny)
        f = m.spectrum(src)
        pot = np.empty_like(f)
        kernel_products(self.kernel_fft, f, pot)
        pot = m.potentials(pot).reshape(3, -1)
        ax, ay, phi = (m.project_t @ pot.T).T.reshape((3,) + pts.shape[:2])
        t0 = (w * (ax * pts[..., 0] + ay * pts[..., 1])).sum(axis=1)
        t1x, t1y = (w * ax).sum(axis=1), (w * ay).sum(axis=1)
        t2 = (w * phi).sum(axis=1)
        y = testing @ np.concatenate([self.c_a * t0 + 2 * self.c_phi * t2, -self.c_a * t1x, -self.c_a * t1y])
        return y + self.pre @ x


@dataclass
class FastStats:
    """How a fast solve went (recorded per frequency)."""

    iterations: int
    residual: float
    mirrored: bool  # solved in the mirror class (MirrorSymmetry): the currents have its symmetry


_TERMS: dict[tuple[int, float], tuple] = {}


def frequency_terms(model: FastModel, freq_hz: float) -> FrequencyTerms:
    """The model's soil-independent terms at ``freq_hz``, kept for the next solve at the same
    frequency in this process (the other soils of a scenario set; one frequency kept)."""
    key = (id(model), float(freq_hz))
    if _TERMS.get(key, (None,))[0] is not model:  # the entry holds its model, so its id is never another's
        _TERMS.clear()
        _TERMS[key] = (model, FrequencyTerms(model, freq_hz))
    return _TERMS[key][1]


SHARE_PRECONDITIONER = True  # the soils of one design at one frequency share one near-matrix LU
WARM_START = True  # a soil's GMRES starts from the previous soil's currents of the design at that frequency
# ... and the first soil at a frequency from the design's last currents at a neighbouring one (within
# WARM_START_SPAN relative): 17-21 % fewer GMRES iterations, no wall time resolved on a loaded machine
# (benchmarks/bench_warm_frequencies.py: 0.96-1.03x; docs/speed.md, fifth pass)
WARM_START_ACROSS_FREQUENCIES = True
WARM_START_SPAN = 0.1
# The near matrix is structurally symmetric (its pairs are), so a minimum-degree order on A^T + A
# fills less than SuperLU's default COLAMD (sawtooth-20-16 at 0.7 m: 0.74 vs 0.88 M, factor 2.2x faster)
LU_ORDERING = "MMD_AT_PLUS_A"
_LU: dict[tuple[int, float], tuple] = {}
_START: dict[tuple[int, float], tuple] = {}


def near_lu(model: FastModel, op: FastOperator, freq_hz: float):
    """The LU of the near matrix (GMRES's preconditioner), kept for the design's next soil at the
    same frequency: its near matrix differs only in the soil's terms, so it preconditions as well
    (GMRES still solves each soil's own operator to ``GMRES_RTOL``). The factorisation was 84 % of
    a search candidate's time on five soils (``benchmarks/profile_candidate.py``)."""
    import scipy.sparse.linalg as spla
    from threadpoolctl import threadpool_limits

    key = (id(model), float(freq_hz))
    if not SHARE_PRECONDITIONER or _LU.get(key, (None,))[0] is not model:  # the entry holds its model: no id reused
        _LU.clear()
        # one BLAS thread: SuperLU's supernodes are small, and two OpenBLAS threads beside other work spin (measured
        # on sawtooth-20-16 at 0.7 m with a search running: 0.6-15 s a factorisation, 0.2 s on one thread)
        with threadpool_limits(1):
            _LU[key] = (model, spla.splu((op.near @ model.u).tocsc(), permc_spec=LU_ORDERING))
    return _LU[key][1]


def warm_start(model: FastModel, freq_hz: float, a: np.ndarray | None = None) -> np.ndarray | None:
    """The last solved unknowns of ``model`` in this process, as GMRES's start at ``freq_hz``: the
    design's previous soil at this frequency (its currents differ from the next soil's by the
    soil's small share of the fields), else the design's last frequency within ``WARM_START_SPAN``
    (a worker's previous one: the currents move smoothly with frequency), else None (from zero);
    with ``a``, keep those instead. One entry, like the LU."""
    if a is not None:
        _START.clear()
        _START[(id(model), float(freq_hz))] = (model, a)
        return a
    if not WARM_START or not _START:
        return None
    (_, f_last), (owner, last) = next(iter(_START.items()))
    if owner is not model:  # the entry holds its model, so its id is never another's
        return None
    if f_last == float(freq_hz):
        return last
    near = abs(f_last - freq_hz) <= WARM_START_SPAN * freq_hz
    return last if WARM_START_ACROSS_FREQUENCIES and near else None


def solve_fast(prob: Problem, freq_hz: float, symmetric: bool) -> tuple[Solution, FastStats]:
    """Currents for a 1 V delta gap, by GMRES on the pFFT operator (see the module doc)."""
    import scipy.sparse.linalg as spla

    if len(prob.rwg.feed) == 0:
        raise ValueError("surface engine: the mesh has no feed edges")
    model = fast_model(prob, symmetric)
    op = FastOperator(model, freq_hz, prob.soil, frequency_terms(model, freq_hz))
    sign = feed_signs(prob)
    v = np.zeros(prob.n, dtype=complex)
    v[prob.rwg.feed] = sign * prob.rwg.length[prob.rwg.feed] * prob.mesh.feed_volts
    u = model.u
    n = u.shape[1]
    vr = v[model.rows]
    lu = near_lu(model, op, freq_hz)
    a_op = spla.LinearOperator((n, n), matvec=lambda a: op.matvec(u @ a), dtype=complex)
    m_op = spla.LinearOperator((n, n), matvec=lu.solve, dtype=complex)
    count = [0]

    def tick(_: np.ndarray) -> None:
        count[0] += 1

    a, info = spla.gmres(a_op, vr, x0=warm_start(model, freq_hz), M=m_op, rtol=GMRES_RTOL, atol=0.0,
                         restart=GMRES_RESTART, maxiter=10, callback=tick, callback_type="pr_norm")
    residual = float(np.linalg.norm(a_op.matvec(a) - vr) / np.linalg.norm(vr))
    if info != 0 or not np.isfinite(residual) or residual > 10 * GMRES_RTOL:
        raise ArithmeticError(f"surface engine (fast): GMRES did not converge at {freq_hz / 1e6:g} MHz "
                              f"({count[0]} iterations, relative residual {residual:.1e}); "
                              "try --method dense")
    warm_start(model, freq_hz, a)
    i = u @ a
    i_in = complex(np.sum(sign * prob.rwg.length[prob.rwg.feed] * i[prob.rwg.feed]))
    return Solution(freq_hz, i, i_in, prob.mesh.feed_volts), FastStats(count[0], residual, model.symmetry is not None)
