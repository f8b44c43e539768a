"""Worker processes for the engines: one BLAS thread each, spawned (engines bundle their own
OpenMP runtimes, which must not share a process with healpy's), dying with their parent, no
more of them than cores; and the memory a plan can count on."""
from __future__ import annotations

import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from groundplane.errors import UserInputError


def available_memory_bytes() -> int | None:
    """MemAvailable from /proc/meminfo (Linux), else None (no check), plus what the kept pool's
    workers hold beyond a fresh worker (:func:`shared_pool`): each lets its last design go before
    building the next, so that memory is the next solve's too; at most what this process's own
    limits leave (:func:`limit_left_bytes`)."""
    have = None
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                have = int(line.split()[1]) * 1024 + kept_worker_bytes()
                break
    except OSError:
        pass
    left = limit_left_bytes()
    return left if have is None else (have if left is None else min(have, left))


def limit_left_bytes() -> int | None:
    """What the process's address-space limit (``ulimit -v``, ``prlimit --as``) leaves beyond what
    it maps already, or None when it has none: under a 2 GB limit a solve the machine's memory
    allowed ran 98 s into a MemoryError. (Each worker inherits the limit; the solve's estimates,
    summed over its processes, are held to it as if it were shared: cautious by the worker count.)"""
    try:
        import resource
    except ImportError:  # not POSIX: no such limit to honour
        return None
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft == resource.RLIM_INFINITY:
        return None
    try:
        mapped = int(Path("/proc/self/statm").read_text().split()[0]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        mapped = 0
    return max(0, soft - mapped)


FRESH_WORKER_BYTES = 300 * 2**20  # a spawned worker with an engine imported keeps at least this (not released)


def kept_worker_bytes() -> int:
    """Resident memory of the kept pool's workers beyond ``FRESH_WORKER_BYTES`` each (Linux; 0 elsewhere)."""
    total = 0
    for pool in _SHARED.values():
        for proc in list((getattr(pool, "_processes", None) or {}).values()):
            try:
                resident_pages = int(Path(f"/proc/{proc.pid}/statm").read_text().split()[1])
            except (OSError, ValueError, IndexError):
                continue
            total += max(0, resident_pages * os.sysconf("SC_PAGE_SIZE") - FRESH_WORKER_BYTES)
    return total


def worker_init(parent_pid: int | None = None) -> None:
    """One BLAS/OpenMP thread per worker (frequencies run in parallel processes instead),
    and a worker that dies with its parent: a ``kill -9`` of a sweep must not leave NEC
    workers running for hours with nobody to read their results."""
    os.environ["OMP_NUM_THREADS"] = "1"
    os.environ["OPENBLAS_NUM_THREADS"] = "1"
    # numpy's BLAS is already loaded here (unpickling this function imported it) with a thread
    # per core: without this, two workers run four BLAS threads on two cores (measured: a fast
    # surface solve 2-2.5x slower per frequency with 2 workers than alone)
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1)
    if parent_pid is not None:
        _die_with_parent(parent_pid)


def _die_with_parent(parent_pid: int) -> None:
    import signal
    import threading

    if sys.platform.startswith("linux"):  # the kernel kills us when the parent goes (no library does this)
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    if os.getppid() != parent_pid:  # the parent died before we got here
        os._exit(1)

    def watch() -> None:  # elsewhere (and as a backstop): poll for re-parenting
        while os.getppid() == parent_pid:
            time.sleep(1.0)
        os._exit(1)

    threading.Thread(target=watch, daemon=True, name="die-with-parent").start()


def unguarded_main_script() -> str | None:
    """Why spawned workers die at once when the program is a script whose solve is not under
    ``if __name__ == "__main__":`` (each worker imports the script again, which solves again, which
    Python refuses in a worker) or was read from standard input (no file to import), or None: a
    guess from the script's text, said as one."""
    path = getattr(sys.modules.get("__main__"), "__file__", None)
    if path is not None and not Path(path).is_file():  # `python - <<EOF`: __file__ is '<stdin>'
        return (f"the program came from {path}, not a file, and the spawned worker processes must import it "
                "again: save it as a script with the solve under `if __name__ == \"__main__\":`, or use workers=0")
    try:
        text = Path(path).read_text() if path else None
    except (OSError, UnicodeDecodeError):
        return None
    if text is None or "__main__" in text:
        return None
    return (f"{path} has no `if __name__ == \"__main__\":` block: the worker processes are spawned and import "
            "the script again; put the solve under that block, or use workers=0")


def _is_main_test(test) -> bool:
    """Whether an ``if`` tests ``__name__ == "__main__"`` (either way round)."""
    import ast

    if not (isinstance(test, ast.Compare) and len(test.ops) == 1 and isinstance(test.ops[0], ast.Eq)):
        return False
    sides = [test.left, test.comparators[0]]
    return (any(isinstance(x, ast.Name) and x.id == "__name__" for x in sides)
            and any(isinstance(x, ast.Constant) and x.value == "__main__" for x in sides))


def unguarded_call_site() -> str | None:
    """``script, line N`` when the program is a script whose top-level code, outside
    ``if __name__ == "__main__":``, led to this call (found on the call stack, the block in the
    script's syntax tree), else None. Spawned workers import the script again and would run that
    code once each: every print, FoM and export three times with two workers."""
    import ast

    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    spec = getattr(main, "__spec__", None)
    if not path or not Path(path).is_file() or (spec is not None and spec.name.endswith("__main__")):
        return None  # `python -m package`: spawn does not run a package's __main__ again
    frame = sys._getframe(1)
    while frame is not None and not (frame.f_code.co_name == "<module>" and frame.f_globals.get("__name__") == "__main__"):
        frame = frame.f_back
    if frame is None or Path(frame.f_code.co_filename).resolve() != Path(path).resolve():
        return None
    line = frame.f_lineno
    try:
        tree = ast.parse(Path(path).read_text())
    except (OSError, UnicodeDecodeError, SyntaxError, ValueError):
        return None
    guarded = any(isinstance(n, ast.If) and _is_main_test(n.test) and n.lineno <= line <= (n.end_lineno or n.lineno)
                  for n in ast.walk(tree))
    return None if guarded else f"{path}, line {line}"


def refuse_unguarded_caller(workers: int) -> None:
    """Stop at once, in the parent and before any worker is spawned, a script that asks for worker
    processes from its unguarded top level (:func:`unguarded_call_site`)."""
    where = unguarded_call_site()
    if where is not None:
        raise UserInputError(f"{where}: a solve with workers runs at the script's top level, outside "
                             f"`if __name__ == \"__main__\":`; each of the {workers} spawned worker processes would "
                             "import the script and run it again (every print, FoM and export once more). Put the "
                             "script's work under that block, or use workers=0")


def refuse_while_spawning() -> None:
    """Refuse a solve started by a worker process while it is spawned (it imports the user's script
    again, which solves again): it would wait forever on the parent's cache lock of the same beam,
    where Python's own check refuses only later, at the pool's start. Refused, the worker dies and
    the parent says why (:func:`unguarded_main_script`). ``_inheriting`` is multiprocessing's flag
    for that phase (its ``spawn._check_not_importing_main`` reads the same)."""
    from multiprocessing import process

    if getattr(process.current_process(), "_inheriting", False):
        raise RuntimeError("a solve was started while this worker process was being spawned: "
                           + (unguarded_main_script() or "put the script's work under `if __name__ == \"__main__\":`"))


def core_capped(workers: int) -> int:
    """Processes that run at once for ``workers`` asked: at least one, at most the cores."""
    return max(1, min(workers, os.cpu_count() or 1))


def usable_workers(workers: int, jobs: int) -> int:
    """Worker processes worth starting: no more than the jobs or the machine's cores (each
    worker runs one BLAS thread); says so on stderr when it caps what was asked."""
    cores = os.cpu_count() or 1
    n = min(core_capped(workers), max(1, jobs))
    if workers > cores:
        print(f"--workers {workers}: this machine has {cores} cores; starting {n} worker process(es)", file=sys.stderr)
    return n


KEEP_POOL = True  # False: a pool spawned for every solve, as before 2026-12-04 (benchmarks/bench_shared_pool.py)
_SHARED: dict[tuple, ProcessPoolExecutor] = {}  # at most one entry: (engine, workers, environment) -> its pool


def shared_pool(workers: int, engine: str) -> ProcessPoolExecutor:
    """:func:`process_pool` of ``workers`` processes, kept for the next solve of this process: a
    search solves hundreds of candidates one after another, and spawning the workers and importing
    the engines cost ~2 s each time (docs/speed.md). A pool of another size is shut down first
    (a worker kept idle would hold its last design's model in memory beside the others), and so is
    one started under another environment (workers read theirs, e.g. ``GROUNDPLANE_CACHE``, once)
    or for another engine (the engines' own OpenMP runtimes do not load into one process: PyNEC
    after the surface engine's fails with "cannot allocate memory in static TLS block")."""
    key = (engine, workers, tuple(sorted(os.environ.items())))
    pool = _SHARED.get(key) if KEEP_POOL else None
    if pool is None or getattr(pool, "_broken", False):  # a worker killed while the pool waited (OOM killer, a user)
        discard_shared_pool()
        pool = _SHARED[key] = process_pool(workers)
    return pool


def discard_shared_pool(terminate: bool = False) -> None:
    """Shut the kept pool down (``terminate``: its workers killed first, for an interrupted or broken
    solve whose jobs must not run on); the next :func:`shared_pool` starts a new one."""
    for pool in _SHARED.values():
        if terminate:
            terminate_pool(pool)
        else:
            pool.shutdown(wait=True, cancel_futures=True)
    _SHARED.clear()


def terminate_pool(pool: ProcessPoolExecutor) -> None:
    """Kill ``pool``'s workers (their running jobs with them) and shut it down."""
    for proc in list((getattr(pool, "_processes", None) or {}).values()):  # no public way to stop a running job
        proc.terminate()
    pool.shutdown(wait=True, cancel_futures=True)


def process_pool(workers: int) -> ProcessPoolExecutor:
    """Spawned worker processes (engines bundle their own OpenMP runtimes, which must not
    share a process with healpy's) that die with this process."""
    import multiprocessing as mp

    refuse_unguarded_caller(workers)
    return ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context("spawn"), initializer=worker_init,
                               initargs=(os.getpid(),))
