"""A budget's answer checked as issue 34 asks, after its search: on NEC-2 beside the reference preset
(MRO, NEC-2's 0.5 m wire grid, 55-97 MHz every 1 MHz, 2 h bins: every earlier NEC check's settings) and
on the `field` set at the search level (0.5 m, 55-97 MHz every 3 MHz) for its as-built sensitivity,
then the folder's sensitivity table written again. Each step is the documented command, run only when
its output is missing (the beam cache makes a rerun cheap anyway).

    .venv/bin/python results/robust_front_0.5m/check_answer.py 600 [--folder results/robust_front_0.5m]
        [--reference sawtooth-20-16] [--workers 2] [--dry-run]

It runs after a search, with the machine to itself: both checks use --workers processes (2, this machine's
cores; 1 when a search runs beside them). Workers split the frequencies, never change a number.
"""
import argparse
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def nec_toml(answer: Path, params: dict, budget: str, reference: str, toml: Path, out: Path, workers: int) -> str:
    """The sweep file of the NEC-2 check: the answer's parameters and the reference preset."""
    lines = [f"# groundplane sweep {toml} -o {out}",
             f"# The {budget} m^2 robust answer ({answer.name}) and {reference} on the second engine: NEC-2's wire grid",
             "# at its default 0.5 m, MRO soil, the fit band at 1 MHz, FoM in 2 h LST bins.",
             "[solver]", 'engine = "nec"', "mesh = 0.5", 'freqs = "fit-band"', f"workers = {workers}", "",
             "[[candidate]]", f'name = "{params.get("shape", "design")}-{budget} (the robust answer)"']
    lines += [f'{k} = "{v}"' if isinstance(v, str) else f"{k} = {v!r}" for k, v in params.items()]
    lines += ["", "[[candidate]]", f'preset = "{reference}"']
    return "\n".join(lines) + "\n"


def _checked_params(results: Path) -> list | None:
    """The parameters of every design a finished check scored (its results.json rows), or None."""
    try:
        return [row.get("params") for row in json.loads(results.read_text())]
    except (OSError, ValueError, AttributeError):
        return None


def main() -> int:
    """Run the checks still missing for one budget's answer."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("budget")
    ap.add_argument("--folder", default="results/robust_front_0.5m")
    ap.add_argument("--reference", default="sawtooth-20-16")
    ap.add_argument("--workers", type=int, default=2, help="solver processes for both checks (default 2)")
    ap.add_argument("--dry-run", action="store_true", help="print the commands, run nothing")
    args = ap.parse_args()
    folder = Path(args.folder)
    answer = folder / f"answer-{args.budget}.json"
    if not answer.exists():
        print(f"check_answer: {answer} does not exist (the budget's search has not answered yet)", file=sys.stderr)
        return 2
    gp = [sys.executable, "-m", "groundplane"]
    toml, nec_out = folder / f"nec_check_{args.budget}.toml", folder / f"nec_check_{args.budget}"
    params = json.loads(answer.read_text())
    field_out = folder / "field" / f"{params.get('shape', 'design')}-{args.budget}"
    stale = [str(d) for d, said in ((nec_out, _checked_params(nec_out / "results.json")),
                                    (field_out, _checked_params(field_out / "results.json")))
             if said is not None and {k: v for k, v in params.items() if k != "shape"} not in said]
    if stale:  # an answer that moved (a resumed search) must not keep the checks of the one before
        print(f"check_answer: {', '.join(stale)} checked another design than {answer}; remove them to check this one",
              file=sys.stderr)
        return 2
    steps = []
    if not (nec_out / "results.json").exists():
        steps.append((gp + ["sweep", str(toml), "-o", str(nec_out)], toml))
    if not (field_out / "results.json").exists():
        steps.append((gp + ["score", "--design", str(field_out / "design.json"), "--scenarios", "field", "--mesh", "0.5",
                            "--freqs", "55:97:3", "--workers", str(args.workers), "-o", str(field_out)], field_out))
    for command, made in steps:
        print(" ".join(command), flush=True)
        if args.dry_run:
            continue
        if made == toml:
            toml.write_text(nec_toml(answer, params, args.budget, args.reference, toml, nec_out, args.workers))
        else:
            field_out.mkdir(parents=True, exist_ok=True)
            (field_out / "design.json").write_text(answer.read_text())
        subprocess.run(command, check=True)
    table = subprocess.run([sys.executable, str(ROOT / "results/robust_front/field/sensitivity.py"), str(folder / "field")],
                           capture_output=True, text=True, check=not args.dry_run)
    if not args.dry_run:
        (folder / "field" / "sensitivity.md").write_text(table.stdout)
    return 0


if __name__ == "__main__":
    sys.exit(main())
