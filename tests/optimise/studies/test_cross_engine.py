"""The cross-engine study end to end on tiny meshes (both engines really solve)."""
import json

import numpy as np


def test_cross_engine_study_writes_its_table_reading_and_figure(tmp_path, monkeypatch):
    from optimise.studies.cross_engine import Meshes, cross_engine

    monkeypatch.setenv("GROUNDPLANE_CACHE", str(tmp_path / "cache"))
    meshes = Meshes(plate=2.5, plate_fine=2.0, nec_finest=2.0, blade=(4, 4), blade_fine=(6, 4))
    cross_engine(tmp_path, "test", workers=1, meshes=meshes, freqs=np.arange(55.0, 98.0, 4.0))
    rows = json.loads((tmp_path / "cross_engine.json").read_text())
    assert len(rows) == 13 and sum(r["reference"] for r in rows) == 3
    for r in rows:
        assert np.isfinite(r["fom_mk"]) and r["fom_mk"] > 0
        if r["engine"] == "surface":
            lo, hi = map(float, r["energy_balance"].split("-"))
            assert abs(lo - 1) < 0.01 and abs(hi - 1) < 0.01
    blade_nec = next(r for r in rows if r["role"] == "blade-nec")
    assert abs(float(blade_nec["fom_vs_ref"].rstrip("%"))) < 15  # coarse models of the same blade
    md = (tmp_path / "cross_engine.md").read_text()
    assert "## Reading" in md and "leaky reflector" in md and (tmp_path / "cross_engine.png").stat().st_size > 1000
