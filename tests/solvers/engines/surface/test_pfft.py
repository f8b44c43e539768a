"""The fast (precorrected-FFT) solve against the dense reference, piece by piece."""
import numpy as np
import pytest

from groundplane.design import Design, InfinitePEC, Soil
from groundplane.shapes import PRESETS
from solvers.engines.surface import pfft
from solvers.engines.surface.dense import impedance_matrix, solve
from solvers.engines.surface.farfield import gain_pattern
from solvers.engines.surface.grid import Q7, Q7_TOUCHING
from solvers.engines.surface.halfspace import C0, reflected_integrals, soil_permittivity
from solvers.engines.surface.mesh import SurfaceSettings, build_mesh
from solvers.engines.surface.operators import Problem, near_moments_rule
from solvers.engines.surface.space import MirrorSymmetry, rwg_basis


def _problem(ground: str, spacing: float = 1.5) -> Problem:
    design = Design(PRESETS["square-10"], Soil() if ground == "soil" else InfinitePEC())
    settings = SurfaceSettings(spacing=spacing, blade_cells=(6, 4), plate_height=0.005 if ground == "soil" else 0.05)
    mesh = build_mesh(design, settings)
    soil = (design.ground.eps_r, design.ground.sigma) if ground == "soil" else None
    return Problem(mesh, rwg_basis(mesh), ground, settings.near_factor, soil)


@pytest.mark.parametrize("ground", ["pec", "soil"])
def test_fast_matvec_is_the_dense_matrix(ground):
    """Z x by grid + precorrection against the dense fill's rows, for a random current: the
    grid's error on the far pairs is small against |Z||x| (the near pairs are exact)."""
    prob = _problem(ground)
    model = pfft.build_fast_model(prob, None)
    op = pfft.FastOperator(model, 70e6)
    z = impedance_matrix(prob, 70e6)
    x = np.random.default_rng(1).normal(size=prob.n) + 1j * np.random.default_rng(2).normal(size=prob.n)
    err = np.abs(op.matvec(x) - z @ x).max() / (np.abs(z).max() * np.abs(x).max())
    assert err < 2e-4
    # the preconditioner is the fill's own near matrix: Z where every triangle pair of two basis
    # functions is near (the diagonal among them; an entry at the list's edge holds only some)
    near = op.near.tocoo()
    assert np.allclose(op.near.diagonal(), np.diag(z), rtol=1e-9)
    held = {(int(o), int(s)) for o, s in model.pairs}
    rwg = prob.rwg
    whole = np.array([all((int(to), int(ts)) in held for to in (rwg.plus[m], rwg.minus[m])
                          for ts in (rwg.plus[n], rwg.minus[n])) for m, n in zip(near.row, near.col)])
    assert whole.mean() > 0.5
    assert np.allclose(near.data[whole], z[near.row, near.col][whole], rtol=1e-9, atol=1e-12 * np.abs(z).max())


@pytest.mark.parametrize("ground", ["pec", "soil"])
def test_fast_solve_gives_the_dense_beam(ground):
    prob = _problem(ground)
    sym = MirrorSymmetry.of(prob.mesh, prob.rwg)
    dense = solve(prob, 80e6, sym)
    fast, stats = pfft.solve_fast(prob, 80e6, symmetric=True)
    assert stats.residual < 1e-4 and stats.iterations > 1
    th = np.arange(0.0, 81.0, 5.0)
    gd, gf = gain_pattern(prob, dense, th, th), gain_pattern(prob, fast, th, th)
    assert np.sqrt(np.mean((10 * np.log10(gf / gd)) ** 2)) < 2e-3
    assert abs(fast.input_impedance - dense.input_impedance) < 0.05


def test_near_series_is_the_engines_near_moments_at_any_frequency():
    """The power series in k of the smooth part reproduces the per-frequency integration."""
    prob = _problem("soil")
    obs = np.ones(len(prob.mesh.tris), bool)
    series = pfft.NearSeries(prob, obs, 2 * np.pi * 50e6 / C0)
    for f in (40e6, 75e6, 100e6):
        k = 2 * np.pi * f / C0
        assert {id(r) for r in series.rules} == {id(Q7), id(Q7_TOUCHING)}
        for (img, pairs, got), (_, _, sing, _), rule in zip(series.moments(k), series.groups, series.rules):
            want = near_moments_rule(prob.mesh, pairs, k, img, rule)
            rows = len(sing)  # scalar-only image groups over soil keep S0 alone
            assert np.allclose(got[:rows], want[:rows], rtol=1e-10, atol=1e-13 * np.abs(want).max())
    with pytest.raises(ValueError, match="lower frequency"):
        next(series.moments(2 * series.k_max))


def test_split_sommerfeld_tables_match_the_full_spectral_rule():
    """The spectral tail integrated to 2 m only: within 1e-6 of the full rule (plate height
    sum 1 cm, where the tail is longest) and 10x faster is what the split is for."""
    f = 40e6
    k0, eps = 2 * np.pi * f / C0, soil_permittivity(3.5, 0.02, f)
    rho = np.concatenate([np.arange(0.0, 0.06, 0.005), np.arange(0.1, 12.0, 0.37)])
    a0, q0 = reflected_integrals(rho, k0, eps, 0.01, split=False)
    a1, q1 = reflected_integrals(rho, k0, eps, 0.01)
    assert np.abs(a1 - a0).max() < 1e-6 * np.abs(a0).max()
    assert np.abs(q1 - q0).max() < 1e-6 * np.abs(q0).max()


def test_solver_method_is_a_setting_recorded_in_the_beam(tmp_path, monkeypatch):
    from solvers.engines.surface import SurfaceSolver

    monkeypatch.setenv("GROUNDPLANE_CACHE", str(tmp_path))
    design = Design(PRESETS["square-10"], Soil())
    freqs = [60.0, 70.0]  # 2 m: above the mesh rule's floor (2 cells per wavelength) to 75 MHz
    beams = {}
    for method in ("dense", "fast"):
        settings = SurfaceSettings(spacing=2.0, blade_cells=(4, 4), method=method)
        solver = SurfaceSolver(settings, workers=0)
        beams[method] = solver.solve(design, freqs)
        assert beams[method].meta["mesh"]["method"] == method
    assert beams["dense"].meta["cache_key"] != beams["fast"].meta["cache_key"]
    assert len(beams["fast"].meta["gmres_iterations"]) == 2
    up = beams["fast"].theta_deg <= 80
    assert np.abs(10 * np.log10(beams["fast"].gain[:, up] / beams["dense"].gain[:, up])).max() < 5e-3
    with pytest.raises(Exception, match="method"):
        SurfaceSettings(method="fmm")


def test_far_field_from_the_first_quadrant_is_the_whole_far_field():
    """Currents solved in the mirror class give the same pattern from a quarter of the points."""
    prob = _problem("soil")
    sol, stats = pfft.solve_fast(prob, 70e6, symmetric=True)
    assert stats.mirrored
    th = np.arange(0.0, 88.0, 3.0)
    full = gain_pattern(prob, sol, th, th)
    quarter = gain_pattern(prob, sol, th, th, mirrored_currents=True)
    assert np.allclose(quarter, full, rtol=1e-10)


def test_far_field_moments_by_nufft_are_the_direct_sum():
    """``horizontal_moments`` (a type-3 NUFFT) against the sum it stands for, written out with
    numpy: every point's exp(j (kx x + ky y)) on two metal levels, plain and as four mirror images."""
    from solvers.engines.surface.farfield import horizontal_moments

    rng = np.random.default_rng(7)
    n = 400
    p = np.c_[rng.uniform(0.01, 15.0, n), rng.uniform(0.01, 15.0, n), rng.choice([0.005, 0.05], n)]
    jw = rng.standard_normal((n, 2)) + 1j * rng.standard_normal((n, 2))
    levels, level = np.unique(p[:, 2], return_inverse=True)
    th, ph = np.meshgrid(np.radians(np.arange(0.0, 91.0, 7.0)), np.radians(np.arange(0.0, 360.0, 11.0)), indexing="ij")
    k = 2 * np.pi * 97e6 / 299792458.0
    kx, ky = k * (np.sin(th) * np.cos(ph)).ravel(), k * (np.sin(th) * np.sin(ph)).ravel()
    want = np.zeros((len(kx), 2, 2), complex)
    for sx, sy in ((1, 1), (-1, 1), (1, -1), (-1, -1)):
        e = np.exp(1j * (np.outer(kx, sx * p[:, 0]) + np.outer(ky, sy * p[:, 1])))  # [D, P]
        for at in range(2):
            on = level == at
            want[:, at, 0] += e[:, on] @ jw[on, 0]
            want[:, at, 1] += sx * sy * (e[:, on] @ jw[on, 1])
    got = horizontal_moments(p, jw, level, len(levels), kx, ky, mirrored=True)
    assert np.abs(got - want).max() < 1e-10 * np.abs(want).max()
    e = np.exp(1j * (np.outer(kx, p[:, 0]) + np.outer(ky, p[:, 1])))
    plain = horizontal_moments(p, jw, level, len(levels), kx, ky, mirrored=False)
    for at in range(2):
        on = level == at
        assert np.abs(plain[:, at] - e[:, on] @ jw[on]).max() < 1e-10 * np.abs(want).max()


def test_grid_moments_are_the_two_stencils_summed_over_the_kernel_table():
    """The compiled precorrection loop against its definition: each point pair's grid value is
    the sum over the observation and source points' 4 x 4 stencils of w_o w_s K[node_o - node_s],
    node by node, and the pair's moments are those values' (``rwg._moments``)."""
    from solvers.engines.surface.operators import pair_moments

    prob = _problem("soil")
    model = pfft.fast_model(prob, True)
    g = model.grid
    rng = np.random.default_rng(3)
    nl = len(g.levels)
    table = rng.normal(size=(nl, nl, 2, 2 * g.nx - 1, 2 * g.ny - 1)) * (1 + 1j)
    pairs = model.pairs[rng.choice(len(model.pairs), 40, replace=False)]
    got = pfft.grid_moments(model, table, pairs)  # [2, 6, 40]
    ix, iy, wx, wy = model.stencils
    pts, w = model.points
    for p, (o, s) in enumerate(pairs):
        want = np.zeros((2, 3, 3), complex)
        for i in range(3):
            for j in range(3):
                for a in range(4):
                    for b in range(4):
                        for c in range(4):
                            for d in range(4):
                                dx = ix[o, i] + a - ix[s, j] - c + g.nx - 1
                                dy = iy[o, i] + b - iy[s, j] - d + g.ny - 1
                                ws = wx[o, i, a] * wy[o, i, b] * wx[s, j, c] * wy[s, j, d]
                                want[:, i, j] += ws * table[model.level[o], model.level[s], :, dx, dy]
        for ch in range(2):
            m = pair_moments(want[ch] * w[o][:, None] * w[s][None, :], pts[o], pts[s])
            assert np.allclose(got[ch, :, p], m, rtol=1e-12, atol=1e-14 * np.abs(m).max())


def test_fast_operator_on_another_soil_is_that_soils_operator():
    """One model and one frequency's soil-independent terms serve every soil: the operator
    built for a second soil from them is the one built from scratch on that soil."""
    prob = _problem("soil")
    model = pfft.build_fast_model(prob, None)
    terms = pfft.FrequencyTerms(model, 70e6)
    other = (5.0, 0.005)
    shared = pfft.FastOperator(model, 70e6, other, terms)
    fresh_prob = Problem(prob.mesh, prob.rwg, "soil", prob.near_factor, other)
    fresh = pfft.FastOperator(pfft.build_fast_model(fresh_prob, None), 70e6)
    x = np.random.default_rng(4).normal(size=prob.n) + 0j
    assert np.allclose(shared.matvec(x), fresh.matvec(x), rtol=1e-12, atol=1e-12 * np.abs(fresh.matvec(x)).max())
    assert abs(shared.near - fresh.near).max() <= 1e-12 * abs(fresh.near).max()


def test_soils_in_one_pass_are_each_soil_alone(monkeypatch):
    """The reflected near terms of several soils computed in one pass over the point pairs (their
    tables on different rho steps: the wet soil's is finer at 97 MHz) are each soil's own, to the
    last bit, and cutting the pairs into blocks changes nothing; a kept soil is handed over once."""
    prob = _problem("soil")
    model = pfft.build_fast_model(prob, None)
    terms = pfft.FrequencyTerms(model, 97e6)
    soils = [(3.5, 0.02), (5.0, 0.05), (2.5, 0.005)]
    steps = {k.step for k in prob.reflected_kernels_many(97e6, soils, pfft.FAR_REACH_CELLS * model.grid.h)}
    assert len(steps) > 1  # the padded tables are exercised
    together = pfft.reflected_near(model, terms, soils)
    assert all(any(v) for v in together)
    monkeypatch.setattr(pfft, "REFLECTED_BLOCK", 100)  # many blocks
    alone = []
    for s in soils:
        pfft._SOIL_NEAR.clear()
        alone.append(pfft.reflected_near(model, terms, [s])[0])
    for a, b in zip(together, alone):
        assert np.array_equal(a, b)
    pfft._SOIL_NEAR.clear()
    pfft.reflected_near(model, terms, soils)
    first = pfft.reflected_near(model, terms, [(5.0, 0.05)])[0]
    assert np.array_equal(first, together[1]) and (5.0, 0.05) not in next(iter(pfft._SOIL_NEAR.values()))[1]
    pfft._SOIL_NEAR.clear()


def test_fast_solve_of_an_asymmetric_plane_gives_the_dense_beam():
    """A plane without mirror symmetry (an as-built variant: a corner moved, the antenna off
    centre) is solved as the whole model by both methods; they agree as on symmetric ones."""
    from groundplane.shapes import PolygonPlane

    plane = PolygonPlane(((-5.0, -5.0), (5.3, -4.8), (5.0, 5.0), (-4.9, 5.2)))
    assert not all(plane.mirror_symmetry.values())
    design = Design(plane, Soil())
    mesh = build_mesh(design, SurfaceSettings(spacing=1.5, blade_cells=(6, 4)))
    prob = Problem(mesh, rwg_basis(mesh), "soil", 2.5, (design.ground.eps_r, design.ground.sigma))
    dense = solve(prob, 80e6, None)
    fast, stats = pfft.solve_fast(prob, 80e6, symmetric=False)
    assert not stats.mirrored and stats.residual < 1e-4
    th, ph = np.arange(0.0, 81.0, 5.0), np.arange(0.0, 360.0, 15.0)
    gd, gf = gain_pattern(prob, dense, th, ph), gain_pattern(prob, fast, th, ph)
    assert np.sqrt(np.mean((10 * np.log10(gf / gd)) ** 2)) < 2e-3
    assert abs(fast.input_impedance - dense.input_impedance) < 0.05


def test_gmres_starts_from_the_nearest_solved_currents_of_the_same_design(monkeypatch):
    """The warm start: the design's previous soil at this frequency, else its last frequency within
    WARM_START_SPAN (10 %), never another design's currents nor a far frequency's."""
    from solvers.engines.surface import pfft

    model, other, a = object(), object(), np.arange(3.0)
    pfft.warm_start(model, 75e6, a)
    assert pfft.warm_start(model, 75e6) is a and pfft.warm_start(model, 78e6) is a
    assert pfft.warm_start(model, 90e6) is None and pfft.warm_start(other, 75e6) is None
    monkeypatch.setattr(pfft, "WARM_START_ACROSS_FREQUENCIES", False)
    assert pfft.warm_start(model, 78e6) is None and pfft.warm_start(model, 75e6) is a
    monkeypatch.setattr(pfft, "WARM_START", False)
    assert pfft.warm_start(model, 75e6) is None
    pfft._START.clear()


def test_pruned_grid_transforms_are_the_padded_fft2():
    """The matvec's FFTs skip the rows a level's sources cannot reach (the blade's level spans a
    few rows of the plate's grid): equal to fft2 of the zero-padded sources, and to ifft2 cut to
    the grid on every row a level's points read."""
    import scipy.fft

    model = pfft.build_fast_model(_problem("soil"), None)
    g, (sx, sy) = model.grid, model.shape
    nl = len(g.levels)
    assert nl == 2 and model.rows_of_level[1].stop - model.rows_of_level[1].start < g.nx // 2  # the blade's is narrow
    rng = np.random.default_rng(3)
    src = np.zeros((3, nl, g.nx, g.ny), complex)
    for c in range(3):  # sources where the model puts them: through its projection
        src[c] = (model.project @ (rng.normal(size=model.project.shape[1]) + 0j)).reshape(nl, g.nx, g.ny)
    padded = np.zeros((3, nl, sx, sy), complex)
    padded[..., :g.nx, :g.ny] = src
    spec = model.spectrum(src)
    assert np.allclose(spec, scipy.fft.fft2(padded, axes=(-2, -1)), rtol=0, atol=1e-12 * np.abs(spec).max())
    pot = rng.normal(size=spec.shape) + 1j * rng.normal(size=spec.shape)
    want = scipy.fft.ifft2(pot, axes=(-2, -1))[..., :g.nx, :g.ny]
    got = model.potentials(pot)
    for lv, rows in enumerate(model.rows_of_level):
        assert np.allclose(got[:, lv, rows], want[:, lv, rows], rtol=0, atol=1e-13)
        read = np.unique(model.project[lv * g.nx * g.ny:(lv + 1) * g.nx * g.ny].nonzero()[0] // g.ny)
        assert rows.start <= read.min() and read.max() < rows.stop  # every row the level reads is kept
