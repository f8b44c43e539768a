"""The field set's sensitivity table of every design scored here (each folder's results.json, written by
`groundplane score --design ... --scenarios field -o results/robust_front/field/<name>`), side by side:
per axis the member that moves the FoM most from the MRO member and the computed verdict
(``optimise.scenarios.sensitivity``, the table `score` now writes into report.md).

    .venv/bin/python results/robust_front/field/sensitivity.py > results/robust_front/field/sensitivity.md
"""
import json
from pathlib import Path

from optimise.scenarios import FRAGILE, sensitivity

HERE = Path(__file__).resolve().parent


def main() -> None:
    """Print the table (sensitivity.md's body)."""
    print("<!-- .venv/bin/python results/robust_front/field/sensitivity.py > results/robust_front/field/sensitivity.md -->")
    print("# The field set, design by design\n")
    print(f"Each design's 18 `field` members at the search level (0.7 m, 55-97 MHz every 3 MHz, 2 h bins; the "
          f"commands are in each folder's report.md). Per axis, the member that moves the FoM most from the MRO "
          f"soil member; fragile where that is more than {100 * FRAGILE:.0f} %.\n")
    print("| design | metal (m^2) | MRO (mK) | worst member (mK) | mean (mK) | largest loss (%) | axis | largest move "
          "(member) | its FoM (mK) | change | verdict |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for folder in sorted(p for p in HERE.iterdir() if (p / "results.json").exists()):
        row = json.loads((folder / "results.json").read_text())[0]
        sens = sensitivity(row)
        loss = row.get("max_loss")
        head = (f"| {folder.name} | {row['metal_area_m2']:.1f} | {sens.nominal_mk:.1f} | {row['worst_fom_mk']:.1f} | "
                f"{row['mean_fom_mk']:.1f} | {'-' if loss is None else f'{100 * loss:.3f}'} |")
        for i, r in enumerate(sens.rows):
            lead = head if i == 0 else "| | | | | | |"
            print(f"{lead} {r['axis']} | {r['member']} | {r['fom_mk']:.1f} | {100 * r['change']:+.1f} % | "
                  f"{'**fragile**' if r['fragile'] else 'not fragile'} |")


if __name__ == "__main__":
    main()
