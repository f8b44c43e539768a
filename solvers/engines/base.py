"""What every engine shares: :class:`Solver`, the abstract engine (in the scikit-rf ``Media``
style: an engine declares what it is and what it can do, and implements two members, its
identity and its model of a design; the base builds the rest: the cached, resumable,
one-process-per-frequency solve, designs solved together, the checks), and the registry."""
from __future__ import annotations

import hashlib
import json
import sys
import time
from abc import ABC, abstractmethod
from collections.abc import Mapping
from concurrent.futures import wait
from concurrent.futures.process import BrokenProcessPool
from contextlib import nullcontext
from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar, Iterable, Iterator

import numpy as np

from groundplane.beam import Beam
from groundplane.design import Design
from groundplane.errors import SettingsError, SolveError, SolverError, UserInputError
from groundplane.options import option, parse_freqs

from .patterns import mirror_quadrant
from .workers import (
    core_capped,
    discard_shared_pool,
    process_pool,
    refuse_while_spawning,
    shared_pool,
    terminate_pool,
    unguarded_main_script,
    usable_workers,
)

DEFAULT_FREQS_MHZ = tuple(float(f) for f in np.arange(40.0, 101.0))  # SPEC: 40-100 MHz, 1 MHz steps


@dataclass(frozen=True)
class SolveSettings:
    """Which engine solves, at which frequencies, on how many processes."""

    engine: str = option("surface", "EM engine: surface (solid sheets, RWG; reproduces FEKO's beam over soil), "
                         "nec (NEC-2 wire grids, the cross-check) or fdtd (gprMax's FDTD, the referee: a volume, "
                         "time-domain method; minutes to an hour a run)")
    freqs_mhz: tuple[float, ...] = option(DEFAULT_FREQS_MHZ, "frequencies (MHz): LO:HI:STEP (inclusive), a comma "
                                          "list, or fit-band (55:97:1, all the FoM uses) (default 40:100:1)",
                                          flag="--freqs", parse=parse_freqs)
    workers: int = option(2, "parallel solver processes (0: in this process), kept from one solve to the next")

    def __post_init__(self) -> None:
        if self.workers < 0:
            raise SettingsError(f"workers must be >= 0, got {self.workers}")
        _freqs(self.freqs_mhz)


class EngineRegistry(Mapping):
    """Registered engines by name. Each engine sub-package registers its solver class when
    imported; the registry imports them on first read, so a command that never solves
    (``groundplane fom``) never imports an engine's physics (scipy.spatial, PyNEC...)."""

    def __init__(self) -> None:
        self._engines: dict[str, type] = {}
        self._loaded = False

    def _load(self) -> None:
        if not self._loaded:
            self._loaded = True
            import importlib
            import pkgutil

            package = importlib.import_module(__name__.rsplit(".", 1)[0])
            for m in pkgutil.iter_modules(package.__path__):
                if m.ispkg:
                    importlib.import_module(f"{package.__name__}.{m.name}")

    def __getitem__(self, name: str) -> type:
        self._load()
        return self._engines[name]

    def __iter__(self) -> Iterator[str]:
        self._load()
        return iter(self._engines)

    def __len__(self) -> int:
        self._load()
        return len(self._engines)

    def add(self, cls: type) -> None:
        self._engines[cls.name] = cls

    def pop(self, name: str) -> type:
        """Unregister an engine (a plug-in's test cleans up after itself)."""
        return self._engines.pop(name)


ENGINES: EngineRegistry = EngineRegistry()
"""Registered engines by name (each engine package registers its solver class)."""


def register_engine(cls: type) -> type:
    """Class decorator: make an engine (a concrete :class:`Solver` with a ``name`` and a
    ``settings_class``) available to every command that solves."""
    import inspect

    if not (isinstance(cls, type) and issubclass(cls, Solver)) or inspect.isabstract(cls) or not cls.name:
        missing = sorted(getattr(cls, "__abstractmethods__", ())) if isinstance(cls, type) else []
        raise TypeError(f"{getattr(cls, '__name__', cls)}: an engine is a subclass of solvers.engines.base.Solver "
                        "with a name, a settings_class, engine_identity() and plan()"
                        + (f" (missing: {', '.join(missing)})" if missing else ""))
    ENGINES.add(cls)
    return cls


def make_solver(engine: str, settings: Any = None, **runtime: Any) -> "Solver":
    """An engine by name, with its settings (None: the engine's defaults)."""
    if engine not in ENGINES:
        raise SettingsError(f"unknown engine '{engine}'; choose one of {', '.join(ENGINES)}")
    cls = ENGINES[engine]
    return cls(settings if settings is not None else cls.settings_class(), **runtime)


@dataclass(frozen=True)
class Plan:
    """An engine's model of one design, ready to solve frequency by frequency.

    ``job(payload, freq)`` runs in a worker process and returns
    ``(gain [91, n_phi], extras {name: float})``; ``meta`` goes into the beam's metadata.
    A ``broadband`` plan's job is called once, in this process, for every frequency left:
    ``job(payload, freqs)`` returns ``[(freq, (gain, extras), seconds)]`` (a time-domain engine
    gets all frequencies from one run, which runs its own threads).
    """

    job: Callable[[Any, Any], Any]
    payload: Any
    n_phi: int  # 91: one quadrant, mirrored; 360: the full circle
    meta: dict[str, Any] = field(default_factory=dict)
    label: str = ""
    broadband: bool = False


def _timed(args: tuple) -> tuple[float, Any, float]:
    """(frequency, what the plan's job returned, seconds), in a worker."""
    job, payload, freq = args
    t0 = time.perf_counter()
    out = job(payload, freq)
    return freq, out, time.perf_counter() - t0


class Solver(ABC):
    """An EM engine as the rest of the toolkit sees it. A subclass declares ``name``,
    ``settings_class`` (its model's options), ``model_version`` and its capabilities
    (``grounds``: what it can put under a design; ``antenna_parts``: whether it models the
    antenna's extra parts), and implements :meth:`engine_identity` and :meth:`plan`; it may
    refine :meth:`check`, :meth:`share_key` / :meth:`plan_group` (designs solved together) and
    the report hooks. Everything else (the cache by content, resuming per frequency, one worker
    process per frequency, several designs at once) is this class's."""

    name: ClassVar[str] = ""
    settings_class: ClassVar[type] = object
    model_version: ClassVar[int] = 1
    grounds: ClassVar[tuple[str, ...]] = ("soil", "pec")  # what the engine can put under a design
    antenna_parts: ClassVar[bool] = False  # models groundplane.antenna.AntennaParts (balun, top plate, ...)

    def __init__(self, settings: Any = None, *, workers: int = 2, progress: bool = False,
                 use_cache: bool = True) -> None:
        self.settings = settings if settings is not None else self.settings_class()
        self.workers = workers  # processes; 0 runs the engine in this process
        self.progress = progress
        self.use_cache = use_cache

    @property
    def processes(self) -> int:
        """Processes a solve runs at once (what memory must hold): the workers asked for,
        capped at the machine's cores as :func:`usable_workers` caps them; 1 in-process."""
        return core_capped(self.workers)

    # --------------------------------------------------------------- engine hooks
    @abstractmethod
    def engine_identity(self) -> dict[str, str]:
        """What computed the beams besides the model (engine, its version, what it links):
        part of every cache key."""

    #: the engine and its plate model in words, for reports
    title: ClassVar[str] = ""
    #: unit of model_size in tables
    size_unit: ClassVar[str] = "unknowns"

    def known_differences(self) -> list[str]:
        """How this engine's model is known to differ from the paper's FEKO model (each with
        the results file that measured it), for reports that explain a gap."""
        return []

    def input_deck(self, design: Design, freqs_mhz: Iterable[float]) -> str:
        """The engine's own input file for ``design`` (for running it outside the toolkit)."""
        raise SettingsError(f"the {self.name} engine has no input deck to write")

    def model_size(self, meta: dict[str, Any]) -> str:
        """How big the solved model was, in the engine's own unit, from a beam's meta."""
        return f"{meta.get('n_' + self.size_unit, '?')} {self.size_unit}"

    #: (floor, recommended) cells of the plane's mesh per free-space wavelength at the top frequency:
    #: below the floor a solve is refused, between the two its beam carries a ``mesh_note``
    cells_per_wavelength: ClassVar[tuple[float, float]] = (2.0, 6.0)

    def mesh_cell_m(self, design: Design) -> float | None:
        """The largest cell of the model's plane mesh (m), what :attr:`cells_per_wavelength` measures;
        None when the model has no plane mesh (the blade alone)."""
        spacing = getattr(self.settings, "spacing", None)
        return float(spacing) if design.plane is not None and spacing is not None else None

    def mesh_note(self, design: Design, freqs: np.ndarray) -> str | None:
        """Refuse a mesh too coarse for the top frequency (:class:`SettingsError`); the note a report
        carries when it is coarser than recommended, else None. Before the rule, a NEC-2 plate
        meshed at 3 m (1 cell per wavelength at 97 MHz) scored square-10 at 8862.8 mK, not ~220."""
        cell = self.mesh_cell_m(design)
        if cell is None or freqs.size == 0:
            return None
        floor, recommended = self.cells_per_wavelength
        top = float(np.max(freqs))
        per_wavelength = 299.792458 / top / cell
        if per_wavelength < floor:
            raise SettingsError(
                f"{design.label()}: a {cell:g} m {self.name} mesh is {per_wavelength:.2f} cells per wavelength at "
                f"{top:g} MHz, below this engine's floor of {floor:g} (at most {299.792458 / top / floor:.3g} m; "
                f"{299.792458 / top / recommended:.3g} m recommended): its FoM would be the mesh's, not the plane's")
        if per_wavelength < recommended:
            return (f"{self.name} mesh {cell:g} m is {per_wavelength:.1f} cells per wavelength at {top:g} MHz (recommended "
                    f">= {recommended:g}, {299.792458 / top / recommended:.3g} m): a coarse look, its FoM not to be trusted")
        return None

    def why_unresolved(self, plane: Any) -> str | None:
        """Why this engine's model would not be the plane as drawn (None when it is): an engine
        whose mesh moves the outline says where. A conforming mesh keeps every edge."""
        return None

    def check(self, design: Design) -> None:
        """Refuse a design this solver cannot do right, before any work: a ground or antenna
        parts outside its declared capabilities (engines add their own checks)."""
        if design.ground_kind not in self.grounds:
            raise SettingsError(f"{design.label()}: the {self.name} engine cannot solve over {design.ground_kind!r} "
                                f"ground (it solves over {', '.join(self.grounds)})")
        if design.antenna.parts is not None and not self.antenna_parts:
            raise SettingsError(f"{design.label()}: the {self.name} engine models the bare blade; antenna parts "
                                f"({design.antenna.parts.label()}) need an engine that models them (--engine nec)")

    @abstractmethod
    def plan(self, design: Design) -> Plan:
        """The engine's model of ``design``, ready to solve frequency by frequency."""

    @staticmethod
    def quadrant(design: Design) -> bool:
        """Whether one azimuth quadrant is solved and mirrored (the blade alone, or a plane
        symmetric about both axes) rather than the full circle."""
        return design.plane is None or all(design.plane.mirror_symmetry.values())

    @staticmethod
    def meshed(design: Design, build: Callable[[], Any]) -> Any:
        """``build()`` (an engine's meshing of ``design``), any failure of the geometry
        libraries (triangle, shapely) named with the candidate it happened to."""
        try:
            return build()
        except (SolveError, SettingsError):
            raise
        except Exception as exc:
            raise SolveError(f"{design.label()}: could not mesh the model ({exc})") from exc

    def share_key(self, design: Design) -> str | None:
        """Designs with one share key (not None) are solved together by :meth:`solve_many`, every
        member at a frequency in one job, because what differs between them (the soil's values)
        is cheap beside what they share. None (the default): the design is solved alone."""
        return None

    def plan_group(self, designs: list[Design]) -> Plan:
        """One plan for designs of one share key: its job returns [(gain, extras, seconds)],
        one per design in order. Engines that share work define it with :meth:`share_key`."""
        raise NotImplementedError(f"the {self.name} engine solves designs one at a time")

    # ------------------------------------------------------------------- caching
    def identity(self, design: Design, freqs: np.ndarray) -> dict[str, Any]:
        return {
            "model_version": self.model_version,
            "design": json.loads(design.canonical()),
            "engine": self.engine_identity(),
            "mesh": self.settings.as_dict(),
            "freqs_mhz": [round(float(f), 9) for f in freqs],
        }

    def cache_key(self, design: Design, freqs_mhz: Iterable[float]) -> str:
        ident = self.identity(design, _freqs(freqs_mhz))
        return hashlib.sha256(json.dumps(ident, sort_keys=True).encode()).hexdigest()[:32]

    def cached(self, design: Design, freqs_mhz: Iterable[float] = DEFAULT_FREQS_MHZ) -> Beam | None:
        """The cached beam of this solve, or None; never solves."""
        from .cache import BeamCache

        return BeamCache().get(self.cache_key(design, freqs_mhz))

    def solve_every(self) -> int:
        """Solve every n-th frequency and fill the rest (:mod:`.frequency_fill`): 1 unless an engine's
        settings ask for more (only where it is validated: the surface engine's ``solve_every``)."""
        return 1

    def _to_solve(self, freqs: np.ndarray) -> np.ndarray:
        from .frequency_fill import check_fill, solved_indices

        solved = freqs[solved_indices(len(freqs), self.solve_every())]
        if len(solved) < len(freqs):
            check_fill(freqs, solved)
        return solved

    # --------------------------------------------------------------------- solve
    def solve(self, design: Design, freqs_mhz: Iterable[float] = DEFAULT_FREQS_MHZ) -> Beam:
        """The design's beam at ``freqs_mhz`` (from the cache when it is there)."""
        refuse_while_spawning()
        freqs = _freqs(freqs_mhz)
        solved = self._to_solve(freqs)  # a fill outside what was validated is refused before anything is built
        note = self.mesh_note(design, freqs)
        return _noted(self._solve(design, freqs, solved), note)

    def _solve(self, design: Design, freqs: np.ndarray, solved: np.ndarray) -> Beam:
        from .cache import BeamCache

        cache = BeamCache() if self.use_cache else None
        key = self.cache_key(design, freqs)
        if cache is not None and (hit := cache.get(key)) is not None:
            return hit
        self.check(design)
        plan = self.plan(design)
        with cache.lock(key, f"{self.name} {plan.label}") if cache is not None else nullcontext():
            if cache is not None and (hit := cache.get(key)) is not None:  # solved by another process meanwhile
                return hit
            results = cache.partial(key) if cache is not None else {}
            todo = [float(f) for f in solved if float(f) not in results]
            for f, (gain, extras), secs in self._run(plan, todo, design, solved.size):
                results[f] = (gain, secs, extras)
                if cache is not None:
                    cache.put_partial(key, f, gain, secs, **extras)
            beam = self._assemble(design, freqs, plan, results, key)
            if cache is not None:
                cache.put(key, beam)
            return beam

    def solve_many(self, designs: list[Design], freqs_mhz: Iterable[float] = DEFAULT_FREQS_MHZ) -> list[Beam]:
        """The beams of several designs (a scenario set's members), in order: each from the
        cache when it is there; designs of one :meth:`share_key` solved together, the rest
        one by one. The same beams (and cache entries) as :meth:`solve` of each."""
        from .cache import BeamCache

        refuse_while_spawning()
        freqs = _freqs(freqs_mhz)
        self._to_solve(freqs)  # refused here, not after the first design's build
        notes = [self.mesh_note(d, freqs) for d in designs]
        cache = BeamCache() if self.use_cache else None
        keys = [self.cache_key(d, freqs) for d in designs]
        beams: dict[str, Beam] = {}
        groups: dict[str, list[int]] = {}
        for i, (design, key) in enumerate(zip(designs, keys)):
            if key in beams or any(key == keys[j] for m in groups.values() for j in m):
                continue  # the same design twice: solved once
            if cache is not None and (hit := cache.get(key)) is not None:
                beams[key] = hit
                continue
            share = self.share_key(design)
            groups.setdefault(share if share is not None else f"alone {key}", []).append(i)
        for members in groups.values():
            if len(members) == 1:
                beams[keys[members[0]]] = self.solve(designs[members[0]], freqs)
                continue
            solved = self._solve_group([designs[i] for i in members], [keys[i] for i in members], freqs, cache)
            beams.update(zip((keys[i] for i in members), solved))
        return [_noted(beams[k], note) for k, note in zip(keys, notes)]

    def _solve_group(self, designs: list[Design], keys: list[str], freqs: np.ndarray, cache) -> list[Beam]:
        """Designs of one share key, every member at a frequency in one job; each member's
        frequencies cached as they finish, under its own key (resumable like :meth:`solve`)."""
        from contextlib import ExitStack

        for design in designs:
            self.check(design)
        plan = self.plan_group(designs)
        with ExitStack() as held:
            if cache is not None:
                for key in sorted(keys):  # one order for every process: no deadlock
                    held.enter_context(cache.lock(key, f"{self.name} {plan.label}"))
                hits = [cache.get(key) for key in keys]
                if all(h is not None for h in hits):  # solved by another process meanwhile
                    return hits  # type: ignore[return-value]
            results = [cache.partial(key) if cache is not None else {} for key in keys]
            solved = self._to_solve(freqs)
            todo = [float(f) for f in solved if any(float(f) not in r for r in results)]
            for f, outs, _ in self._run(plan, todo, designs[0], solved.size):
                for key, res, (gain, extras, secs) in zip(keys, results, outs):
                    res[f] = (gain, secs, extras)
                    if cache is not None:
                        cache.put_partial(key, f, gain, secs, **extras)
            beams = [self._assemble(d, freqs, plan, r, key) for d, r, key in zip(designs, results, keys)]
            if cache is not None:
                for key, beam in zip(keys, beams):
                    cache.put(key, beam)
            return beams

    def _run(self, plan: Plan, todo: list[float], design: Design, n_total: int):
        """Yield (freq, the job's result, seconds) as frequencies finish (saved one by one).

        A worker that dies (the OOM killer, a kill) breaks the pool; what finished is kept
        and the rest is tried once more in a fresh pool before the solve is called failed."""
        bar = None
        if self.progress:
            from groundplane.progress import Progress

            bar = Progress(n_total, f"{self.name} {plan.label}", "freq", initial=n_total - len(todo))
        left = list(todo)
        try:
            for attempt in (1, 2):
                try:
                    for out in self._attempt(plan, left):
                        left.remove(out[0])
                        if bar:
                            bar.update(1)
                        yield out
                    return
                except BrokenProcessPool as exc:
                    if attempt == 2:
                        raise SolveError(f"{design.label()}: a {self.name} worker process died twice "
                                         f"({len(left)} frequencies unsolved; "
                                         f"{unguarded_main_script() or 'out of memory?'})") from exc
                    print(f"{design.label()}: a {self.name} worker process died; retrying the {len(left)} "
                          "unsolved frequencies once", file=sys.stderr)
        except (SolveError, UserInputError):  # a user's mistake found inside a job stays one (exit 2)
            raise
        except SolverError as exc:
            raise SolveError(f"{design.label()}: {exc}") from exc
        except Exception as exc:  # the engine's own failure, in a worker: name the candidate
            raise SolveError(f"{design.label()}: {self.name} solve failed ({type(exc).__name__}: {exc})") from exc
        finally:
            if bar:
                bar.close()

    def _attempt(self, plan: Plan, todo: list[float]):
        if plan.broadband:
            if todo:
                yield from plan.job(plan.payload, todo)
            return
        jobs = [(plan.job, plan.payload, f) for f in todo]
        if not (self.workers >= 1 and todo):
            yield from map(_timed, jobs)
            return
        import threading

        n = usable_workers(self.workers, len(todo))
        # the main thread keeps its pool for the next solve (a search's next candidate); another
        # thread's solve has its own, so that one caller's interrupt never stops another's jobs
        shared = threading.current_thread() is threading.main_thread()
        pool = shared_pool(n, self.name) if shared else process_pool(n)
        futures = []
        try:
            futures = [pool.submit(_timed, job) for job in jobs]  # a kept pool may have broken since
            for fut in futures:
                yield fut.result()
        except (KeyboardInterrupt, GeneratorExit, BrokenProcessPool):
            # interrupted, or the caller stopped reading: abandon the frequencies in flight rather
            # than wait for them; a broken pool (a worker killed) is not kept either
            if shared:
                discard_shared_pool(terminate=True)
            else:
                terminate_pool(pool)
                pool = None
            raise
        except BaseException:  # a job failed: the others stop at the next frequency, not the next solve
            for fut in futures:
                fut.cancel()
            wait(futures)
            raise
        finally:
            if not shared and pool is not None:
                pool.shutdown(cancel_futures=True)

    def _assemble(self, design: Design, freqs_asked: np.ndarray, plan: Plan, results: dict, key: str) -> Beam:
        freqs = self._to_solve(freqs_asked)
        beam = self._assembled(design, freqs, plan, results, key)
        if len(freqs) == len(freqs_asked):
            return beam
        from .frequency_fill import filled

        return filled(beam, freqs_asked, self.solve_every())

    def _assembled(self, design: Design, freqs: np.ndarray, plan: Plan, results: dict, key: str) -> Beam:
        gains = np.stack([results[float(f)][0] for f in freqs])
        if plan.n_phi == 91:
            gains = mirror_quadrant(gains)
        # one value per frequency, aligned: a frequency resumed from a partial written without
        # some extra (an older run) holds NaN there, not a shorter list that shifts the rest
        names = sorted({k for f in freqs for k in results[float(f)][2]})
        extras = {k: [results[float(f)][2].get(k, float("nan")) for f in freqs] for k in names}
        return Beam(freqs, np.arange(91.0), np.arange(360.0), gains, {
            "source": f"{self.name} solve of {design.label()}",
            "solver": self.name,
            "gain_normalisation": "input_power",  # every engine's gain is 4 pi U / P_in (NEC's calibrated so)
            "engine": self.engine_identity(),
            "design": json.loads(design.canonical()),
            "mesh": self.settings.as_dict(),
            **plan.meta,
            "mirror_symmetric_solve": plan.n_phi == 91,
            **extras,
            "seconds_per_frequency": [results[float(f)][1] for f in freqs],
            "cache_key": key,
        })


MAX_FREQ_MHZ = 1e5  # 100 GHz: far above any ground-plane model here; a larger value is Hz passed as MHz


def _noted(beam: Beam, mesh_note: str | None) -> Beam:
    """The beam with the mesh rule's note in its meta (not in the cache: the note follows from the
    settings and frequencies, which the key already holds)."""
    return beam if mesh_note is None else beam.with_meta(mesh_note=mesh_note)


def _freqs(freqs_mhz: Iterable[float]) -> np.ndarray:
    f = np.asarray(list(freqs_mhz), dtype=float)
    if f.size == 0 or not np.all(np.isfinite(f)) or np.any(f <= 0):
        raise SettingsError("frequencies must be positive MHz")
    if np.any(f > MAX_FREQ_MHZ):  # the engines would mesh and solve at it for hours before anything failed
        raise SettingsError(f"frequencies are in MHz: {f.max():g} MHz is above {MAX_FREQ_MHZ:g} MHz "
                            f"(Hz given as MHz? 55e6 Hz is 55 MHz)")
    return f
