"""The cross-engine study end to end on tiny meshes (both engines really solve)."""
import json

import numpy as np


def test_cross_engine_study_writes_its_table_reading_and_figure(tmp_path, monkeypatch):
    from optimise.studies.cross_engine import Meshes, cross_engine

    monkeypatch.setenv("GROUNDPLANE_CACHE", str(tmp_path / "cache"))
    meshes = Meshes(plate=1.55, plate_fine=1.5, nec_finest=1.5, blade=(4, 4), blade_fine=(6, 4))  # the mesh rule: <= 1.58 m at 95 MHz
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
    table = [ln for ln in md.splitlines() if ln.startswith("| ") and not ln.startswith("| case")]
    assert len(table) == len(rows)  # one table row per solved row, each with its own FoM
    assert all(f"| {r['fom_mk']:.1f} |" in ln for r, ln in zip(rows, table))
    assert (tmp_path / "cross_engine.png").stat().st_size > 1000
    assert all(np.isfinite(r["rms_db_vs_ref_max"]) for r in rows if not r["reference"] and r["rms_db_vs_ref_max"] != "-")


def _rows(**changes):
    """The reading's rows as the committed study found them (in spirit): engines agree on the
    blade, the production grid leaks, the surface engine is converged above PEC."""
    def row(role, fom, fom_frac, zen_frac, model="m, 0.5 m"):
        return {"role": role, "fom_mk": fom, "fom_vs_ref_frac": fom_frac, "zenith_vs_ref_frac": zen_frac,
                "fom_vs_ref": f"{fom_frac:+.1%}", "zenith_vs_ref_max": f"{zen_frac:+.1%} at 97 MHz", "model": model}
    rows = {"blade-nec": row("blade-nec", 80.0, 0.01, 0.01), "blade-ref": row("blade-ref", 79.0, 0.0, 0.0),
            "free-nec-production": row("free-nec-production", 300.0, 0.4, -0.2),
            "free-nec-equal-area-fine": row("free-nec-equal-area-fine", 210.0, 0.02, 0.01),
            "free-nec-equal-area-finest": row("free-nec-equal-area-finest", 205.0, 0.01, 0.01),
            "pec-nec-production": row("pec-nec-production", 900.0, 0.6, 0.3),
            "pec-nec-thick": row("pec-nec-thick", 700.0, 0.3, 0.2), "pec-surface": row("pec-surface", 560.0, 0.01, 0.0)}
    for role, fields in changes.items():
        rows[role] = {**rows[role], **fields}
    return list(rows.values())


def test_each_verdict_follows_its_rows():
    from optimise.studies.cross_engine import _reading

    base = _reading(_rows())
    assert "the engines agree" in base[0] and "not the wire grid's" in base[0]
    assert "leaky reflector" in base[1] and "converged and NEC's grids are not" in base[2]
    flipped = _reading(_rows(**{"blade-nec": {"fom_vs_ref_frac": 0.2}}))
    assert "the engines differ" in flipped[0] and "not the wire grid's" not in flipped[0]
    near_feko = _reading(_rows(**{"blade-nec": {"fom_mk": 62.0}, "blade-ref": {"fom_mk": 61.0}}))
    assert "not the wire grid's" not in near_feko[0] and "Against FEKO's 61.8 mK" in near_feko[0]
    assert "leaky" not in _reading(_rows(**{"free-nec-equal-area-fine": {"zenith_vs_ref_frac": 0.2}}))[1]
    assert "agrees with the solid plate" in _reading(_rows(**{"free-nec-production": {"fom_vs_ref_frac": 0.0,
                                                                                      "zenith_vs_ref_frac": 0.0}}))[1]
    assert "meshes differ by more than 5%" in _reading(_rows(**{"pec-surface": {"fom_vs_ref_frac": 0.2}}))[2]
