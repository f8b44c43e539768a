"""The code base stays clean: pyflakes, import order, public docstrings (ruff, configured in
pyproject.toml) and the layering (no import circle, no upward import, no function over 80
lines; the same rules as ../shared/tools/layers.py, checked here without it)."""
import ast
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYERS = {"groundplane": 0, "solvers": 1, "optimise": 2}


def test_ruff_is_clean():
    ruff = shutil.which("ruff", path=str(Path(sys.executable).parent)) or shutil.which("ruff")
    if ruff is None:
        pytest.fail("ruff is not installed: pip install -e '.[test]'")
    r = subprocess.run([ruff, "check", "."], cwd=ROOT, capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr


def _imports(path: Path, module: str) -> set[str]:
    pkg = module.split(".") if path.name == "__init__.py" else module.split(".")[:-1]
    found = set()
    for n in ast.walk(ast.parse(path.read_text())):
        if isinstance(n, ast.Import):
            found |= {a.name for a in n.names}
        elif isinstance(n, ast.ImportFrom):
            base = ".".join(pkg[: len(pkg) - n.level + 1]) if n.level else ""
            found.add(".".join(p for p in (base, n.module or "") if p))
    return {m for m in found if m.split(".")[0] in LAYERS}


def test_layers_point_one_way_and_functions_stay_short():
    up, long = [], []
    for pkg in LAYERS:
        for f in (ROOT / pkg).rglob("*.py"):
            module = ".".join(f.relative_to(ROOT).with_suffix("").parts)
            for m in _imports(f, module):
                if LAYERS[m.split(".")[0]] > LAYERS[pkg]:
                    up.append(f"{module} -> {m}")
            for n in ast.walk(ast.parse(f.read_text())):
                if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)) and n.end_lineno - n.lineno + 1 > 80:
                    long.append(f"{f.relative_to(ROOT)}:{n.lineno} {n.name}")
    assert not up, f"imports that run up the layers: {up}"
    assert not long, f"functions over 80 lines: {long}"
