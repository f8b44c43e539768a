"""Sweeps (resume after kill -9, invalid members, beam files, Dask), the optimiser's
constraint handling and NaN guard, and the report writer. Solves are a 3 m plate at a
1 m mesh and 8 frequencies: seconds each."""

import numpy as np
import pytest

from groundplane.beam import Beam
from optimise.evaluate import EvalSettings
from solvers.engines.base import SolveSettings
from tests.conftest import EXAMPLE_BEAM

CHEAP = """
[solver]
mesh = 1.0
freqs = "55:97:4"
[fom]
n_lst = 24
"""



def test_design_study_table_conclusions_compare_mesh_and_retry(tmp_path, monkeypatch):
    """The reproduction on a stand-in solver: nine rows, a failed row retried on the rerun,
    NEC time read from the beam's own timings, and a second mesh's column and conclusions."""
    from dataclasses import replace

    import optimise.evaluate as evaluate
    from optimise.studies.design_study import DESIGN_STUDY, design_study
    from solvers.engines.nec import NecSettings

    f = np.arange(55.0, 98.0, 4.0)
    hb = Beam.load(EXAMPLE_BEAM)
    broken = {"sawtooth-15-12"}

    def fake_beam(candidate, settings, progress=False):
        if candidate.name in broken:
            raise RuntimeError("GEOMETRY DATA ERROR -- WIRE #5 INTERSECTS WIRE #6")
        # chromaticity falling with metal area and with mesh refinement, like the real thing
        amp = 0.02 * settings.model.spacing * 100.0 / candidate.plane.metal_area
        g = np.repeat(hb.gain[:1], f.size, axis=0) * (1 + amp * np.sin(f / 3))[:, None, None]
        return Beam(f, hb.theta_deg, hb.phi_deg, g, meta={"seconds_per_frequency": [2.0] * f.size,
                                                           "n_segments": 100}), 0.0

    monkeypatch.setattr(evaluate, "candidate_beam", fake_beam)
    import optimise.studies.design_study as reproduce

    monkeypatch.setattr(reproduce, "pec_reference_fom", lambda settings, progress=False: 123.6)
    fine = EvalSettings(solve=SolveSettings(engine="nec", freqs_mhz=tuple(f)), model=NecSettings(spacing=0.7), fom=replace(EvalSettings().fom, n_lst=24))
    coarse = fine.with_spacing(1.0)
    table = design_study(fine, tmp_path, "groundplane reproduce design-study", progress=False)
    assert [t["preset"] for t in table] == [n for n, _ in DESIGN_STUDY]
    assert next(t for t in table if t["preset"] == "sawtooth-15-12")["status"] == "failed"
    assert "(i) cannot be tested yet" in (tmp_path / "design_study.md").read_text()
    broken.clear()  # the cause is fixed: rerunning retries only the failed row
    table = design_study(fine, tmp_path, "groundplane reproduce design-study", progress=False, compare=coarse)
    assert all(t["status"] == "ok" for t in table)
    assert all(t["solver_cpu_s"] == pytest.approx(2.0 * f.size) for t in table)
    md = (tmp_path / "design_study.md").read_text()
    assert "our FoM at 1 m (mK)" in md and "Same conclusions at 1 m" in md
    assert md.count("(i) larger area, lower FoM within a shape: **holds**") == 2
    assert "refining the mesh 1 -> 0.7 m moved it" in md
    assert "ours 123.6 mK vs the paper's 61.8 mK (x2.00)" in md
    rows = (tmp_path / "design_study_runs" / "results.jsonl").read_text().splitlines()
    assert len(rows) == 2 * 9 + 1  # 9 fine (one failed then retried) + 9 coarse, nothing redone

