"""Draw results/engine_dry/engine_dry.png: square-10 on the soil set, FoM and ground loss per member for
NEC-2's wire grid and the surface engine's sheet at 5 mm and 24 cm (the rows of results/engine_dry/*.json,
written by the `groundplane score` commands in results/engine_dry/README.md).

    .venv/bin/python benchmarks/plot_engine_dry.py
"""
from __future__ import annotations

import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parents[1] / "results" / "engine_dry"
MODELS = [("nec-production", "NEC-2 grid, 1.6 mm wires, 5 mm up"), ("surface-production", "surface sheet, 5 mm up"),
          ("nec-equal-area-24cm", "NEC-2 grid, 8 cm wires, 24 cm up"), ("surface-24cm", "surface sheet, 24 cm up")]


def member_label(name: str) -> str:
    """'eps_r 2.5, sigma 0.005' -> '2.5 / 0.005'; the MRO member -> 'MRO'."""
    return "MRO" if name.startswith("MRO") else name.replace("eps_r ", "").replace(", sigma ", " / ")


def main() -> None:
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2))
    for i, (name, label) in enumerate(MODELS):
        row = json.loads((HERE / f"{name}.json").read_text())
        members = [member_label(m["member"]) for m in row["members"]]
        x = np.arange(len(members)) + (i - 1.5) * 0.2
        a1.bar(x, row["per_member_mk"], 0.2, label=label)
        a2.bar(x, [100 * m["max_ground_loss"] for m in row["members"]], 0.2, label=label)
    for ax, title in ((a1, "FoM, 2 h LST bins (mK)"), (a2, "largest ground loss in the fit band (%)")):
        ax.set_xticks(np.arange(len(members)), members, fontsize=8)
        ax.set_ylabel(title)
        ax.set_xlabel("soil (eps_r / sigma S/m)")
    a2.set_yscale("log")
    a1.legend(fontsize=7)
    fig.suptitle("square-10 on the soil set: NEC-2's wire grid vs the surface engine's sheet (results/engine_dry)",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(HERE / "engine_dry.png", dpi=110)


if __name__ == "__main__":
    main()
