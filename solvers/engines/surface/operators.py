"""The operators: the mixed-potential EFIE's kernels over a ground (free space, the PEC image,
the soil's quasi-static image and tabulated Sommerfeld parts) and their integrals over
triangle pairs: 3-point product rules for distant pairs, closed-form 1/R and 7-point (or
subdivided) rules for near ones. :class:`Problem` is one boundary-value problem: grid, space,
ground and near-pair lists. The assemblers (``dense.py``, ``pfft.py``) turn these into Z."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .grid import Q3, Q7, Q7_TOUCHING, TriMesh, quadrature_points
from .halfspace import ReflectedKernels, charge_image, soil_permittivity
from .space import Rwg, rwg_coefficients

CLOSE_FACTOR = 1.0  # pairs whose centroids are closer than this times the larger triangle use it


def smooth_kernel(r: np.ndarray, k: float) -> np.ndarray:
    """(exp(-jkR) - 1)/R without cancellation at small kR (its limit at R = 0 is -jk)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        out = (-2.0 * np.sin(0.5 * k * r) ** 2 - 1j * np.sin(k * r)) / r
    return np.where(r > 1e-12, out, -1j * k)


def kernel(r: np.ndarray, k: float) -> np.ndarray:
    """exp(-jkR)/R, with 0 where R ~ 0 (a self pair's coincident points: the near-pair
    correction subtracts exactly this rule, so the value there never reaches Z; a value
    of 1e17 there would, by cancellation, wipe out the self term)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(r > 1e-9, np.exp(-1j * k * r) / r, 0.0)


def product_rule(po: np.ndarray, wo: np.ndarray, ps: np.ndarray, ws: np.ndarray, zs: np.ndarray,
                  k: float) -> np.ndarray:
    """Moments [6, ...] of G by the product of two point rules, for triangle pairs laid out
    on any broadcastable leading shape (every pair of a block, or a list of pairs):
    points ``po`` [..., Qo, 3] / ``ps`` [..., Qs, 3], weights ``wo``/``ws`` (area included),
    source level ``zs`` [...] (negated for an image). Returns S0 = sum w w' G, the
    observation first moments Sx, Sy, Srr = sum w w' G (rho . rho'), and the source first
    moments Sx', Sy'. The dense fill and the near-pair correction both use this, so the
    correction subtracts exactly what the fill put in."""
    d = po[..., :, None, :2] - ps[..., None, :, :2]
    dz = po[..., :, None, 2] - zs[..., None, None]
    r = np.sqrt(np.einsum("...k,...k->...", d, d) + dz ** 2)
    return pair_moments(kernel(r, k) * wo[..., :, None] * ws[..., None, :], po, ps)


def pair_moments(g: np.ndarray, po: np.ndarray, ps: np.ndarray) -> np.ndarray:
    """The six pair moments [6, ...] of weighted kernel values ``g`` [..., Qo, Qs]."""
    so = np.einsum("...i,...ik->k...", g.sum(axis=-1), po[..., :2])
    ss = np.einsum("...j,...jk->k...", g.sum(axis=-2), ps[..., :2])
    srr = np.einsum("...ik,...ik->...", np.einsum("...ij,...jk->...ik", g, ps[..., :2]), po[..., :2])
    return np.stack([g.sum(axis=(-1, -2)), so[0], so[1], srr, ss[0], ss[1]])


def reflected_rule(po: np.ndarray, wo: np.ndarray, ps: np.ndarray, ws: np.ndarray, zs: np.ndarray,
                    kernels: ReflectedKernels) -> tuple[np.ndarray, np.ndarray]:
    """The soil's smooth reflected kernels by a product rule (shapes as ``product_rule``):
    the six moments of S(R_TE) (vector potential) and S0 of S(R_q - K_q) (scalar)."""
    d = po[..., :, None, :2] - ps[..., None, :, :2]
    rho = np.sqrt(np.einsum("...k,...k->...", d, d))
    zeta = po[..., :, None, 2] + zs[..., None, None]
    ga, gq = kernels.lookup(rho, zeta)
    w = wo[..., :, None] * ws[..., None, :]
    return pair_moments(ga * w, po, ps), (gq * w).sum(axis=(-1, -2))


def block_moments(po: np.ndarray, wo: np.ndarray, ps: np.ndarray, ws: np.ndarray, zs: np.ndarray, k: float,
                   weights: tuple | None, kernels: ReflectedKernels | None) -> tuple[np.ndarray, np.ndarray]:
    """The fill's 3-point moments of a block, every kernel summed before the moments are
    taken (one set of moments, not one per kernel): the six of the vector potential's
    kernel (direct + image weight x image + soil's S(R_TE)) and S0 of the scalar
    potential's (direct + its image weight x image + S(R_q - K_q)). The same sums as
    ``product_rule`` and ``reflected_rule`` term by term, which the near-pair corrections
    subtract."""
    d = po[..., :, None, :2] - ps[..., None, :, :2]
    rho2 = np.einsum("...k,...k->...", d, d)
    zo = po[..., :, None, 2]
    w = wo[..., :, None] * ws[..., None, :]
    g_dir = kernel(np.sqrt(rho2 + (zo - zs[..., None, None]) ** 2), k) * w
    g_a, g_q = g_dir, g_dir
    if weights is not None:
        zeta = zo + zs[..., None, None]
        g_img = kernel(np.sqrt(rho2 + zeta ** 2), k) * w
        g_a = g_a + weights[0] * g_img if weights[0] != 0 else g_a
        g_q = g_q + weights[1] * g_img
        if kernels is not None:
            ga, gq = kernels.lookup(np.sqrt(rho2), zeta)
            g_a = g_a + ga * w
            g_q = g_q + gq * w
    return pair_moments(g_a, po, ps), g_q.sum(axis=(-1, -2))


def potential_integrals(rho: np.ndarray, d: np.ndarray, verts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form integrals over flat triangles of 1/R and (rho' - rho)/R (Wilton et al.
    1984), for observation points with in-plane position ``rho`` [..., 2] at height ``d``
    [...] above the plane of triangles ``verts`` [..., 3, 2] (any orientation).

    Returns (I [...], J [..., 2]): I = int 1/R dS', J = int (rho' - rho)/R dS'."""
    v = verts
    orient = np.sign((v[..., 1, 0] - v[..., 0, 0]) * (v[..., 2, 1] - v[..., 0, 1])
                     - (v[..., 1, 1] - v[..., 0, 1]) * (v[..., 2, 0] - v[..., 0, 0]))
    ad = np.abs(d)
    total_i = np.zeros(np.broadcast_shapes(rho.shape[:-1], d.shape), dtype=float)
    total_j = np.zeros(total_i.shape + (2,))
    for a, b in ((0, 1), (1, 2), (2, 0)):
        pa, pb = v[..., a, :], v[..., b, :]
        edge = pb - pa
        ell = np.linalg.norm(edge, axis=-1)
        lhat = edge / ell[..., None]
        uhat = orient[..., None] * np.stack([lhat[..., 1], -lhat[..., 0]], axis=-1)  # outward in-plane normal
        ra, rb = pa - rho, pb - rho
        t0 = np.einsum("...k,...k->...", ra, uhat)
        lm = np.einsum("...k,...k->...", ra, lhat)
        lp = np.einsum("...k,...k->...", rb, lhat)
        r0sq = t0 ** 2 + d ** 2
        rm = np.sqrt(lm ** 2 + r0sq)
        rp = np.sqrt(lp ** 2 + r0sq)
        with np.errstate(divide="ignore", invalid="ignore"):
            # R + l, written as R0^2 / (R - l) where l < 0 so it never cancels
            fp = np.where(lp >= 0, rp + lp, r0sq / (rp - lp))
            fm = np.where(lm >= 0, rm + lm, r0sq / (rm - lm))
            log = np.where(r0sq > 1e-24, np.log(fp) - np.log(fm), 0.0)
            atn = np.where(ad > 0, np.arctan2(t0 * lp, r0sq + ad * rp) - np.arctan2(t0 * lm, r0sq + ad * rm), 0.0)
        total_i += t0 * log - ad * atn
        total_j += 0.5 * uhat * (r0sq * log + lp * rp - lm * rm)[..., None]
    return total_i, total_j


def sorted_unique(keys: np.ndarray) -> np.ndarray:
    """``np.unique(keys)`` of an integer array by a sort and a neighbour test: numpy 2.3+ takes a
    hash table for a values-only unique, 9x slower on the near lists' millions of int64 keys
    (sawtooth-20-16 at 0.5 m: 0.91 s against 0.10 s; ``benchmarks/bench_near_pairs.py``)."""
    keys = np.sort(keys)
    return keys[np.concatenate([[True], keys[1:] != keys[:-1]])] if len(keys) else keys


REACH_CLASSES = 2.0  # triangles are searched in classes of reach within this factor of each other


def _within_reach(a: np.ndarray, b: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """Index pairs (i, j) with |a_i - b_j| <= reach_i (a superset for small i-classes: each class
    of similar reach is searched with its largest), by one KD-tree query per class. Written here
    because scipy's trees take one radius per query, not one per point."""
    tree_b = cKDTree(b)
    cls = np.floor(np.log(reach / reach.min()) / np.log(REACH_CLASSES)).astype(int)
    out = [np.zeros((0, 2), dtype=np.int64)]
    for c in np.unique(cls):
        idx = np.flatnonzero(cls == c)
        hits = cKDTree(a[idx]).sparse_distance_matrix(tree_b, float(reach[idx].max()), output_type="ndarray")
        out.append(np.stack([idx[hits["i"]], hits["j"]], axis=1))
    return np.concatenate(out)


@dataclass
class Problem:
    """A mesh ready to solve: basis, coefficients, and the near-pair lists. ``soil`` is
    (eps_r, sigma S/m) for ``ground="soil"`` (see ``halfspace.py``)."""

    mesh: TriMesh
    rwg: Rwg
    ground: str  # "pec" | "free" | "soil"
    near_factor: float = 2.5
    soil: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        if self.ground not in ("pec", "free", "soil"):
            raise ValueError(f"surface engine: ground must be 'pec', 'soil' or 'free', got {self.ground!r}")
        if self.ground == "soil" and self.soil is None:
            raise ValueError("surface engine: ground 'soil' needs soil=(eps_r, sigma)")
        if self.ground != "free" and np.any(self.mesh.nodes[:, 2] <= 0):
            raise ValueError(f"surface engine: over {self.ground} every triangle must be above z = 0")
        self.c1, self.cv = rwg_coefficients(self.mesh, self.rwg)
        cen, size = self.mesh.centroids, self.mesh.sizes
        self.near = [self._near_pairs(cen, size, img) for img in ((False,) if self.ground == "free" else (False, True))]

    def _near_pairs(self, cen: np.ndarray, size: np.ndarray, image: bool) -> np.ndarray:
        """(observer, source) triangle pairs closer than ``near_factor`` times the larger of the two
        sizes (source centroids mirrored below z = 0 for the image), in sorted order. Each triangle
        searches only its own reach, so the work and memory follow the pairs kept: one search radius
        for all (the largest triangle's) had made a plane of millimetre triangles beside metre ones
        (a 1.4 mm neck a search proposed: 60 608 triangles) ask for billions of pairs and the
        process be killed for memory before any check could refuse it."""
        src = cen * np.array([1, 1, -1]) if image else cen
        reach = self.near_factor * size
        n = len(cen)
        by_obs, by_src = _within_reach(cen, src, reach), _within_reach(src, cen, reach)
        key = sorted_unique(np.concatenate([by_obs[:, 0] * n + by_obs[:, 1], by_src[:, 1] * n + by_src[:, 0]]))
        o, s = key // n, key % n
        pairs = np.stack([o, s], axis=1)
        keep = np.linalg.norm(cen[o] - src[s], axis=1) < np.maximum(reach[o], reach[s])
        if not image:  # a triangle with itself (distance 0) is always a pair
            keep |= o == s
        return pairs[keep]

    @property
    def n(self) -> int:
        return self.rwg.n

    def image_weights(self, freq_hz: float, soil: tuple[float, float] | None = None
                      ) -> tuple[float | complex, float | complex] | None:
        """Weights (vector, scalar potential) of the image kernel exp(-jkR')/R': the
        reversed current over PEC (-1, -1); over soil (``soil``, default the problem's) only
        the quasi-static charge image (0, K_q), the rest being the tabulated reflected
        kernels; None in free space."""
        if self.ground == "pec":
            return -1.0, -1.0
        if self.ground == "soil":
            return 0.0, charge_image(soil_permittivity(*(soil or self.soil), freq_hz))
        return None

    def reflected_kernels(self, freq_hz: float, reach: float = 0.0,
                          soil: tuple[float, float] | None = None) -> ReflectedKernels | None:
        """The soil's (``soil``, default the problem's) smooth reflected kernels for this mesh's
        height sums, or None; tabulated to the mesh's diagonal plus ``reach`` (m; the fast
        solve's grid extends past the metal)."""
        if self.ground != "soil":
            return None
        return self.reflected_kernels_many(freq_hz, [soil or self.soil], reach)[0]

    def reflected_kernels_many(self, freq_hz: float, soils: list[tuple[float, float]],
                               reach: float = 0.0) -> list[ReflectedKernels]:
        """:meth:`reflected_kernels` of several soils, built together (and kept)."""
        levels = np.unique(np.round(self.mesh.nodes[:, 2], 9))
        zetas = (levels[:, None] + levels[None, :]).ravel()
        xy = self.mesh.nodes[:, :2]
        rho_max = float(np.hypot(*(xy.max(axis=0) - xy.min(axis=0)))) + 0.1 + reach
        return ReflectedKernels.cached_many(freq_hz, soils, zetas, rho_max)


def near_moments(mesh: TriMesh, pairs: np.ndarray, k: float, image: bool) -> np.ndarray:
    """Accurate moments [6, n_pairs] of G (direct or image) for near pairs (obs, src).

    Close pairs (centroids nearer than ``CLOSE_FACTOR`` times the larger triangle: the same,
    touching or nearly touching triangles) see an inner integral with a logarithmic edge
    singularity, which the 7-point outer rule integrates poorly on skewed triangles (Z lost
    its symmetry by up to 4 % on a Triangle mesh): their outer rule is the 7-point rule on
    16 sub-triangles."""
    out = np.empty((6, len(pairs)), dtype=complex)
    cen, size = mesh.centroids, mesh.sizes
    src = cen[pairs[:, 1]] * (np.array([1, 1, -1]) if image else 1)
    gap = np.linalg.norm(cen[pairs[:, 0]] - src, axis=1)
    close = gap < CLOSE_FACTOR * np.maximum(size[pairs[:, 0]], size[pairs[:, 1]])
    for sel, rule in ((~close, Q7), (close, Q7_TOUCHING)):
        if sel.any():
            out[:, sel] = near_moments_rule(mesh, pairs[sel], k, image, rule)
    return out


def near_moments_rule(mesh: TriMesh, pairs: np.ndarray, k: float, image: bool,
                      outer: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """Near pairs' accurate moments [6, n] with the outer rule ``outer``: closed-form 1/R plus the smooth rest."""
    sing, r, wo, ws, rho, ps = near_geometry(mesh, pairs, image, outer)
    return sing + smooth_moments(smooth_kernel(r, k) * ws[:, None, :], wo, rho, ps)


def near_geometry(mesh: TriMesh, pairs: np.ndarray, image: bool, outer: tuple[np.ndarray, np.ndarray]) -> tuple:
    """The frequency-independent part of near pairs' accurate moments: the six moments [6, n]
    of the closed-form 1/R integrals, and the point geometry the smooth part is integrated
    on (distances r [n, Qo, 7], outer weights [n, Qo], inner weights [n, 7], outer and inner
    in-plane points [n, Qo, 2], [n, 7, 2])."""
    o, s = pairs[:, 0], pairs[:, 1]
    bary, w = outer
    po = np.einsum("qk,tkd->tqd", bary, mesh.nodes[mesh.tris[o]])
    po[..., 2] = mesh.nodes[mesh.tris[o, 0], 2][:, None]
    wo = w[None, :] * mesh.areas[o][:, None]
    ps, ws = quadrature_points(mesh, Q7)
    ps, ws = ps[s], ws[s]
    zs = mesh.nodes[mesh.tris[s, 0], 2] * (-1 if image else 1)
    verts = mesh.nodes[mesh.tris[s]][..., :2]  # [n, 3, 2]
    rho = po[..., :2]
    d = po[..., 2] - zs[:, None]
    i_sing, j_sing = potential_integrals(rho, d, verts[:, None])  # [n, Qo], [n, Qo, 2]
    diff = po[:, :, None, :2] - ps[:, None, :, :2]
    r = np.sqrt(np.einsum("...k,...k->...", diff, diff) + d[..., None] ** 2)  # [n, Qo, 7]
    i1 = rho * i_sing[..., None] + j_sing
    sing = np.stack([np.einsum("ni,ni->n", wo, i_sing), *np.einsum("ni,nik->kn", wo * i_sing, rho),
                     np.einsum("ni,nik,nik->n", wo, rho, i1), *np.einsum("ni,nik->kn", wo, i1)])
    return sing, r, wo, ws, rho, ps[..., :2]


def smooth_moments(gs: np.ndarray, wo: np.ndarray, rho: np.ndarray, ps: np.ndarray) -> np.ndarray:
    """The six moments [6, n] of a smooth kernel given at the near pairs' points, times the
    inner weights (``gs`` [n, Qo, 7]), by the outer rule."""
    i0 = gs.sum(axis=2)
    i1 = gs @ ps  # int rho' G, [n, Qo, 2]
    wi0 = wo * i0
    wi1 = wo[..., None] * i1
    return np.stack([wi0.sum(axis=1), *(wi0[..., None] * rho).sum(axis=1).T, (rho * wi1).sum(axis=(1, 2)),
                     *wi1.sum(axis=1).T])


def far_rule_pairs(mesh: TriMesh, pairs: np.ndarray, k: float, image: bool) -> np.ndarray:
    """The 3-point product-rule moments [6, n_pairs] of the same pairs (to be replaced)."""
    o, s = pairs[:, 0], pairs[:, 1]
    p, w = quadrature_points(mesh, Q3)
    zs = mesh.nodes[mesh.tris[s, 0], 2] * (-1 if image else 1)
    return product_rule(p[o], w[o], p[s], w[s], zs, k)


def reflected_near(mesh: TriMesh, pairs: np.ndarray, kernels: ReflectedKernels) -> tuple[np.ndarray, np.ndarray]:
    """Near pairs' soil-reflected moments by 7 x 7 points minus the fill's 3 x 3 (the kernels
    are smooth, but vary on the scale of the soil wavelength, about a plate cell)."""
    o, s = pairs[:, 0], pairs[:, 1]
    zs = mesh.nodes[mesh.tris[s, 0], 2]
    (p7, w7), (p3, w3) = quadrature_points(mesh, Q7), quadrature_points(mesh, Q3)
    acc_a, acc_q = reflected_rule(p7[o], w7[o], p7[s], w7[s], zs, kernels)
    far_a, far_q = reflected_rule(p3[o], w3[o], p3[s], w3[s], zs, kernels)
    return acc_a - far_a, acc_q - far_q


def near_groups(prob: Problem, k: float, obs: np.ndarray):
    """(image, pairs, accurate moments [6, n]) of the near pairs whose observation triangle is
    in ``obs`` (a mask), in chunks: direct, then image."""
    for img, pairs in zip((False, True), prob.near):
        pairs = pairs[obs[pairs[:, 0]]]
        for start in range(0, len(pairs), 20000):
            pr = pairs[start:start + 20000]
            yield img, pr, near_moments(prob.mesh, pr, k, img)


def near_corrections(prob: Problem, k: float, obs: np.ndarray | None, weights: tuple | None,
                      kernels: ReflectedKernels | None, groups=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(pairs [n, 2], vector-potential corrections [6, n], scalar corrections [n]): accurate
    minus fill moments of the near pairs whose observation triangle is in ``obs`` (a mask):
    direct, image (with its ``weights``) and, over soil, the reflected kernels. ``groups``
    gives the accurate moments another way (the fast solve's series), as :func:`near_groups`."""
    all_pairs, all_a, all_q = [], [], []
    for img, pr, accurate in (near_groups(prob, k, obs) if groups is None else groups):
        wa, wq = weights if img else (1.0, 1.0)
        diff = accurate - far_rule_pairs(prob.mesh, pr, k, img)
        all_pairs.append(pr)
        all_a.append(wa * diff)
        all_q.append(wq * diff[0])
        if img and kernels is not None:
            ca, cq = reflected_near(prob.mesh, pr, kernels)
            all_pairs.append(pr)
            all_a.append(ca)
            all_q.append(cq)
    if not all_pairs:
        return np.zeros((0, 2), int), np.zeros((6, 0), complex), np.zeros(0, complex)
    return np.concatenate(all_pairs), np.concatenate(all_a, axis=1), np.concatenate(all_q)
