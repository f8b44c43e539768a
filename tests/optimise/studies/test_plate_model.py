"""The plate-model study's findings are conditions on its rows."""


def test_plate_model_findings_follow_the_rows():
    """The plate-model study's findings: a falling series flattens or not, a bump is named."""
    from optimise.studies.plate_model import _findings

    def rows(foms):
        return [{"spacing_m": 0.5, "height_m": h, "radius_m": 0.001, "fom_mk": v, "narrow_rms": 1e-4,
                 "efficiency_75": 0.9} for h, v in zip((0.02, 0.01, 0.005, 0.003), foms)]
    assert "falls at every step, the last by less than 5%" in "\n".join(_findings(rows([300, 270, 255, 250])))
    assert "the last by 12%" in "\n".join(_findings(rows([300, 270, 255, 225])))
    assert "not monotone; the largest step is +20 % (row 2 -> 3)" in "\n".join(_findings(rows([300, 270, 324, 320])))
