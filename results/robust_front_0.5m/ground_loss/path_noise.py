"""Are README.md's mK above the solver's own noise? The 600 m^2 answer's cached beams on MRO and the dry
corner (as ``ground_loss.py`` reads them: 2 workers, warm-started GMRES to 1e-5) against the same beams
solved from zero to 1e-7 in one process (``benchmarks/check_solve_path.py``'s reference): the largest
loss difference, what the FoM's fit leaves of T_ant x that difference, and the dry corner corrected
with MRO's table both ways (README.md's largest, 2.72 mK).

    .venv/bin/python results/robust_front_0.5m/ground_loss/path_noise.py > results/robust_front_0.5m/ground_loss/path_noise.txt
"""
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]
sys.path[:0] = [str(ROOT), str(ROOT / "benchmarks"), str(HERE)]


def main() -> None:
    """Print the comparison."""
    import numpy as np
    from check_solve_path import soil_set, solve
    from ground_loss import left_by, miscorrected

    from groundplane.options import parse_freqs
    from groundplane.shapes import from_file
    from solvers.api import solve_soils

    soils = soil_set()[:2]  # MRO and the dry corner, the soil README.md's largest miscorrection is on
    plane = from_file(ROOT / "results/robust_front_0.5m/answer-600.json")
    cached = solve_soils(plane, soils, mesh=0.5, freqs="55:97:1", workers=2)
    ref = solve(plane, 0.5, parse_freqs("55:97:1"), 0, warm=False, rtol=1e-7, soils=soils)
    print(f"# .venv/bin/python {Path(__file__).relative_to(ROOT)}")
    for beam, soil in zip(cached, soils):
        d = beam.ground_loss() - ref[soil].ground_loss()
        print(f"eps_r {soil[0]:g}, sigma {soil[1]:g}: largest |loss - reference| {np.abs(d).max():.2e}; "
              f"the fit leaves {left_by(beam, d):.4f} mK of T_ant x the difference")
    got = miscorrected(cached[1], cached[1].ground_loss(), cached[0].ground_loss())
    want = miscorrected(ref[soils[1]], ref[soils[1]].ground_loss(), ref[soils[0]].ground_loss())
    print(f"dry corner corrected with MRO's table: {got:.4f} mK (cached beams), {want:.4f} mK (the reference)")


if __name__ == "__main__":
    main()
