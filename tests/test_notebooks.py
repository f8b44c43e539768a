"""The example notebooks (examples/notebooks) run top to bottom on their tiny settings, in a
scratch copy of the folder (their files land there), and are committed without outputs."""
from __future__ import annotations

import shutil

import pytest

from tests.conftest import ROOT

NOTEBOOKS = sorted((ROOT / "examples" / "notebooks").glob("*.ipynb"))


def test_there_is_a_tour():
    assert len(NOTEBOOKS) >= 4


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_runs_top_to_bottom(path, tmp_path, monkeypatch):
    nbformat = pytest.importorskip("nbformat")
    from nbclient import NotebookClient

    nb = nbformat.read(path, as_version=4)
    assert all(not c.get("outputs") and not c.get("execution_count") for c in nb.cells if c.cell_type == "code"), \
        f"{path.name}: committed with outputs (clear them before committing)"
    work = tmp_path / "examples" / "notebooks"
    work.mkdir(parents=True)
    shutil.copy(ROOT / "examples" / "lowband_square10_nec.npz", tmp_path / "examples")
    monkeypatch.setenv("GROUNDPLANE_CACHE", str(tmp_path / "cache"))
    NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(work)}}).execute()
    errors = [o for c in nb.cells for o in c.get("outputs", []) if o.get("output_type") == "error"]
    assert not errors
    assert any(p.suffix in (".png", ".step", ".stl") for p in work.iterdir()), "the notebook wrote nothing"
