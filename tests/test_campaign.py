"""The input contract as a campaign that cannot rot: generated bad values, types, files and
documents driven through the commands' parsers and loaders. Each case ends in exit 0 with finite
numbers, exit 2 with one line naming the input, or exit 1 with one line naming the solver; never
a traceback; file readers under a memory ceiling. A fast slice runs by default (a few dozen
examples per front door); ``pytest -m slow tests/test_campaign.py`` runs the long campaign."""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from groundplane.cli import main
from groundplane.errors import UserInputError
from tests.conftest import ROOT

FAST = settings(max_examples=25, deadline=None, suppress_health_check=list(HealthCheck))
LONG = settings(max_examples=400, deadline=None, suppress_health_check=list(HealthCheck))
EXAMPLE = str(ROOT / "examples" / "lowband_square10_nec.npz")
MEMORY_CEILING = 3 * 2**30  # bytes of address space a reader may take (numpy's own import takes ~1 GiB)

json_values = st.recursive(
    st.none() | st.booleans() | st.integers(-10**6, 10**6) | st.floats(allow_nan=True, allow_infinity=True)
    | st.text(max_size=12),
    lambda children: st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=8), children, max_size=4),
    max_leaves=12)
numbers = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**9, 10**9))
texts = st.text(alphabet=st.characters(blacklist_categories=("Cs",)), max_size=16)


def run(argv: list[str], capsys) -> tuple[int, str, str]:
    """``groundplane ARGV`` in this process: (exit status, stdout, stderr); a traceback (any
    exception the command line does not turn into a status) fails the test with its input."""
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's own refusals
        code = exc.code if isinstance(exc.code, int) else 2
    except Exception as exc:  # noqa: BLE001 - this is what the campaign hunts
        raise AssertionError(f"traceback for {argv}: {type(exc).__name__}: {exc}") from exc
    out = capsys.readouterr()
    return code, out.out, out.err


def assert_contract(code: int, out: str, err: str, argv: list[str]) -> None:
    """0 with finite numbers, or 1/2 with one line that says what failed."""
    assert code in (0, 1, 2), (code, argv, err)
    if code == 0:
        assert "nan" not in out.lower().split() and " inf " not in out.lower(), (argv, out)
    else:
        lines = [line for line in err.splitlines() if line.strip() and not line.startswith("groundplane: warning")
                 and not (line.startswith("[") and line[1:3].isdigit())]  # progress lines before the error
        assert lines and len(lines) <= 2 and "Traceback" not in err, (argv, err)
        assert lines[-1].startswith("groundplane") or "error:" in lines[-1], (argv, err)


# ------------------------------------------------------------------ fom options
fom_flags = st.sampled_from(["--nu0", "--beta", "--terms", "--lst-bin", "--antenna-azimuth", "--lat", "--lon",
                             "--site", "--fit-band", "--sky"])


@FAST
@given(flags=st.lists(st.tuples(fom_flags, st.one_of(texts, numbers.map(str))), min_size=1, max_size=3))
def test_fom_options_fast(flags, capsys):
    _fom_options(flags, capsys)


@pytest.mark.slow
@LONG
@given(flags=st.lists(st.tuples(fom_flags, st.one_of(texts, numbers.map(str))), min_size=1, max_size=4))
def test_fom_options_long(flags, capsys):
    _fom_options(flags, capsys)


def _fom_options(flags, capsys):
    argv = ["fom", EXAMPLE, "--n-lst", "24"]
    for flag, value in flags:
        argv += [flag, value, value] if flag == "--fit-band" else [flag, value]
    if "--sky" in argv and argv[argv.index("--sky") + 1] not in ("haslam",):
        argv[argv.index("--sky") + 1] = "lfsm-not-a-sky"  # the other skies are slow to build; refused is enough
    code, out, err = run(argv, capsys)
    assert_contract(code, out, err, argv)


# ------------------------------------------------------------------ design files
design_docs = st.one_of(
    json_values,
    st.fixed_dictionaries({"shape": st.sampled_from(["square", "sawtooth", "teeth-xy", "polygon", "star"]) | json_values},
                          optional={"side": numbers | json_values, "teeth_per_side": numbers | json_values,
                                    "tooth_base": numbers, "tooth_height": numbers, "vertices": json_values,
                                    "n_points": numbers, "outer_radius": numbers, "inner_radius": numbers}),
    st.fixed_dictionaries({"preset": json_values | st.sampled_from(["square-10", "nope"])}),
    st.fixed_dictionaries({"params": json_values, "shape": json_values | st.just("teeth")}))


@FAST
@given(doc=design_docs)
def test_design_files_fast(doc, tmp_path_factory, capsys):
    _design_file(doc, tmp_path_factory.mktemp("d"), capsys)


@pytest.mark.slow
@LONG
@given(doc=design_docs)
def test_design_files_long(doc, tmp_path_factory, capsys):
    _design_file(doc, tmp_path_factory.mktemp("d"), capsys)


def _design_file(doc, folder: Path, capsys) -> None:
    f = folder / "design.json"
    f.write_text(json.dumps(doc, allow_nan=True))
    argv = ["export", "--design", str(f), "-o", str(folder / "out.svg")]
    code, out, err = run(argv, capsys)
    assert_contract(code, out, err, argv)


# ------------------------------------------------------------------ sweep and scenario documents
def _toml(value) -> str:
    """A TOML rendering of a JSON-like value (strings escaped; dicts as inline tables)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(float(value)) if isinstance(value, float) and math.isfinite(value) else (
            str(value) if isinstance(value, int) else ("nan" if value != value else ("inf" if value > 0 else "-inf")))
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value if v is not None) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {_toml(v)}" for k, v in value.items() if v is not None) + "}"
    return '""'


sweep_docs = st.fixed_dictionaries({}, optional={
    "solver": st.dictionaries(st.sampled_from(["mesh", "freqs", "eps_r", "engine", "workers", "plate_height", "x"]),
                              json_values, max_size=3) | json_values,
    "fom": st.dictionaries(st.sampled_from(["beta", "fit_band", "n_lst", "nu0", "site", "y"]), json_values,
                           max_size=3) | json_values,
    "candidate": st.lists(st.dictionaries(st.sampled_from(["preset", "shape", "side", "beam", "name", "z"]),
                                          json_values, max_size=3), max_size=2) | json_values,
    "family": st.lists(st.dictionaries(st.sampled_from(["shape", "side", "teeth_per_side", "w"]), json_values,
                                       max_size=3), max_size=2) | json_values,
    "scenarios": st.dictionaries(st.sampled_from(["scenarios", "aggregate", "max_loss", "v"]), json_values,
                                 max_size=3) | json_values})


def _sweep_text(doc: dict) -> str:
    lines = []
    for key, value in doc.items():
        if value is None:
            continue
        if isinstance(value, list) and value and all(isinstance(v, dict) for v in value) and key in ("candidate",
                                                                                                   "family"):
            for entry in value:
                lines.append(f"[[{key}]]")
                lines += [f"{json.dumps(k)} = {_toml(v)}" for k, v in entry.items() if v is not None]
        else:
            lines.append(f"{key} = {_toml(value)}")
    return "\n".join(lines) + "\n"


@FAST
@given(doc=sweep_docs)
def test_sweep_documents_fast(doc, tmp_path_factory):
    _sweep_document(doc, tmp_path_factory.mktemp("s"))


@pytest.mark.slow
@LONG
@given(doc=sweep_docs)
def test_sweep_documents_long(doc, tmp_path_factory):
    _sweep_document(doc, tmp_path_factory.mktemp("s"))


def _sweep_document(doc: dict, folder: Path) -> None:
    """A sweep file is read (and its scenarios with it) or refused by name; nothing else."""
    from optimise.sweep import load_config, load_scenarios

    f = folder / "sweep.toml"
    f.write_text(_sweep_text(doc))
    try:
        load_config(f)
        opts = load_scenarios(f)
        if opts is not None:
            opts.set()
    except UserInputError as exc:
        assert str(f) in str(exc) or str(exc), exc
    except Exception as exc:  # noqa: BLE001
        raise AssertionError(f"traceback reading {f.read_text()!r}: {type(exc).__name__}: {exc}") from exc


scenario_docs = st.fixed_dictionaries({}, optional={
    "name": json_values, "aggregate": st.sampled_from(["mean", "worst", "worst-2", "worst-0", "median"]) | json_values,
    "member": st.lists(st.dictionaries(st.sampled_from(["name", "eps_r", "sigma", "plate_height", "feed_width",
                                                        "as_built", "q"]), json_values | st.sampled_from(
        ["missing-sheet", "corners:0.05:1", "turned:x", "offset:1", "tooth-base:0.2"]), max_size=4),
        max_size=3) | json_values})


@FAST
@given(doc=scenario_docs)
def test_scenario_files_fast(doc, tmp_path_factory):
    _scenario_file(doc, tmp_path_factory.mktemp("c"))


@pytest.mark.slow
@LONG
@given(doc=scenario_docs)
def test_scenario_files_long(doc, tmp_path_factory):
    _scenario_file(doc, tmp_path_factory.mktemp("c"))


def _scenario_file(doc: dict, folder: Path) -> None:
    from groundplane.shapes import preset
    from optimise.evaluate import EvalSettings
    from optimise.scenarios import NotApplicable, check_set, load_set

    f = folder / "set.toml"
    f.write_text(_sweep_text(doc))
    try:
        check_set(load_set(f), EvalSettings(), preset("extended"))
    except NotApplicable:
        pass
    except UserInputError:
        pass
    except Exception as exc:  # noqa: BLE001
        raise AssertionError(f"traceback reading {f.read_text()!r}: {type(exc).__name__}: {exc}") from exc


# ------------------------------------------------------------------ beam files, under a memory ceiling
def _npz(folder: Path, arrays: dict, members: dict | None = None) -> Path:
    f = folder / "beam.npz"
    with zipfile.ZipFile(f, "w") as z:
        for name, a in arrays.items():
            from io import BytesIO

            buf = BytesIO()
            np.save(buf, a, allow_pickle=False)
            z.writestr(name + ".npy", buf.getvalue())
        for name, raw in (members or {}).items():
            z.writestr(name, raw)
    return f


axes = st.lists(numbers, min_size=0, max_size=6).map(lambda v: np.array(v, dtype=float))
beam_docs = st.fixed_dictionaries({
    "freqs_mhz": axes, "theta_deg": axes, "phi_deg": axes,
    "gain": st.lists(numbers, min_size=0, max_size=24).map(lambda v: np.array(v, dtype=float)),
    "shape": st.tuples(st.integers(0, 4), st.integers(0, 4), st.integers(0, 4)),
    "meta": json_values})


@FAST
@given(doc=beam_docs)
def test_beam_files_fast(doc, tmp_path_factory, capsys):
    _beam_file(doc, tmp_path_factory.mktemp("b"), capsys)


@pytest.mark.slow
@LONG
@given(doc=beam_docs)
def test_beam_files_long(doc, tmp_path_factory, capsys):
    _beam_file(doc, tmp_path_factory.mktemp("b"), capsys)


def _beam_file(doc: dict, folder: Path, capsys) -> None:
    gain = doc["gain"]
    size = int(np.prod(doc["shape"]))
    if gain.size >= size:
        gain = gain[:size].reshape(doc["shape"])
    arrays = {k: doc[k] for k in ("freqs_mhz", "theta_deg", "phi_deg")} | {"gain": gain,
                                                                          "meta": np.array(json.dumps(doc["meta"]))}
    f = _npz(folder, arrays)
    argv = ["fom", str(f), "--n-lst", "24"]
    code, out, err = run(argv, capsys)
    assert_contract(code, out, err, argv)


HOSTILE = {
    "declares 1e12 points": lambda d: _npz(d, {"freqs_mhz": np.array([60.0])},
                                           {"gain.npy": b"\x93NUMPY\x01\x00v\x00{'descr': '<f8', 'fortran_order': False, "
                                                        b"'shape': (1000000, 1000000), }" + b" " * 50 + b"\n"}),
    "a 1 GB gain without .npy": lambda d: _bomb(d),
    "a 20 MB meta": lambda d: _npz(d, {"freqs_mhz": np.array([60.0])}, {"meta": b" " * (20 * 2**20)}),
    "/dev/zero": lambda d: Path("/dev/zero"),
    "a FEKO header and 10^6 columns": lambda d: _text(d, "#Request Name: x\n#Frequency: 7.0E+07\n#No. of Theta "
                                                        "Samples: 1\n" + "1 " * 10**6 + "\n"),
}


def _bomb(folder: Path) -> Path:
    f = folder / "bomb.npz"
    with zipfile.ZipFile(f, "w", zipfile.ZIP_DEFLATED) as z:
        with z.open("gain", "w", force_zip64=True) as fh:
            for _ in range(64):
                fh.write(bytes(2**24))
    return f


def _text(folder: Path, text: str) -> Path:
    f = folder / "export.ffe"
    f.write_text(text)
    return f


@pytest.mark.parametrize("what", sorted(HOSTILE))
def test_hostile_files_are_refused_within_the_memory_ceiling(what, tmp_path):
    """Each in its own process under RLIMIT_AS: refused (exit 2, one line) before it can take the machine."""
    import resource

    path = HOSTILE[what](tmp_path)

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_CEILING, MEMORY_CEILING))

    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    proc = subprocess.run([sys.executable, "-m", "groundplane", "fom", str(path), "--n-lst", "24"],
                          capture_output=True, text=True, timeout=120, preexec_fn=limit, env=env, cwd=ROOT)
    assert proc.returncode == 2, (what, proc.stderr[-2000:])
    assert "Traceback" not in proc.stderr and proc.stderr.strip().splitlines()[-1].startswith("groundplane fom: error")


# ------------------------------------------------------------------ the Python API
wrong_values = st.one_of(st.none(), st.booleans(), numbers, st.text(max_size=12), st.binary(max_size=4),
                         st.lists(st.integers(), max_size=2), st.dictionaries(st.text(max_size=3), st.integers(), max_size=2),
                         st.just(object()), st.just(Path("/nonexistent/groundplane")))


def _positive(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0


SQ = "square-10"
API_CALLS = {  # (call with one value a user could get wrong, which values are right: those would really work)
    "fom": (lambda gp, a: gp.fom(a), None),
    "fom correction_beam": (lambda gp, a: gp.fom(EXAMPLE, correction_beam=a, n_lst=24), lambda a: a is None),
    "compare": (lambda gp, a: gp.compare(a, a), None),
    "compare labels": (lambda gp, a: gp.compare(EXAMPLE, labels=a), None),
    "export plane": (lambda gp, a: gp.export(a, "x.stl"), None),
    "export path": (lambda gp, a: gp.export(SQ, a), None),  # any path is written: right when it is one
    "fabrication_plan": (lambda gp, a: gp.fabrication_plan(a), None),
    "fabrication_plan out_dir": (lambda gp, a: gp.fabrication_plan(SQ, a), None),
    "solve": (lambda gp, a: gp.solve(a), None),
    "solve ground": (lambda gp, a: gp.solve(SQ, ground=a, freqs="55:97:21", mesh=1.5), None),
    "solve_soils plane": (lambda gp, a: gp.solve_soils(a, [(3.5, 0.02)]), None),
    "solve_soils soils": (lambda gp, a: gp.solve_soils(SQ, a), None),
    "score plane": (lambda gp, a: gp.score(a), None),
    "score scenarios": (lambda gp, a: gp.score(SQ, scenarios=a), None),
    "score max_loss": (lambda gp, a: gp.score(SQ, max_loss=a, scenarios="nonesuch"), None),
    "optimise shape": (lambda gp, a: gp.optimise(a, 100.0, "o"), None),
    "optimise max_area": (lambda gp, a: gp.optimise("square", a, "o"), _positive),
    "optimise budget": (lambda gp, a: gp.optimise("square", 100.0, "o", budget=a), lambda a: _positive(a)
                        and isinstance(a, int)),
    "sweep": (lambda gp, a: gp.sweep(a, "o"), None),
}


@FAST
@given(name=st.sampled_from(sorted(API_CALLS)), value=wrong_values)
def test_api_functions_fast(name, value, tmp_path_factory, monkeypatch):
    _api_call(name, value, tmp_path_factory, monkeypatch)


@pytest.mark.slow
@LONG
@given(name=st.sampled_from(sorted(API_CALLS)), value=wrong_values)
def test_api_functions_long(name, value, tmp_path_factory, monkeypatch):
    _api_call(name, value, tmp_path_factory, monkeypatch)


def _api_call(name, value, tmp_path_factory, monkeypatch) -> None:
    """A wrong value in any argument: a GroundplaneError (what the docs promise), never Python's own
    TypeError or AttributeError from deep inside; a right one (a path where any path will do): done."""
    from hypothesis import assume

    import groundplane as gp
    from groundplane.errors import GroundplaneError

    call, right = API_CALLS[name]
    assume(right is None or not right(value))  # a right budget would start a real search
    monkeypatch.chdir(tmp_path_factory.mktemp("api"))
    try:
        call(gp, value)
    except GroundplaneError:
        return
    except Exception as exc:  # noqa: BLE001 - this is what the campaign hunts
        raise AssertionError(f"{name}: {value!r}: {type(exc).__name__}: {exc}") from exc
    assert name in ("export path", "fabrication_plan out_dir"), f"{name}: {value!r} was accepted"
