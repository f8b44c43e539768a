"""The ``groundplane`` command: a small root application that sub-commands attach to.

Command modules (``groundplane.cli.commands``, ``solvers.cli``, ``optimise.cli``, or a
third party's) register themselves with :func:`command` when imported; the root finds
them through the ``groundplane.commands`` entry points and never imports them by name,
so dependencies point one way. Heavy libraries (astropy, cadquery, PyNEC, nlopt, dask,
matplotlib) are imported inside the commands that need them, so start-up stays fast.

Errors: a :class:`~groundplane.errors.UserInputError` is printed as one line with exit
status 2, a :class:`~groundplane.errors.SolverError` as one line with status 1; anything
else is a bug and keeps its traceback.
"""
from __future__ import annotations

import argparse
import os
import shlex
import signal
import sys
from typing import Any, Callable, Sequence

from .. import shapes as sh
from ..errors import GroundplaneError, UserInputError
from ..files import release_output_dir

COMMAND_GROUP = "groundplane.commands"
COMMANDS: dict[str, tuple[str, Callable[[argparse.ArgumentParser], Callable[[argparse.Namespace], int]]]] = {}


class CLIError(UserInputError):
    """A command-line mistake: printed as one line, exit status 2."""


def command(name: str, help: str):
    """Register a sub-command: the decorated ``setup(parser)`` adds its arguments and
    returns the function that runs it (``run(args) -> exit status``)."""
    def deco(setup):
        COMMANDS[name] = (help, setup)
        return setup
    return deco


def load_commands() -> None:
    """Import every module the installed distributions list as groundplane commands."""
    from importlib.metadata import entry_points

    for ep in entry_points(group=COMMAND_GROUP):
        ep.load()


class _Parser(argparse.ArgumentParser):
    """argparse with a one-line error (what is wrong and where to look), exit status 2,
    instead of the whole usage block first."""

    def error(self, message: str):  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {one_line(message)} (see {self.prog} --help)\n")


MAX_MESSAGE = 2000  # characters of an error line (a message quoting a 60 MB value stays one readable line)


def one_line(text: str) -> str:
    """An error message as one printable line: control characters (a NUL, a carriage return in a
    value the user typed) shown escaped, so the line cannot break or hide itself."""
    text = "".join(c if c.isprintable() else repr(c)[1:-1] for c in str(text))
    return text if len(text) <= MAX_MESSAGE else text[:MAX_MESSAGE] + " ..."


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The parser with every registered sub-command attached; given the command line, only
    the sub-command it names is set up (setting one up may import what it needs: the
    engines for ``solve``), so ``groundplane fom`` starts without them."""
    load_commands()
    chosen = None if argv is None else next((a for a in argv if not a.startswith("-")), "")
    p = _Parser(prog="groundplane", description="Design ground planes for low-frequency "
                                "radio antennas: shapes, MoM solves, the chromaticity FoM, optimisation.")
    sub = p.add_subparsers(dest="command", required=True)
    for name in sorted(COMMANDS):
        help, setup = COMMANDS[name]
        sp = sub.add_parser(name, help=help, description=help)
        if chosen is None or name == chosen:
            sp.set_defaults(run=setup(sp))
    return p


def invocation() -> str:
    """The command line as typed (for reports that say how to regenerate them)."""
    return "groundplane " + " ".join(shlex.quote(a) for a in sys.argv[1:])


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``groundplane`` command."""
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(argv)
    args = parser.parse_args(argv)
    previous = _terminate_as_interrupt()
    try:
        return int(args.run(args) or 0)
    except Terminated:
        print(f"groundplane {args.command}: terminated (what was finished is kept)", file=sys.stderr)
        return 143
    except UserInputError as exc:
        print(f"groundplane {args.command}: error: {one_line(exc)}", file=sys.stderr)
        return 2
    except GroundplaneError as exc:  # a solver that failed: not a bug in this program
        print(f"groundplane {args.command}: failed: {one_line(exc)}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"groundplane {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader went away (`groundplane fom b.npz | head -1`): not an error
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # Python's own recipe: no flush error at exit
        return 0
    finally:
        release_output_dir()  # the folders this command wrote are free for the next
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the program is, so that worker pools and files are closed as on
    Ctrl-C (Python's default for SIGTERM kills at once, leaving the pool's semaphores behind)."""


def _terminate_as_interrupt():
    """Turn SIGTERM into :class:`Terminated` for this command (main thread only); the old handler."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        return None

    def raise_terminated(signum, frame):
        raise Terminated()
    return signal.signal(signal.SIGTERM, raise_terminated)


# ----------------------------------------------------------------- shape options
def add_shape_options(p: argparse.ArgumentParser, required: bool = True) -> None:
    """``--preset NAME`` or ``SHAPE --param ...``, generated from the registered families."""
    p.add_argument("shape", nargs="?", choices=sorted(sh.SHAPES), help="shape family (or use --preset)")
    p.add_argument("--preset", choices=sorted(sh.PRESETS), help="a design-study preset")
    p.add_argument("--design", metavar="FILE.json",
                   help="a saved design: an optimiser's best.json, or {\"shape\": ..., parameters} / {\"preset\": ...}")
    g = p.add_argument_group("shape parameters (metres unless stated)")
    users: dict[str, list[str]] = {}
    helps: dict[str, set[str]] = {}
    params: dict[str, sh.Param] = {}
    for kind, cls in sh.SHAPES.items():
        for prm in cls.parameters():
            users.setdefault(prm.name, []).append(kind)
            helps.setdefault(prm.name, set()).add(prm.help)
            params.setdefault(prm.name, prm)
    for name, prm in params.items():
        metavar = "N" if prm.type is int else "V" if prm.type is float else "TEXT"
        g.add_argument(prm.flag, dest=f"shape_{name}", default=None, metavar=metavar,
                       help=f"[{', '.join(users[name])}] " + " / ".join(sorted(helps[name])))
    p.set_defaults(_shape_required=required)


def _shape_value(kind: str, prm: sh.Param, text: str) -> Any:
    if prm.parse is not None:
        return prm.parse(text)
    try:
        return int(text) if prm.type is int else float(text)
    except ValueError:
        what = "a whole number" if prm.type is int else "a number"
        raise CLIError(f"{kind}: {prm.flag} expects {what}, got '{text}'") from None


def shape_from_args(args: argparse.Namespace) -> sh.GroundPlane | None:
    """The ground plane the command line describes (None when none is given and none is required)."""
    given = {k[len("shape_"):]: v for k, v in vars(args).items() if k.startswith("shape_") and v is not None}
    if sum(bool(x) for x in (args.preset, args.shape or given, getattr(args, "design", None))) > 1:
        raise CLIError("give one design: --preset NAME, a shape with its parameters, or --design FILE.json")
    if getattr(args, "design", None):
        return sh.from_file(args.design)
    if args.preset:
        if given:
            raise CLIError(f"--preset {args.preset} takes no shape parameters (got {', '.join(sorted(given))})")
        return sh.preset(args.preset)
    if not args.shape:
        if given:
            raise CLIError("shape parameters given without a shape: name the family (e.g. 'square --side 10')")
        if args._shape_required:
            raise CLIError("no ground plane: give --preset NAME, a shape (e.g. 'square --side 10') or --design FILE.json")
        return None
    cls = sh.SHAPES[args.shape]
    own = {p.name: p for p in cls.parameters()}
    extra = sorted(set(given) - set(own))
    if extra:
        raise CLIError(f"{args.shape} does not take {', '.join('--' + e.replace('_', '-') for e in extra)}")
    missing = [p.flag for p in own.values() if p.required and p.name not in given]
    if missing:
        raise CLIError(f"{args.shape} needs {', '.join(missing)}")
    return sh.from_dict({"shape": args.shape, **{k: _shape_value(args.shape, own[k], v) for k, v in given.items()}})
