"""Draw results/engine_dry/engine_dry.png: square-10 on the soil set, FoM and ground loss per member for
NEC-2's wire grid and the surface engine's sheet at 5 mm and 24 cm (the rows of results/engine_dry/*.json,
written by the `groundplane score` commands in results/engine_dry/README.md).

    .venv/bin/python benchmarks/plot_engine_dry.py
"""
import json
import matplotlib; matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
names = [("nec-production", "NEC-2 grid, 1.6 mm wires, 5 mm up"), ("surface-production", "surface sheet, 5 mm up"),
         ("nec-equal-area-24cm", "NEC-2 grid, 8 cm wires, 24 cm up"), ("surface-24cm", "surface sheet, 24 cm up")]
fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2))
for i, (n, lab) in enumerate(names):
    d = json.load(open(f"results/engine_dry/{n}.json"))
    members = [m["member"].replace("eps_r ", "").replace(", sigma ", " / ").replace("MRO (3.5 / 0.02)", "MRO") for m in d["members"]]
    x = np.arange(len(members)) + (i - 1.5) * 0.2
    a1.bar(x, d["per_member_mk"], 0.2, label=lab)
    a2.bar(x, [100 * m["max_ground_loss"] for m in d["members"]], 0.2, label=lab)
for a, t in ((a1, "FoM, 2 h LST bins (mK)"), (a2, "largest ground loss in the fit band (%)")):
    a.set_xticks(np.arange(len(members)), members, fontsize=8); a.set_ylabel(t); a.set_xlabel("soil (eps_r / sigma S/m)")
a2.set_yscale("log"); a1.legend(fontsize=7)
fig.suptitle("square-10 on the soil set: NEC-2's wire grid vs the surface engine's sheet (results/engine_dry)", fontsize=10)
fig.tight_layout(); fig.savefig("results/engine_dry/engine_dry.png", dpi=110)
