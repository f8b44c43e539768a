"""The two 396 m^2 seeds of the 400 m^2 search from the 600 m^2 star (see README.md here).

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

AREA = 396.0  # m^2: under the 400 m^2 budget with room for the search's first steps
LENGTHS = ("side", "chamfer", "base_x", "height_x", "base_y", "height_y", "base_d", "height_d")


def main() -> None:
    """Write both seeds beside this script (each checked against the search mesh's neck rule)."""
    star = json.loads((ROOT / "results/robust_front/field/teeth-xy-600/design.json").read_text())
    base = {k: v for k, v in star.items() if k != "shape"}
    makers = {"star-600-arms-shortened-400": lambda f: {k: base[k] * f for k in ("height_x", "height_y", "height_d")},
              "star-600-scaled-400": lambda f: {k: base[k] * f for k in LENGTHS}}
    for name, change in makers.items():
        f = brentq(lambda f: TeethXY(**{**base, **change(f)}).metal_area - AREA, 0.05, 1.0)
        plane = TeethXY(**{**base, **change(f)})
        assert too_fine_for(plane, 0.7) is None, name
        out = Path(__file__).with_name(f"{name}.json")
        out.write_text(json.dumps({"shape": "teeth-xy", **{k: getattr(plane, k) for k in base}}, indent=1))
        print(f"{name}: factor {f:.4f}, {plane.metal_area:.1f} m^2 -> {out.name}")


if __name__ == "__main__":
    main()
