"""Studies: the paper's reproductions and our model studies, each a function that writes
its results (markdown with the command that made it, CSV, figures) under a directory it
is given. ``groundplane study NAME -o DIR`` runs one; every solve is cached, so an
interrupted study resumes where it stopped when rerun.

Each study module registers itself with :func:`study`; every module here is imported.
"""
from __future__ import annotations

import importlib
import pkgutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from ..evaluate import EvalSettings


@dataclass(frozen=True)
class StudyOption:
    """A command-line option of one study: ``--flag`` becomes the keyword ``into`` of its run
    function, parsed by ``type`` and refused before any solve by ``check`` (which returns the
    value to pass, or raises UserInputError)."""

    flag: str
    into: str
    help: str
    type: Callable[[str], Any] | None = None
    metavar: str | None = None
    switch: bool = False
    check: Callable[[Any], Any] | None = None


@dataclass(frozen=True)
class Study:
    """A registered study. ``run(out_dir, settings, command, **extra)``; ``settings`` is
    None for studies whose settings are fixed by what they measure. ``options``: its own
    flags (the ``study`` command is built from them); ``validate(extra)`` refuses a
    combination of them before any work."""

    name: str
    help: str
    run: Callable[..., None]
    uses_settings: bool = False
    options: tuple[StudyOption, ...] = field(default=())
    validate: Callable[[dict[str, Any]], None] | None = None


STUDIES: dict[str, Study] = {}


def study(name: str, help: str, uses_settings: bool = False, options: tuple[StudyOption, ...] = (),
          validate: Callable[[dict[str, Any]], None] | None = None):
    """Register a study function under ``name``, with its own options."""
    def deco(fn: Callable[..., None]) -> Callable[..., None]:
        STUDIES[name] = Study(name, help, fn, uses_settings, options, validate)
        return fn
    return deco


def study_options() -> dict[str, tuple[StudyOption, list[str]]]:
    """Every study option by flag, with the studies that take it (one flag, one meaning)."""
    found: dict[str, tuple[StudyOption, list[str]]] = {}
    for s in STUDIES.values():
        for o in s.options:
            found.setdefault(o.flag, (o, []))[1].append(s.name)
    return found


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
