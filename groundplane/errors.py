"""One error hierarchy for the whole toolkit.

``UserInputError`` and its subclasses are mistakes the user can correct (a file, a flag,
a TOML key, an impossible geometry): the CLI prints them as one line and exits 2.
``SolverError`` is a solver that is unusable or failed: one line, exit 1. Anything else
is a bug and keeps its traceback.
"""
from __future__ import annotations


class GroundplaneError(Exception):
    """Base of every error this toolkit raises on purpose.

    >>> import groundplane as gp
    >>> try:
    ...     gp.preset("square-11")
    ... except gp.GroundplaneError as exc:
    ...     print(type(exc).__name__)
    ShapeError
    """


class UserInputError(GroundplaneError, ValueError):
    """Input the user can correct; the message names what is wrong and where.

    >>> import groundplane as gp
    >>> try:
    ...     gp.fom("examples/lowband_square10_nec.npz", n_lst="many")
    ... except gp.UserInputError as exc:
    ...     print("refused")
    refused
    """


class BeamFormatError(UserInputError):
    """A beam file or array that is malformed, truncated or inconsistent.

    >>> import numpy as np, groundplane as gp
    >>> try:
    ...     gp.Beam(np.array([50.0]), np.arange(91.0), np.arange(360.0), -np.ones((1, 91, 360)))
    ... except gp.BeamFormatError as exc:
    ...     print(str(exc))
    beam: linear power gain must be >= 0
    """


class GroundLossUndefined(UserInputError):
    """A beam whose gain is not normalised to the antenna's input power: a ground loss read
    from it would be meaningless (directivity is lossless by definition)."""


class ArgumentError(UserInputError, TypeError):
    """A public function given an argument of a type it does not take, named with what it takes
    (also a ``TypeError``, as Python's own are).

    >>> import groundplane as gp
    >>> try:
    ...     gp.fom(None)
    ... except gp.ArgumentError as exc:
    ...     print(str(exc))
    fom(): beam must be a Beam or a beam file's path, got None
    """


class ShapeError(UserInputError):
    """Impossible ground-plane geometry."""


class SettingsError(UserInputError):
    """Impossible solver or Figure-of-Merit settings."""


class ConfigError(UserInputError):
    """A sweep file that cannot be used; names the file and the entry."""


class SolverError(GroundplaneError, RuntimeError):
    """A solver that is missing, known to be wrong, or failed on a candidate (its subclass
    ``SolveError`` names the candidate).

    >>> import groundplane as gp
    >>> issubclass(gp.SolverError, gp.GroundplaneError)
    True
    """


class EngineError(SolverError):
    """The engine is missing, known to be wrong for this case, or failed its golden test."""


class SolveError(SolverError):
    """A solve failed; names the candidate and the reason."""


class OutputError(GroundplaneError):
    """A file could not be written (a full disk, a folder gone read-only): one line, exit 1;
    what was written before it is kept."""
