"""The field set's sensitivity table of every design scored in a folder (each subfolder's results.json,
written by `groundplane score --design ... --scenarios field -o FOLDER/<name>`; default this one), side
by side: per axis the member that moves the FoM most from the MRO member and the computed verdict
(``optimise.scenarios.sensitivity``, the table `score` now writes into report.md).

    .venv/bin/python results/robust_front/field/sensitivity.py [FOLDER] > FOLDER/sensitivity.md
"""
import json
import shlex
import sys
from pathlib import Path

from optimise.scenarios import FRAGILE, sensitivity

HERE = Path(__file__).resolve().parent


def level(folder: Path) -> str:
    """The mesh and frequencies a design was scored at, from its report's provenance command."""
    try:
        first = (folder / "report.md").read_text().splitlines()[0]
        words = shlex.split(json.loads(first.removeprefix("<!-- provenance:").removesuffix("-->"))["command"])
    except (OSError, IndexError, ValueError, KeyError):
        return "?"
    said = {w: words[i + 1] for i, w in enumerate(words[:-1]) if w in ("--mesh", "--freqs")}
    return f"{said.get('--mesh', 'default')} m, {said.get('--freqs', 'default')} MHz"


def main() -> None:
    """Print the table (sensitivity.md's body)."""
    here = Path(sys.argv[1]).resolve() if len(sys.argv) > 1 else HERE
    shown = here.relative_to(HERE.parents[2]) if here.is_relative_to(HERE.parents[2]) else here
    print(f"<!-- .venv/bin/python results/robust_front/field/sensitivity.py {shown} > {shown}/sensitivity.md -->")
    print("# The field set, design by design\n")
    print(f"Each design's `field` members (2 h bins; how many and the level each was scored at in its row, the command in its "
          f"folder's report.md). Per axis, the member that moves the FoM most from the MRO soil member; fragile "
          f"where that is more than {100 * FRAGILE:.0f} %.\n")
    print("| design | members | level | metal (m^2) | MRO (mK) | worst member (mK) | mean (mK) | largest loss (%) | axis | largest "
          "move (member) | its FoM (mK) | change | verdict |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for folder in sorted(p for p in here.iterdir() if (p / "results.json").exists()):
        row = json.loads((folder / "results.json").read_text())[0]
        sens = sensitivity(row)
        loss = row.get("max_loss")
        head = (f"| {folder.name} | {len(row.get('per_member_mk') or [])} | {level(folder)} | {row['metal_area_m2']:.1f} | {sens.nominal_mk:.1f} | "
                f"{row['worst_fom_mk']:.1f} | {row['mean_fom_mk']:.1f} | {'-' if loss is None else f'{100 * loss:.3f}'} |")
        for i, r in enumerate(sens.rows):
            lead = head if i == 0 else "| | | | | | | | |"
            print(f"{lead} {r['axis']} | {r['member']} | {r['fom_mk']:.1f} | {100 * r['change']:+.1f} % | "
                  f"{'**fragile**' if r['fragile'] else 'not fragile'} |")


if __name__ == "__main__":
    main()
