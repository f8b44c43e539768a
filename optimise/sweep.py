"""Design sweeps from a TOML file: candidates solved through the cache, scored, ranked.

Config (all tables optional except at least one candidate)::

    [solver]
    mesh = 0.5              # plate grid spacing, m
    wire_radius = 0.01
    plate_height = 0.05     # m above the soil
    refine_centre = [2.0, 2]  # optional: a 2x finer grid inside |x|,|y| <= 2 m
    freqs = "40:100:1"
    eps_r = 3.5
    sigma = 0.02

    [fom]
    fit_band = [55, 97]
    beta = 2.55
    n_lst = 360

    [[candidate]]
    preset = "square-10"

    [[candidate]]
    name = "feko-candidate-7"
    beam = ["exports/c7_0-90.ffe", "exports/c7_91-180.ffe"]   # a solver export joins the ranking
    metal_area_m2 = 600

    [[family]]              # every combination of the listed values
    shape = "sawtooth"
    side = [15, 20]
    teeth_per_side = [3, 4]
    tooth_base = 5
    tooth_height = 5

Resumable: each finished row is appended (and fsync'd) to ``DIR/results.jsonl``; a rerun
skips rows already there, and a candidate interrupted mid-solve resumes from the solver's
per-frequency cache. Nothing computed is lost, even on kill -9.
"""
from __future__ import annotations

import itertools
import math
import sys
import tomllib
from pathlib import Path
from typing import Any, Iterable

from groundplane.errors import ConfigError, ShapeError, UserInputError
from groundplane.files import append_jsonl, one_writer, read_jsonl
from groundplane.fom import FomSettings
from groundplane.options import build, check_name
from groundplane.shapes import PRESETS, SHAPES, from_dict
from solvers.api import solve_options_from_mapping

from .evaluate import (
    Candidate,
    EvalSettings,
    evaluate,
    failed_row,
    invalid_row,
    row_key,
)

MAX_FAMILY_MEMBERS = 100_000  # combinations of one [[family]]'s values

__all__ = ["ConfigError", "ResultStore", "load_config", "run_sweep", "summary_table", "settings_from_tables"]

def settings_from_tables(solver: dict[str, Any], fom: dict[str, Any], where: str) -> EvalSettings:
    """EvalSettings from a sweep file's ``[solver]`` and ``[fom]`` tables (strictly typed)."""
    soil, solve, model = solve_options_from_mapping(solver, f"{where}[solver]: ")
    return EvalSettings(soil=soil, solve=solve, model=model, fom=build(FomSettings, fom, f"{where}[fom]: "))


def load_config(path: str | Path) -> tuple[list[Candidate], list[dict[str, Any]], EvalSettings]:
    """Candidates, rows for invalid family members (kept in the report), and settings."""
    path = Path(path)
    try:
        cfg = tomllib.loads(path.read_text())
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(f"{path}: {exc}") from None
    unknown = set(cfg) - {"solver", "fom", "candidate", "family", "scenarios"}
    if unknown:
        raise ConfigError(f"{path}: unknown table(s) {sorted(unknown)}; expected solver, fom, scenarios, candidate, "
                          "family")
    for table in ("solver", "fom"):
        if not isinstance(cfg.get(table, {}), dict):
            raise ConfigError(f"{path}: '{table}' must be a [{table}] table, got {type(cfg[table]).__name__}")
    for table in ("candidate", "family"):
        entries = cfg.get(table, [])
        if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
            raise ConfigError(f"{path}: '{table}' must be [[{table}]] tables (one per {table}), got "
                              f"{type(entries).__name__}")
    if "scenarios" in cfg and not isinstance(cfg["scenarios"], dict):
        raise ConfigError(f"{path}: 'scenarios' must be a [scenarios] table (set, aggregate, max_loss, max_loss_spread)")
    settings = settings_from_tables(cfg.get("solver", {}), cfg.get("fom", {}), f"{path}: ")
    candidates = [_candidate(c, path, f"{path}: [[candidate]] #{i + 1}") for i, c in enumerate(cfg.get("candidate", []))]
    invalid: list[dict[str, Any]] = []
    for i, fam in enumerate(cfg.get("family", [])):
        members, bad = _family(fam, f"{path}: [[family]] #{i + 1}")
        candidates += members
        invalid += bad
    if not candidates:
        raise ConfigError(f"{path}: no candidates ([[candidate]] or [[family]] tables)")
    names = [c.name for c in candidates]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise ConfigError(f"{path}: candidate names must be unique; repeated: {sorted(dup)}")
    return candidates, invalid, settings


def load_scenarios(path: str | Path, given: dict[str, Any] | None = None):
    """The sweep file's ``[scenarios]`` table (keys of ``ScenarioOptions``: scenarios, aggregate,
    max_loss, max_loss_spread), with the command line's ``given`` values over it; None when
    neither says anything (the candidates are scored at the settings as given, no loss limit)."""
    from .scenarios import PAPER_OBJECTIVE, ScenarioOptions

    path = Path(path)
    try:
        table = tomllib.loads(path.read_text()).get("scenarios", {})
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(f"{path}: {exc}") from None
    values = {**(table if isinstance(table, dict) else {}), **(given or {})}
    if not values:
        return None
    base = {"scenarios": PAPER_OBJECTIVE.scenarios, "max_loss": None}  # a sweep's defaults: the paper's objective
    return build(ScenarioOptions, {**base, **values}, f"{path}: [scenarios] ")


def _candidate(c: dict[str, Any], path: Path, where: str) -> Candidate:
    """One ``[[candidate]]``: a preset, a shape with its parameters, or solver export file(s)."""
    try:
        if "name" in c:
            check_name(c["name"], "a candidate's name")
        if "beam" in c:
            extra = set(c) - {"beam", "name", "format", "metal_area_m2"}
            if extra:
                raise ConfigError(f"a beam-file candidate takes beam, name, format, metal_area_m2; not {sorted(extra)}")
            beams = c["beam"] if isinstance(c["beam"], list) else [c["beam"]]
            beams = [str((path.parent / b) if not Path(b).is_absolute() else b) for b in beams]
            area = c.get("metal_area_m2")
            if area is not None and (isinstance(area, bool) or not isinstance(area, (int, float))
                                     or not (math.isfinite(area) and area > 0)):
                raise ConfigError(f"metal_area_m2 must be a positive number of m^2, got {area!r}")
            return Candidate(c.get("name") or Path(beams[0]).stem, beam_paths=tuple(beams),
                             beam_format=c.get("format", "auto"), metal_area_m2=None if area is None else float(area))
        if "preset" in c:
            extra = set(c) - {"preset", "name"}
            if extra:
                raise ConfigError(f"a preset candidate takes preset and name only; not {sorted(extra)}")
            return Candidate(c.get("name", c["preset"]), plane=from_dict({"preset": c["preset"]}))
        params = {k: v for k, v in c.items() if k != "name"}
        if not isinstance(params.get("shape"), str):
            raise ConfigError("a shape candidate names its family as a string ('shape = \"square\"'), a preset "
                              "('preset = ...') or a beam file ('beam = ...')")
        return Candidate(c.get("name", _auto_name(params)), plane=from_dict(params))
    except (UserInputError, TypeError) as exc:
        raise ConfigError(f"{where}: {exc}") from None


def _family(fam: dict[str, Any], where: str) -> tuple[list[Candidate], list[dict[str, Any]]]:
    """Every combination of a ``[[family]]``'s listed values; impossible members become rows."""
    if "shape" not in fam:
        raise ConfigError(f"{where} needs 'shape'")
    if not isinstance(fam["shape"], str) or fam["shape"] not in SHAPES:
        raise ConfigError(f"{where}: unknown shape {fam['shape']!r}; choose one of {', '.join(SHAPES)}")
    keys = [k for k in fam if k != "shape"]
    own = {p.name for p in SHAPES[fam["shape"]].parameters()}
    if set(keys) - own:  # a typo would otherwise make every member "invalid" and the sweep empty
        raise ConfigError(f"{where}: {fam['shape']} has no parameter(s) {sorted(set(keys) - own)}; it takes "
                          f"{sorted(own)}")
    grids = [fam[k] if isinstance(fam[k], list) else [fam[k]] for k in keys]
    size = math.prod(len(g) for g in grids)
    if size > MAX_FAMILY_MEMBERS:  # before expanding it: 1.5e9 members were still being listed after 40 s
        raise ConfigError(f"{where}: {size:,} combinations of its values; at most {MAX_FAMILY_MEMBERS:,} (a sweep "
                          "of that many solves would take years): list fewer values")
    for k, g in zip(keys, grids):
        bad = [v for v in g if isinstance(v, (list, dict)) or isinstance(v, bool)]
        if bad:
            raise ConfigError(f"{where}: {k} = {bad[0]!r}: each value is a number (or a list of numbers)")
    members, invalid = [], []
    for combo in itertools.product(*grids):
        params = {"shape": fam["shape"], **dict(zip(keys, combo))}
        name = _auto_name(params)
        try:
            members.append(Candidate(name, plane=from_dict(params)))
        except ShapeError as exc:  # an impossible member is reported, not fatal
            invalid.append(invalid_row(name, fam["shape"], {k: v for k, v in params.items() if k != "shape"}, str(exc)))
    return members, invalid


def _auto_name(params: dict[str, Any]) -> str:
    for name, shape in PRESETS.items():
        try:
            if from_dict(params).key() == shape.key():
                return name
        except ShapeError:
            break
    return params["shape"] + "-" + "-".join(f"{v:g}" if isinstance(v, (int, float)) else str(v)
                                            for k, v in params.items() if k != "shape")


# ----------------------------------------------------------------------- results
class ResultStore:
    """Append-only JSON lines, one row a candidate; the last row of a key wins."""

    def __init__(self, directory: str | Path) -> None:
        self.dir = Path(directory)
        self.dir.mkdir(parents=True, exist_ok=True)
        self.path = self.dir / "results.jsonl"

    def rows(self) -> dict[str, dict[str, Any]]:
        return {row["key"]: row for row in read_jsonl(self.path) if "key" in row}

    def append(self, row: dict[str, Any]) -> None:
        append_jsonl(self.path, row)


def run_sweep(
    candidates: list[Candidate],
    settings: EvalSettings,
    out_dir: str | Path,
    *,
    invalid: Iterable[dict[str, Any]] = (),
    executor: str = "local",
    scheduler: str | None = None,
    progress: bool = True,
    retry_failed: bool = False,
    scenarios=None,
    constraints=None,
) -> list[dict[str, Any]]:
    """Evaluate every candidate not already in ``out_dir``; return all rows (this sweep's). With
    ``scenarios`` each candidate is scored on every member (``scenarios.evaluate_scenarios``) and
    held to ``constraints``."""
    if any(c.plane is not None for c in candidates):
        settings.check_scorable()
    if scenarios is not None and executor != "local":
        raise UserInputError("--executor dask solves one beam per candidate; a sweep over a scenario set runs "
                             "locally (its members of one model are solved together)")
    with one_writer(out_dir):  # a second sweep into the folder is refused, not interleaved with this one
        store = ResultStore(out_dir)
        done = store.rows()
        extra = {} if scenarios is None else {"scenarios": scenarios.identity(),
                                              "constraints": constraints.identity() if constraints else None}
        keys = {c.name: row_key(c, settings, extra) for c in candidates}
        todo = [c for c in candidates
                if keys[c.name] not in done or (retry_failed and done[keys[c.name]].get("status") != "ok")]
        if progress:
            print(f"sweep: {len(candidates)} candidates, {len(candidates) - len(todo)} already done, "
                  f"{len(todo)} to solve -> {store.dir}", file=sys.stderr)
        if executor == "local":
            from groundplane.progress import Progress

            bar = Progress(len(todo), "candidates", "cand") if progress else None
            if scenarios is not None:
                from .scenarios import NO_CONSTRAINTS, check_set, evaluate_scenarios

                for c in todo:
                    check_set(scenarios, settings, c.plane)  # refused before any solve
            for c in todo:
                row = (evaluate(c, settings, progress=progress) if scenarios is None else
                       evaluate_scenarios(c, settings, scenarios, constraints or NO_CONSTRAINTS, progress))
                store.append({"key": keys[c.name], **row})
                if bar:
                    fom = row.get("lst_averaged_fom_mk")
                    bar.update(1, f"{c.name}: {f'{fom:.1f} mK' if fom is not None else row.get('status')}")
            if bar:
                bar.close()
        elif executor == "dask":
            _run_dask(todo, settings, store, keys, scheduler, progress)
        else:
            raise UserInputError(f"unknown executor '{executor}'; choose local or dask")
        rows = store.rows()
        result = [rows[keys[c.name]] for c in candidates if keys[c.name] in rows]
        return result + [dict(r) for r in invalid]


def _solve_on_worker(candidate: Candidate, settings: EvalSettings) -> tuple[str, float]:
    """Dask task: solve (NEC in this worker process, never beside healpy) and return the
    beam's cache path; scoring happens in the client."""
    import time

    from groundplane.design import Design
    from solvers.engines import BeamCache

    t0 = time.perf_counter()
    beam = settings.make_solver(workers=0).solve(Design(candidate.plane, settings.soil), settings.freqs_mhz)
    return str(BeamCache().path(beam.meta["cache_key"])), time.perf_counter() - t0


def _run_dask(todo, settings, store, keys, scheduler, progress) -> None:
    """Candidates on a Dask distributed cluster (a local one when no scheduler is given)."""
    from dask.distributed import Client, LocalCluster, as_completed

    from groundplane.beam import Beam

    from .evaluate import score

    cluster = None
    if scheduler:
        client = Client(scheduler)
    else:
        # one NEC per worker process, one OpenMP thread each: the 2 cores run 2 candidates
        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                               env={"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"})
        client = Client(cluster)
    try:
        files = [c for c in todo if c.plane is None]
        for c in files:  # beam files need no solve
            store.append({"key": keys[c.name], **evaluate(c, settings)})
        solve = [c for c in todo if c.plane is not None]
        futures = {client.submit(_solve_on_worker, c, settings, pure=False): c for c in solve}
        for fut in as_completed(futures):
            c = futures[fut]
            try:
                path, secs = fut.result()
                row = score(c, Beam.load(path), settings, secs)
            except Exception as exc:  # noqa: BLE001 - recorded in the row
                row = failed_row(c, f"{type(exc).__name__}: {exc}")
            store.append({"key": keys[c.name], **row})
            if progress:
                print(f"  {c.name}: {row.get('lst_averaged_fom_mk')}", file=sys.stderr)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def summary_table(rows: list[dict[str, Any]]) -> str:
    """The ranking as fixed-width text for the terminal."""
    ok = sorted([r for r in rows if r.get("status") == "ok"], key=lambda r: r["lst_averaged_fom_mk"])
    lines = [f"{'rank':>4} {'candidate':24s} {'metal (m^2)':>11} {'extent (m)':>10} {'FoM (mK)':>9}"]
    for i, r in enumerate(ok, 1):
        area = f"{r['metal_area_m2']:.1f}" if r.get("metal_area_m2") is not None else "-"
        ext = f"{r['extent_m']:.1f}" if r.get("extent_m") is not None else "-"
        lines.append(f"{i:4d} {r['name'][:24]:24s} {area:>11} {ext:>10} {r['lst_averaged_fom_mk']:9.1f}")
    for r in rows:
        if r.get("status") != "ok":
            lines.append(f"   - {r['name'][:24]:24s} {r.get('status')}: {r.get('error', '')[:80]}")
    return "\n".join(lines)

