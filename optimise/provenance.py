"""Machine-readable provenance of generated reports: the first line of every markdown report a
study, search or sweep writes is ``<!-- provenance: {json} -->`` with what made it (the command,
the settings' identity, the code version and each engine's model version), so
``groundplane study --check`` can list the committed results an engine change has made stale
instead of relying on banners written by hand."""
from __future__ import annotations

import json
import re
import subprocess
import time
from pathlib import Path
from typing import Any

PREFIX = "<!-- provenance: "
SUFFIX = " -->"
COMMAND = re.compile(r"Command:\s*`([^`]+)`")


def model_versions() -> dict[str, int]:
    """Each registered engine's model version (what its cache keys carry)."""
    from solvers.engines import ENGINES

    return {name: int(getattr(cls, "model_version", 0)) for name, cls in sorted(ENGINES.items())}


def code_version() -> str:
    """The package version and, in a git checkout, the commit."""
    import groundplane

    root = Path(groundplane.__file__).resolve().parents[1]
    try:
        commit = subprocess.run(["git", "-C", str(root), "rev-parse", "--short=12", "HEAD"], capture_output=True,
                                text=True, timeout=5).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        commit = ""
    return f"{groundplane.__version__}+{commit}" if commit else groundplane.__version__


def read(path: Path) -> dict[str, Any] | None:
    """The provenance of a report, or None when it has none (or an unreadable one)."""
    try:
        with open(path, encoding="utf-8") as fh:
            first = fh.readline().strip()
    except (OSError, UnicodeDecodeError):
        return None
    if not (first.startswith(PREFIX) and first.endswith(SUFFIX)):
        return None
    try:
        head = json.loads(first[len(PREFIX):-len(SUFFIX)])
    except json.JSONDecodeError:
        return None
    return head if isinstance(head, dict) else None


def header(kind: str, command: str, settings: dict[str, Any] | None = None, **extra: Any) -> str:
    """The provenance line a report starts with: what made it, with which code and models."""
    head = {"report": kind, "command": command, "code": code_version(), "models": model_versions(),
            "written": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), **extra}
    if settings is not None:
        head["settings"] = settings
    return PREFIX + json.dumps(head, sort_keys=True) + SUFFIX


def write_md(path: Path, text: str, kind: str, command: str, settings: dict[str, Any] | None = None,
             **extra: Any) -> Path:
    """Write a markdown report atomically, starting with its provenance line (the one it already
    has, or :func:`header` of ``kind`` and ``command``): the code that writes a report stamps it,
    for that file only (stamping every new file of a folder had named one command on another's
    report)."""
    from groundplane.files import atomic_path

    path = Path(path)
    if not text.startswith(PREFIX):
        text = header(kind, command, settings, **extra) + "\n" + text
    with atomic_path(path, suffix=".tmp.md") as tmp:
        tmp.write_text(text, encoding="utf-8")
    return path


def check(root: Path) -> list[dict[str, str]]:
    """Every generated report under ``root``: current, stale (an engine's model changed since),
    or without provenance; with the command that regenerates it when the report names one."""
    now = model_versions()
    rows = []
    for p in sorted(root.rglob("*.md")):
        if p.name == "answer.md":
            continue
        head = read(p)
        text = p.read_text(encoding="utf-8", errors="replace")
        m = COMMAND.search(text)
        command = (head or {}).get("command") or (m.group(1) if m else "")
        if head is None or "models" not in head:
            rows.append({"path": str(p), "status": "unknown", "why": "no model versions in its provenance (written "
                         "before reports carried them)", "command": command})
            continue
        changed = [f"{e} v{v} -> v{now[e]}" for e, v in sorted(head["models"].items()) if e in now and now[e] != v]
        rows.append({"path": str(p), "status": "stale" if changed else "current",
                     "why": ", ".join(changed) if changed else f"written {head.get('written', '?')} by {head.get('code', '?')}",
                     "command": command})
    return rows
