"""Studies: the paper's reproductions and our model studies, each a function that writes
its results (markdown with the command that made it, CSV, figures) under a directory it
is given. ``groundplane study NAME -o DIR`` runs one; every solve is cached, so an
interrupted study resumes where it stopped when rerun.

Each study module registers itself with :func:`study`; every module here is imported.
"""
from __future__ import annotations

import importlib
import pkgutil
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from ..evaluate import EvalSettings


@dataclass(frozen=True)
class Study:
    """A registered study. ``run(out_dir, settings, command, **extra)``; ``settings`` is
    None for studies whose settings are fixed by what they measure."""

    name: str
    help: str
    run: Callable[..., None]
    uses_settings: bool = False


STUDIES: dict[str, Study] = {}


def study(name: str, help: str, uses_settings: bool = False):
    """Register a study function under ``name``."""
    def deco(fn: Callable[..., None]) -> Callable[..., None]:
        STUDIES[name] = Study(name, help, fn, uses_settings)
        return fn
    return deco


def run_study(name: str, out_dir: str | Path, settings: EvalSettings | None = None, command: str = "",
              **extra) -> None:
    """Run a registered study, writing under ``out_dir``."""
    s = STUDIES[name]
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    command = command or f"groundplane study {name} -o {out}"
    s.run(out, settings, command, **extra)  # each study stamps the reports it writes (provenance.write_md)


for _m in pkgutil.iter_modules(__path__):
    if not _m.name.startswith("_"):
        importlib.import_module(f"{__name__}.{_m.name}")
