"""Is the loss tables' bend above the solver's own noise? The 600 m^2 answer's cached beams on MRO and the
dry corner (as ``ground_loss.py`` reads them: 2 workers, warm-started GMRES to 1e-5) against the same
beams solved from zero to 1e-7 in one process (``benchmarks/check_solve_path.py``'s reference): the
largest loss difference and the bend of the difference, beside the bend that README.md reports for
the dry corner's loss minus MRO's.

    .venv/bin/python results/robust_front_0.5m/ground_loss/path_noise.py > results/robust_front_0.5m/ground_loss/path_noise.txt
"""
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]
sys.path[:0] = [str(ROOT), str(ROOT / "benchmarks"), str(HERE)]
SOILS = [(3.5, 0.02), (2.5, 0.005)]  # MRO and the soil whose difference from it bends most (README.md)


def main() -> None:
    """Print the comparison."""
    import numpy as np
    from check_solve_path import solve
    from ground_loss import bend

    from groundplane.options import parse_freqs
    from groundplane.shapes import from_file
    from solvers.api import solve_soils

    plane = from_file(ROOT / "results/robust_front_0.5m/answer-600.json")
    cached = solve_soils(plane, SOILS, mesh=0.5, freqs="55:97:1", workers=2)
    ref = solve(plane, 0.5, parse_freqs("55:97:1"), 0, warm=False, rtol=1e-7, soils=SOILS)
    print(f"# .venv/bin/python {Path(__file__).relative_to(ROOT)}")
    f = cached[0].freqs_mhz
    for beam, soil in zip(cached, SOILS):
        d = beam.ground_loss() - ref[soil].ground_loss()
        print(f"eps_r {soil[0]:g}, sigma {soil[1]:g}: largest |loss - reference| {np.abs(d).max():.2e}; "
              f"bend of the difference {1e6 * bend(f, d):.3f} ppm")
    diff = cached[1].ground_loss() - cached[0].ground_loss()
    noise = diff - (ref[SOILS[1]].ground_loss() - ref[SOILS[0]].ground_loss())
    print(f"dry corner minus MRO: bend {1e6 * bend(f, diff):.3f} ppm; of its change against the reference "
          f"{1e6 * bend(f, noise):.3f} ppm")


if __name__ == "__main__":
    main()
