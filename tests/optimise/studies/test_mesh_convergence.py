"""The mesh-convergence verdict is computed from the rows: change a row and it changes."""
from optimise.studies.mesh_convergence import chosen_mesh, steps


def _rows(foms: dict) -> list[dict]:
    return [{"preset": p, "mesh_m": m, "fom_mk": f, "status": "ok", "unknowns": 1, "solver_cpu_s": 1.0}
            for (p, m), f in foms.items()]


FOMS = {("a", 0.7): 100.0, ("a", 0.5): 97.0, ("a", 0.35): 96.0,
        ("b", 0.7): 200.0, ("b", 0.5): 201.0, ("b", 0.35): 202.0}


def test_the_coarsest_mesh_whose_finer_step_moves_every_fom_within_tolerance():
    assert [round(s["change_pct"], 2) for s in steps(_rows(FOMS)) if s["preset"] == "a"] == [-3.0, -1.03]
    mesh, text = chosen_mesh(_rows(FOMS))
    assert mesh == 0.5 and "0.5 m" in text and "a -1.0 %" in text
    assert chosen_mesh(_rows({**FOMS, ("a", 0.5): 99.0}))[0] == 0.7  # 0.7 -> 0.5 now moves a by -1 %
    none, text = chosen_mesh(_rows({**FOMS, ("b", 0.35): 210.0}))  # the finest step moves b by +4.5 %
    assert none is None and "No mesh meets the rule" in text and "b +4.5 %" in text


def test_a_preset_missing_at_a_mesh_does_not_pass_the_rule():
    rows = [r for r in _rows(FOMS) if not (r["preset"] == "b" and r["mesh_m"] == 0.35)]
    mesh, text = chosen_mesh(rows)
    assert mesh is None and "1 of 2 presets" in text
