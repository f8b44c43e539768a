"""The seeds of the 200, 400 and 900 m^2 searches from the 600 m^2 star (see README.md here).

    .venv/bin/python results/robust_front/seeds/make_seeds.py
"""
import json
import sys
from pathlib import Path

from scipy.optimize import brentq

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))
from groundplane.shapes import TeethXY  # noqa: E402
from optimise.search import too_fine_for  # noqa: E402

LENGTHS = ("side", "chamfer", "base_x", "height_x", "base_y", "height_y", "base_d", "height_d")
CORE = ("side", "chamfer", "base_x", "base_y", "base_d")  # the core and the arms' bases, not their lengths
# each seed: (how the star's lengths change with the factor f, the metal it is brought to: 1 % under its
# budget, room for the search's first steps; the factor's bracket)
SEEDS = {
    "star-600-arms-shortened-400": (lambda b, f: {k: b[k] * f for k in ("height_x", "height_y", "height_d")}, 396.0,
                                    (0.05, 1.0)),
    "star-600-scaled-400": (lambda b, f: {k: b[k] * f for k in LENGTHS}, 396.0, (0.05, 1.0)),
    # scaled to 200 m^2 the corner teeth would be 1.5 m wide at their base, narrower than the search mesh's
    # two cells along most of their length (refused): they go, the rest scaled (a tapered cross)
    "star-600-scaled-200": (lambda b, f: {**{k: b[k] * f for k in LENGTHS}, "base_d": 0.0, "height_d": 0.0}, 198.0,
                            (0.05, 1.0)),
    # the x arms already reach 13.7 of their 14 m: grow the core and the arms' bases instead
    "star-600-core-grown-900": (lambda b, f: {k: b[k] * f for k in CORE}, 891.0, (1.0, 2.0)),
}


def main() -> None:
    """Write every seed beside this script (each checked against the search mesh's neck rule)."""
    star = json.loads((ROOT / "results/robust_front/field/teeth-xy-600/design.json").read_text())
    base = {k: v for k, v in star.items() if k != "shape"}
    for name, (change, area, bracket) in SEEDS.items():
        f = brentq(lambda f: TeethXY(**{**base, **change(base, f)}).metal_area - area, *bracket)
        plane = TeethXY(**{**base, **change(base, f)})
        assert too_fine_for(plane, 0.7) is None, name
        out = Path(__file__).with_name(f"{name}.json")
        out.write_text(json.dumps({"shape": "teeth-xy", **{k: getattr(plane, k) for k in base}}, indent=1))
        print(f"{name}: factor {f:.4f}, {plane.metal_area:.1f} m^2 -> {out.name}")


if __name__ == "__main__":
    main()
