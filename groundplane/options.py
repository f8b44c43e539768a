"""Settings dataclasses as command-line options and sweep-file keys, declared once.

A field declared with :func:`option` becomes ``--flag`` on every command that takes its
dataclass and the key ``flag`` (dashes as underscores) in a sweep TOML. Defaults live
only in the dataclass; values are type-checked strictly (a TOML ``"false"`` is not a
boolean, ``3.7`` is not a whole number), so nothing is silently coerced.
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import typing
from dataclasses import dataclass, field, fields, replace
from typing import Any, Callable, Mapping

import numpy as np

from .errors import ArgumentError, ConfigError, SettingsError, UserInputError


def option(default: Any, help: str, *, flag: str | None = None, parse: Callable[[str], Any] | None = None,
           choices: tuple[str, ...] | None = None, switch: Callable[[], Any] | None = None,
           metavar: str | tuple[str, ...] | None = None, keyed_at_default: bool = True) -> Any:
    """Declare a settings field that users may set.

    Parameters
    ----------
    default
        The one place the default is written.
    help : str
        What it is, with its unit.
    flag : str, optional
        The command-line flag (default ``--field-name``); the TOML key is the flag's name
        with underscores.
    parse : callable, optional
        Turns a string (command line or TOML) into the value, e.g. a frequency range.
    choices : tuple of str, optional
        Allowed values of a string option.
    switch : callable, optional
        For an on/off option whose "on" is an object: ``--flag`` sets the field to ``switch()``.
    metavar : str or tuple of str, optional
        Placeholder(s) shown in ``--help``.
    keyed_at_default : bool
        False for an option added after results were cached: at its default it is left out of the
        settings' identity (``PlateModel.as_dict``), so the keys of those results stay as they were.
    """
    meta = {"help": help, "flag": flag, "parse": parse, "choices": choices, "switch": switch, "metavar": metavar,
            "keyed_at_default": keyed_at_default}
    return field(default=default, metadata={"option": meta})


@dataclass(frozen=True)
class Option:
    """One user-settable field of a settings dataclass."""

    name: str
    hint: Any
    default: Any
    help: str
    flag: str
    parse: Callable[[str], Any] | None
    choices: tuple[str, ...] | None
    switch: Callable[[], Any] | None
    metavar: Any

    @property
    def key(self) -> str:
        """The sweep-TOML key."""
        return self.flag[2:].replace("-", "_")

    @property
    def element_types(self) -> tuple[type, ...] | None:
        """Element types of a fixed-length tuple option, else None."""
        if typing.get_origin(self.hint) is tuple:
            args = typing.get_args(self.hint)
            if args and args[-1] is not Ellipsis:
                return tuple(args)
        return None


def options(cls: type) -> list[Option]:
    """The user-settable fields of a settings dataclass, in declaration order."""
    hints = typing.get_type_hints(cls)
    out = []
    for f in fields(cls):
        m = f.metadata.get("option")
        if m is None:
            continue
        default = f.default if f.default is not dataclasses.MISSING else f.default_factory()  # type: ignore[misc]
        out.append(Option(f.name, hints[f.name], default, m["help"], m["flag"] or "--" + f.name.replace("_", "-"),
                          m["parse"], m["choices"], m["switch"], m["metavar"]))
    return out


def _fmt(v: Any) -> str:
    if isinstance(v, (tuple, list)):
        return " ".join(_fmt(x) for x in v)
    if isinstance(v, float):
        return f"{v:g}"
    return str(v)


def add_options(parser: argparse.ArgumentParser, cls: type, title: str | None = None) -> None:
    """Add the dataclass's options to ``parser`` (in a group titled ``title``)."""
    g = parser.add_argument_group(title) if title else parser
    for o in options(cls):
        o = replace(o, help=o.help.replace("%", "%%"))  # argparse formats help with %: a literal % is %%
        shared = parser._option_string_actions.get(o.flag)
        if shared is not None:  # shared by two engines' settings: one flag, each one's default said
            if f"(default {_fmt(o.default)})" not in (shared.help or ""):
                shared.help = f"{shared.help}; {title or cls.__name__}: default {_fmt(o.default)}"
            continue
        kw: dict[str, Any] = {"dest": o.key, "default": None}
        if o.switch is not None or (o.hint is bool and o.default is False):
            g.add_argument(o.flag, action="store_true", help=o.help, **kw)
            continue
        if o.hint is bool:
            g.add_argument(o.flag, action=argparse.BooleanOptionalAction, help=f"{o.help} (default {o.default})", **kw)
            continue
        n = o.element_types
        if n:
            kw["nargs"] = len(n)
        if o.metavar:
            kw["metavar"] = o.metavar
        if o.choices:
            kw["choices"] = o.choices
        default = "" if o.parse and isinstance(o.default, tuple) and len(o.default) > 4 else f" (default {_fmt(o.default)})"
        g.add_argument(o.flag, help=o.help + default, **kw)


def markdown_table(groups: list[tuple[str, type]]) -> str:
    """A markdown table of every option in ``groups`` ((title, settings dataclass) pairs): flag,
    default and help, from the dataclasses themselves, so the docs cannot drift from ``--help``.
    A flag shared by several dataclasses is listed once, under its first group."""
    lines = ["| option | default | what it is |", "|---|---|---|"]
    seen: set[str] = set()
    for title, cls in groups:
        rows = [o for o in options(cls) if o.flag not in seen]
        if rows:
            lines.append(f"| **{title}** | | |")
        for o in rows:
            seen.add(o.flag)
            meta = o.metavar if isinstance(o.metavar, tuple) else (o.metavar,) if o.metavar else ()
            flag = " ".join([o.flag, *meta]) if meta else o.flag
            if o.hint is bool and o.default is True:
                flag = f"--[no-]{o.flag[2:]}"
            if o.switch is not None or (o.hint is bool and o.default is False):
                default = "off"
            elif o.parse and isinstance(o.default, tuple) and len(o.default) > 4:
                default = f"{o.default[0]:g}:{o.default[-1]:g}:{o.default[1] - o.default[0]:g}"
            elif o.default is None:
                default = "-"
            else:
                default = _fmt(o.default)
            choices = f" ({' / '.join(o.choices)})" if o.choices else ""
            lines.append(f"| `{flag}` | {default} | {o.help.replace('|', chr(92) + '|')}{choices} |")
    return "\n".join(lines)


def _number(o: Option, v: Any, t: type, where: str) -> Any:
    """``v`` as a ``t`` (float or int), from a string (command line) or a TOML value; strict."""
    if isinstance(v, str):
        try:
            x = float(v)
        except ValueError:
            raise ConfigError(f"{where}{o.flag}: expected a number, got '{v}'") from None
    elif isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise ConfigError(f"{where}{o.key}: expected a number, got {v!r} ({type(v).__name__})")
    else:
        x = v
    if not math.isfinite(float(x)):
        raise ConfigError(f"{where}{o.key}: expected a finite number, got {v!r}")
    if t is int:
        if float(x) != int(float(x)):
            raise ConfigError(f"{where}{o.key}: expected a whole number, got {v!r}")
        return int(float(x))
    return float(x)


def coerce(o: Option, v: Any, where: str = "", strings: bool = False) -> Any:
    """One option's value from the command line (``strings``: every value arrives as text) or
    a TOML file (typed: a number in quotes is refused, not read), type-checked."""
    numeric = o.hint in (int, float) or bool(o.element_types) or (
        typing.get_origin(o.hint) in (typing.Union, getattr(__import__("types"), "UnionType", None))
        and float in typing.get_args(o.hint))
    if not strings and isinstance(v, str) and numeric and o.parse is None:
        raise ConfigError(f"{where}{o.key}: expected a number, got the string {v!r} (write it without quotes)")
    if o.switch is not None:
        if not isinstance(v, bool):
            raise ConfigError(f"{where}{o.key}: expected true or false, got {v!r}")
        return o.switch() if v else None
    if o.parse is not None and isinstance(v, str):
        try:
            return o.parse(v)
        except UserInputError as exc:
            raise ConfigError(f"{where}{exc}") from None
    if o.hint is bool:
        if not isinstance(v, bool):
            raise ConfigError(f"{where}{o.key}: expected true or false, got {v!r} ({type(v).__name__})")
        return v
    if o.hint is str:
        if not isinstance(v, str) or (o.choices and v not in o.choices):
            allowed = f" (one of {', '.join(o.choices)})" if o.choices else ""
            raise ConfigError(f"{where}{o.key}: expected a string{allowed}, got {v!r}")
        return v
    types = o.element_types
    if types:
        if not isinstance(v, (list, tuple)) or len(v) != len(types):
            raise ConfigError(f"{where}{o.key}: expected {len(types)} numbers, got {v!r}")
        return tuple(_number(o, x, t, where) for x, t in zip(v, types))
    if o.hint in (int, float):
        return _number(o, v, o.hint, where)
    if typing.get_origin(o.hint) in (typing.Union, getattr(__import__("types"), "UnionType", None)) \
            and float in typing.get_args(o.hint):  # an optional number (None: not given)
        return _number(o, v, float, where)
    if o.parse is not None and isinstance(v, (list, tuple)):  # e.g. a list of frequencies
        return tuple(_number(o, x, float, where) for x in v)
    raise ConfigError(f"{where}{o.key}: cannot read {v!r}")


def build(cls: type, values: Mapping[str, Any], where: str = "", strings: bool = False, **fixed: Any) -> Any:
    """``cls`` from option values keyed by TOML key (strict); missing keys take the defaults.

    Raises
    ------
    ConfigError
        An unknown key, a value of the wrong type, or settings the dataclass refuses.
    """
    opts = {o.key: o for o in options(cls)}
    unknown = set(values) - set(opts)
    if unknown:
        raise ConfigError(f"{where}unknown key(s) {sorted(unknown)}; expected some of {sorted(opts)}")
    kwargs = {opts[k].name: coerce(opts[k], v, where, strings) for k, v in values.items()}
    try:
        return cls(**kwargs, **fixed)
    except SettingsError as exc:
        raise ConfigError(f"{where}{exc}") from None


def from_args(cls: type, args: argparse.Namespace, **fixed: Any) -> Any:
    """``cls`` from the parsed command line: options not given take the dataclass defaults."""
    given = {o.key: getattr(args, o.key) for o in options(cls) if getattr(args, o.key, None) is not None}
    return build(cls, given, "", strings=True, **fixed)


def option_keys(cls: type) -> set[str]:
    """The TOML keys a settings dataclass accepts."""
    return {o.key for o in options(cls)}


MAX_FREQS = 5000  # a 0.01 MHz sweep of 40-100 MHz; more is a step typed wrong


def expect(value: Any, kinds: type | tuple[type, ...], name: str, where: str, takes: str) -> Any:
    """``value`` when it is one of ``kinds`` (a bool is no number), else :class:`ArgumentError`
    naming the argument, the function and what it ``takes``: ``gp.fom(None)`` was a TypeError deep
    in the loader, ``gp.score(sq, scenarios=5)`` an AttributeError."""
    kinds = kinds if isinstance(kinds, tuple) else (kinds,)
    number_wanted = any(k in (int, float) for k in kinds) and bool not in kinds
    if not isinstance(value, kinds) or (number_wanted and isinstance(value, bool)):
        shown = repr(value)
        raise ArgumentError(f"{where}: {name} must be {takes}, got {shown if len(shown) <= 60 else shown[:57] + '...'}")
    return value


MAX_NAME_CHARS = 120


def check_name(value: Any, what: str) -> str:
    """A user's name for a thing (a scenario, a member, a candidate) as reports will print it: a
    string of printable characters (an escape sequence was printed raw to the terminal, a newline
    broke the markdown table), at most :data:`MAX_NAME_CHARS` long."""
    if not isinstance(value, str):
        raise SettingsError(f"{what} must be a string, got {value!r}"[:200])
    if not value.strip() or not value.isprintable() or len(value) > MAX_NAME_CHARS:
        raise SettingsError(f"{what} {value[:40]!r}: a name is 1-{MAX_NAME_CHARS} printable characters (no control "
                            "characters, tabs or newlines)")
    return value


def parse_freqs(spec: str) -> tuple[float, ...]:
    """'40:100:1' (inclusive), '50,75,100' or 'fit-band' (the paper's LinLog fit band,
    55-97 MHz at 1 MHz: the only frequencies the FoM uses, so the same FoM for 43/61 of
    the solve time) -> MHz, checked: positive, increasing, no repeats."""
    if spec.strip().lower() == "fit-band":
        from .paper import FIT_BAND_MHZ

        lo, hi = FIT_BAND_MHZ
        return tuple(float(f) for f in np.arange(lo, hi + 0.5, 1.0))
    try:
        if ":" in spec:
            lo, hi, step = (float(v) for v in spec.split(":"))
            if not (step > 0 and hi >= lo and math.isfinite(hi)):
                raise ValueError
            hi = min(hi, lo + MAX_FREQS * step)  # a longer range is refused below without building it whole
            f = np.round(np.arange(lo, hi + step / 2, step), 9)
        else:
            f = np.array([float(v) for v in spec.split(",")])
    except ValueError:
        raise SettingsError(f"--freqs: expected LO:HI:STEP or a comma list of MHz, got '{spec}'") from None
    if f.size > MAX_FREQS:
        raise SettingsError(f"--freqs '{spec}': more than {MAX_FREQS} frequencies is not a band anyone solves; check "
                            "the step")
    if f.size == 0 or not np.all(np.isfinite(f)) or np.any(f <= 0):
        raise SettingsError(f"--freqs '{spec}': frequencies must be positive MHz")
    if f.size > 1 and not np.all(np.diff(f) > 0):
        raise SettingsError(f"--freqs '{spec}': frequencies must be increasing with no repeats")
    return tuple(float(x) for x in f)
