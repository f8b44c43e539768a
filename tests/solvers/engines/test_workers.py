"""Engine worker processes: they die with their parent, and a worker killed mid-solve
(as the OOM killer would) costs a retry, not the candidate. Real processes, real kills."""
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from groundplane.design import Design, Soil
from groundplane.errors import SolveError
from groundplane.shapes import Square
from solvers.engines.base import Plan, Solver

ROOT = Path(__file__).resolve().parents[3]


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    state = Path(f"/proc/{pid}/stat").read_text().split()[2] if Path(f"/proc/{pid}/stat").exists() else "X"
    return state not in ("Z", "X")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_workers_die_when_the_parent_is_killed(tmp_path):
    script = textwrap.dedent(f"""
        import os, sys, time
        sys.path.insert(0, {str(ROOT)!r})
        from solvers.engines.workers import process_pool
        from tests.solvers.engines.test_workers import sleeper
        pool = process_pool(2)
        futs = [pool.submit(sleeper, {str(tmp_path)!r}) for _ in range(2)]
        time.sleep(600)
    """)
    parent = subprocess.Popen([sys.executable, "-c", script], cwd=ROOT)
    try:
        deadline = time.time() + 60
        while len(list(tmp_path.glob("*.pid"))) < 2 and time.time() < deadline:
            time.sleep(0.2)
        pids = [int(p.read_text()) for p in tmp_path.glob("*.pid")]
        assert len(pids) == 2 and all(_alive(p) for p in pids)
        parent.send_signal(signal.SIGKILL)
        parent.wait()
        deadline = time.time() + 10
        while any(_alive(p) for p in pids) and time.time() < deadline:
            time.sleep(0.2)
        assert not any(_alive(p) for p in pids), "workers outlived their killed parent"
    finally:
        parent.kill()


def sleeper(folder: str) -> None:
    """Worker job: say who we are, then work for a long time."""
    Path(folder, f"{os.getpid()}.pid").write_text(str(os.getpid()))
    time.sleep(300)


def dies_once(payload: str, freq: float):
    """Worker job: the first time 60 MHz is solved, the worker is killed outright."""
    marker = Path(payload) / "killed"
    if freq == 60.0 and not marker.exists():
        marker.write_text("1")
        os.kill(os.getpid(), signal.SIGKILL)
    return np.full((91, 91), freq), {}


def always_dies(payload: str, freq: float):
    os.kill(os.getpid(), signal.SIGKILL)


class StandIn(Solver):
    name = "stand-in"

    def __init__(self, job, folder, **kw):
        super().__init__(None, **kw)
        self.job, self.folder = job, folder

    def engine_identity(self):
        return {"engine": "stand-in"}

    def plan(self, design):
        return Plan(self.job, str(self.folder), 91, {}, "stand-in")


def test_a_killed_worker_is_retried_once(tmp_path):
    solver = StandIn(dies_once, tmp_path, workers=2, use_cache=False)
    solver.settings_class = object
    solver.settings = type("S", (), {"as_dict": lambda self: {}})()
    beam = solver.solve(Design(Square(2.0), Soil()), [50.0, 60.0, 70.0])
    assert (tmp_path / "killed").exists()
    assert np.allclose(beam.gain[:, 0, 0], [50.0, 60.0, 70.0])
    solver = StandIn(always_dies, tmp_path, workers=1, use_cache=False)
    solver.settings = type("S", (), {"as_dict": lambda self: {}})()
    with pytest.raises(SolveError, match=r"Square\(side=2.0\).*worker process died twice"):
        solver.solve(Design(Square(2.0), Soil()), [50.0])


def counted(payload: str, freq: float):
    """Worker job: note each solve, take a moment."""
    Path(payload, f"{freq:g}-{time.monotonic_ns()}").write_text("")
    time.sleep(0.3)
    return np.full((91, 91), freq), {}


def test_the_same_design_asked_twice_at_once_is_solved_once(tmp_path, monkeypatch, capsys):
    import threading

    monkeypatch.setenv("GROUNDPLANE_CACHE", str(tmp_path / "cache"))
    jobs = tmp_path / "jobs"
    jobs.mkdir()

    def make():
        s = StandIn(counted, jobs, workers=0)
        s.settings = type("S", (), {"as_dict": lambda self: {}})()
        return s

    beams = []
    first = threading.Thread(target=lambda: beams.append(make().solve(Design(Square(2.0), Soil()), [50.0, 60.0])))
    first.start()
    time.sleep(0.15)  # the first holds the design's lock and is solving
    beams.append(make().solve(Design(Square(2.0), Soil()), [50.0, 60.0]))
    first.join()
    assert len(list(jobs.iterdir())) == 2, "each frequency solved once, not once per caller"
    assert np.array_equal(beams[0].gain, beams[1].gain)
    assert "another process is solving this design; waiting for it" in capsys.readouterr().err


def test_stray_temp_files_of_a_killed_write_are_cleaned_under_the_lock(tmp_path):
    from solvers.engines.cache import TMP_SUFFIX, BeamCache

    cache = BeamCache(tmp_path)
    key = "k" * 32
    stray_beam = tmp_path / "beams" / f"{key}.npz.abc{TMP_SUFFIX}"
    stray_beam.write_bytes(b"half")
    other = tmp_path / "beams" / f"{'j' * 32}.npz.abc{TMP_SUFFIX}"  # another key's: not ours to touch
    other.write_bytes(b"half")
    (tmp_path / "partial" / key).mkdir(parents=True)
    stray_part = tmp_path / "partial" / key / f"50.000000.npz.xyz{TMP_SUFFIX}"
    stray_part.write_bytes(b"half")
    with cache.lock(key):
        assert not stray_beam.exists() and not stray_part.exists()
    assert other.exists()


def test_memory_is_checked_for_the_processes_that_will_run_not_the_workers_asked(monkeypatch):
    """--workers 50 on 2 cores starts 2 processes: the memory estimate counts 2, not 50."""
    from groundplane.errors import SettingsError
    from solvers.engines.surface import SurfaceSettings, SurfaceSolver
    from solvers.engines.surface import solver as surface_solver

    monkeypatch.setattr(os, "cpu_count", lambda: 2)
    solver = SurfaceSolver(SurfaceSettings(spacing=2.0), workers=50)
    assert solver.processes == 2
    assert SurfaceSolver(workers=0).processes == 1
    monkeypatch.setattr(surface_solver, "available_memory_bytes", lambda: 1)
    with pytest.raises(SettingsError, match=r"on 2 process\(es\)"):
        solver.plan(Design(Square(10.0), Soil()))


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="POSIX signals")
def test_sigterm_mid_solve_exits_cleanly_and_keeps_what_finished(tmp_path):
    """SIGTERM (a batch system's kill) was Python's default: an instant death and 'leaked
    semaphore objects' from the pool. Now: one line, status 143, workers gone, solved frequencies kept."""
    env = {**os.environ, "GROUNDPLANE_CACHE": str(tmp_path / "cache")}
    cmd = [sys.executable, "-m", "groundplane", "solve", "--preset", "square-10", "--mesh", "2.0",
           "--freqs", "40:70:1", "-o", str(tmp_path / "b.npz")]
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.time() + 120
        while not list((tmp_path / "cache" / "partial").glob("*/*.npz")) and time.time() < deadline:
            time.sleep(0.2)
        assert list((tmp_path / "cache" / "partial").glob("*/*.npz")), "no frequency finished"
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=30)
    finally:
        proc.kill()
    assert proc.returncode == 143, err
    assert "terminated (what was finished is kept)" in err and "leaked" not in err
    assert not (tmp_path / "b.npz").exists()
    assert list((tmp_path / "cache" / "partial").glob("*/*.npz"))  # a rerun resumes from these


def test_frequencies_given_in_hz_are_refused_not_solved_for_hours():
    """``solve(design, np.arange(55, 98) * 1e6)`` (Hz where the API takes MHz) meshed and built the
    near series at 55 THz, where its term count loops for ever; now it is refused by name."""
    import numpy as np

    from groundplane.errors import SettingsError
    from solvers.engines.surface import SurfaceSettings, SurfaceSolver
    from solvers.engines.surface.pfft import NearSeries

    solver = SurfaceSolver(SurfaceSettings(spacing=2.0), workers=0, use_cache=False)
    with pytest.raises(SettingsError, match=r"in MHz: 9\.7e\+07 MHz .*Hz given as MHz"):
        solver.solve(Design(Square(10.0), Soil()), np.arange(55.0, 98.0) * 1e6)
    series = NearSeries.__new__(NearSeries)
    series.k_max = 2e6
    with pytest.raises(ValueError, match="beyond the series' reach"):
        series._n_terms(3.0)
    series.k_max = 3.35
    assert 10 < series._n_terms(3.0) < 60


def worker_pid(payload: str, freq: float):
    """Worker job: which process solved it."""
    time.sleep(0.05)
    return np.full((91, 91), float(os.getpid())), {}


def fails_at_60(payload: str, freq: float):
    if freq == 60.0:
        raise RuntimeError("no convergence at 60 MHz")
    return worker_pid(payload, freq)


def _stand_in(job, folder, workers):
    solver = StandIn(job, folder, workers=workers, use_cache=False)
    solver.settings = type("S", (), {"as_dict": lambda self: {}})()
    return solver


def test_successive_solves_share_their_worker_processes(tmp_path, monkeypatch):
    """A search solves candidate after candidate: the workers (spawned, the engines imported: ~2 s)
    are kept from one solve to the next, through a job's failure, until a solve asks for another number."""
    from solvers.engines.workers import discard_shared_pool

    discard_shared_pool()
    pids = set()
    for side in (2.0, 3.0, 4.0):
        beam = _stand_in(worker_pid, tmp_path, 2).solve(Design(Square(side), Soil()), [50.0, 60.0, 70.0])
        pids |= set(beam.gain[:, 0, 0].astype(int))
    assert os.getpid() not in pids and 1 <= len(pids) <= 2, "three solves, one pool of two workers"
    with pytest.raises(SolveError, match="no convergence at 60 MHz"):
        _stand_in(fails_at_60, tmp_path, 2).solve(Design(Square(5.0), Soil()), [50.0, 60.0, 70.0, 80.0, 90.0])
    beam = _stand_in(worker_pid, tmp_path, 2).solve(Design(Square(6.0), Soil()), [50.0, 60.0])
    assert set(beam.gain[:, 0, 0].astype(int)) <= pids, "a job's failure leaves the pool working"
    one = _stand_in(worker_pid, tmp_path, 1).solve(Design(Square(7.0), Soil()), [50.0, 60.0])
    assert len(set(one.gain[:, 0, 0])) == 1, "--workers 1: one process"
    assert not any(_alive(p) for p in pids), "another size of pool: the two workers were shut down"
    first = set(_stand_in(worker_pid, tmp_path, 1).solve(Design(Square(8.0), Soil()), [50.0]).gain[:, 0, 0])
    monkeypatch.setenv("GROUNDPLANE_CACHE", str(tmp_path / "elsewhere"))
    second = set(_stand_in(worker_pid, tmp_path, 1).solve(Design(Square(9.0), Soil()), [50.0]).gain[:, 0, 0])
    assert first == set(one.gain[:, 0, 0]) and not first & second, "a worker reads its environment once"

    class OtherEngine(StandIn):
        name = "other-stand-in"

    other = OtherEngine(worker_pid, tmp_path, workers=1, use_cache=False)
    other.settings = type("S", (), {"as_dict": lambda self: {}})()
    third = set(other.solve(Design(Square(9.5), Soil()), [50.0]).gain[:, 0, 0])
    assert not third & second, "each engine its own workers (their OpenMP runtimes do not mix)"
    discard_shared_pool()


def holds_memory(payload: str, freq: float):
    """Worker job: keep ~800 MB resident after returning (as a kept worker keeps its last design)."""
    global _HELD
    _HELD = np.ones(100_000_000)  # 800 MB, touched
    return np.full((91, 91), freq), {}


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_memory_a_kept_worker_holds_counts_as_available():
    """The memory check before a solve must not refuse a design for memory the kept workers will let go."""
    from solvers.engines.workers import discard_shared_pool, kept_worker_bytes

    discard_shared_pool()
    assert kept_worker_bytes() == 0
    _stand_in(holds_memory, ".", 1).solve(Design(Square(2.0), Soil()), [50.0])
    assert kept_worker_bytes() > 400 * 2**20
    discard_shared_pool()
    assert kept_worker_bytes() == 0


def test_a_script_without_a_main_block_is_named_when_its_workers_die(tmp_path, monkeypatch):
    """A script that solves at its top level makes every spawned worker import it and solve again
    (refused by Python): the pool breaks twice, and the error said 'out of memory?'. It names the cause."""
    import types

    from solvers.engines.workers import unguarded_main_script

    script = tmp_path / "survey.py"
    script.write_text("from groundplane.api import solve\nbeam = solve('square-10')\n")
    monkeypatch.setitem(sys.modules, "__main__", types.SimpleNamespace(__file__=str(script)))
    assert "survey.py has no `if __name__" in unguarded_main_script()
    script.write_text("if __name__ == '__main__':\n    pass\n")
    assert unguarded_main_script() is None
    monkeypatch.setitem(sys.modules, "__main__", types.SimpleNamespace())  # a notebook, the REPL
    assert unguarded_main_script() is None
    monkeypatch.setitem(sys.modules, "__main__", types.SimpleNamespace(__file__="<stdin>"))  # python - <<EOF
    assert "came from <stdin>, not a file" in unguarded_main_script()


def test_a_program_read_from_stdin_fails_with_the_cause_not_out_of_memory(tmp_path):
    """`python - <<EOF` with workers: each spawned worker tries to import '<stdin>' again and dies; the
    error guessed 'out of memory?'. It names the cause."""
    program = textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {str(ROOT)!r})
        import groundplane as gp
        beam = gp.solve("square-10", freqs="40:70:15", mesh=2.0, blade_cells=(4, 4), workers=2)
        print("solved")
    """)
    env = {**os.environ, "GROUNDPLANE_CACHE": str(tmp_path / "cache")}
    done = subprocess.run([sys.executable, "-"], input=program, cwd=tmp_path, env=env, capture_output=True,
                          text=True, timeout=240)
    assert done.returncode != 0 and "solved" not in done.stdout
    assert "came from <stdin>, not a file" in done.stderr.splitlines()[-1]


def test_a_script_without_a_main_block_fails_with_the_cause_instead_of_waiting_forever(tmp_path):
    """Run as a new user would, a real script: each spawned worker imports it again and its solve
    asked for the beam the parent holds the cache lock of, so it waited for the parent, which waited
    for its workers: a silent hang. The worker now refuses at once and the parent names the cause."""
    script = tmp_path / "survey.py"
    script.write_text(textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {str(ROOT)!r})
        import groundplane as gp
        beam = gp.solve("square-10", freqs="40:70:15", mesh=2.0, blade_cells=(4, 4), workers=2)
        print("solved")
    """))
    env = {**os.environ, "GROUNDPLANE_CACHE": str(tmp_path / "cache")}
    try:
        done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env, capture_output=True, text=True,
                              timeout=240)
    except subprocess.TimeoutExpired:
        pytest.fail("a script without a main block hung instead of failing")
    assert done.returncode != 0 and "solved" not in done.stdout
    assert "survey.py, line 5: a solve with workers runs at the script's top level" in done.stderr.splitlines()[-1]


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="POSIX signals")
def test_a_kept_worker_killed_between_solves_costs_nothing(tmp_path, capsys):
    """The OOM killer (or a user) may kill an idle kept worker: the next solve starts a new pool
    instead of failing twice on the broken one."""
    from solvers.engines.workers import discard_shared_pool

    discard_shared_pool()
    first = _stand_in(worker_pid, tmp_path, 2).solve(Design(Square(2.0), Soil()), [50.0, 60.0])
    for pid in set(first.gain[:, 0, 0].astype(int)):
        os.kill(int(pid), signal.SIGKILL)
    time.sleep(0.5)
    beam = _stand_in(worker_pid, tmp_path, 2).solve(Design(Square(3.0), Soil()), [50.0, 60.0])
    assert not set(beam.gain[:, 0, 0].astype(int)) & set(first.gain[:, 0, 0].astype(int))
    discard_shared_pool()
