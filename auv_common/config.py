"""Configuration helpers shared by the three programs: TOML into frozen dataclasses, strictly.

Every program reads one TOML file with ``tomllib`` into frozen dataclasses that have defaults and range
checks. Unknown keys, wrong types and out-of-range values stop start-up with one clear line
(:class:`ConfigError`), never a traceback.

A setting is declared once, beside its default, with :func:`param`: unit, range, a one-line
description and (for an operator parameter) its MAVLink name. The dataclass's ``__post_init__`` calls
:func:`check_declared`, so the file loader and every ``dataclasses.replace`` refuse a value outside the range
with one message; the parameter table (``onboard.core.params``) and the generated ``docs/parameters.md``
read the same declaration (:func:`declaration`, :func:`declared_bounds`).
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
import types
import typing
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

T = TypeVar("T")


class ConfigError(ValueError):
    """A bad configuration: the message names the file/section/key and what is wrong."""


def load_toml(path: str | Path) -> dict[str, Any]:
    """Read a TOML file; a missing file or a syntax error becomes a :class:`ConfigError`."""
    p = Path(path)
    try:
        with p.open("rb") as f:
            return tomllib.load(f)
    except FileNotFoundError:
        raise ConfigError(f"{p}: no such configuration file") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{p}: not valid TOML: {exc}") from None


def _check_type(where: str, value: Any, annotation: Any) -> Any:
    """Check (and gently coerce int -> float, list -> tuple) one value against its annotation."""
    origin = typing.get_origin(annotation)
    if annotation is Any:
        return value
    if origin in (typing.Union, types.UnionType):
        errors = []
        for arm in typing.get_args(annotation):
            if arm is type(None) and value is None:
                return None
            if arm is type(None):
                continue
            try:
                return _check_type(where, value, arm)
            except ConfigError as exc:
                errors.append(str(exc))
        raise ConfigError(errors[0] if errors else f"{where}: invalid value {value!r}")
    if origin is typing.Literal:
        allowed = typing.get_args(annotation)
        if value not in allowed:
            raise ConfigError(f"{where}: must be one of {', '.join(map(repr, allowed))}, got {value!r}")
        return value
    if origin is tuple:
        if not isinstance(value, list | tuple):
            raise ConfigError(f"{where}: expected a list, got {value!r}")
        args = typing.get_args(annotation)
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_check_type(f"{where}[{i}]", v, args[0]) for i, v in enumerate(value))
        if len(args) != len(value):
            raise ConfigError(f"{where}: expected {len(args)} values, got {len(value)}")
        return tuple(
            _check_type(f"{where}[{i}]", v, a) for i, (v, a) in enumerate(zip(value, args, strict=True))
        )
    if annotation is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(f"{where}: expected a number, got {value!r}")
        if not math.isfinite(float(value)):
            raise ConfigError(f"{where}: must be finite, got {value!r}")
        return float(value)
    if annotation is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{where}: expected an integer, got {value!r}")
        return value
    if annotation is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{where}: expected true or false, got {value!r}")
        return value
    if annotation is str:
        if not isinstance(value, str):
            raise ConfigError(f"{where}: expected a string, got {value!r}")
        return value
    if dataclasses.is_dataclass(annotation) and isinstance(annotation, type):
        if not isinstance(value, dict):
            raise ConfigError(f"{where}: expected a table, got {value!r}")
        return from_table(annotation, value, where)
    return value


def from_table(cls: type[T], table: dict[str, Any] | None, where: str) -> T:
    """Build the frozen dataclass ``cls`` from a TOML table.

    ``where`` names the place for error messages (e.g. ``"onboard.toml [planner]"``). Missing keys take the
    dataclass defaults; unknown keys and wrong types raise :class:`ConfigError`. Range checks belong in the
    dataclass's ``__post_init__`` and should raise :class:`ConfigError` too.
    """
    if not (dataclasses.is_dataclass(cls) and isinstance(cls, type)):
        raise TypeError(f"{cls!r} is not a dataclass type")
    table = dict(table or {})
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    removed: dict[str, str] = getattr(cls, "REMOVED_KEYS", {})  # key -> why (and what to set instead)
    for key in sorted(set(table) & set(removed)):
        raise ConfigError(f"{where}: {key} was removed: {removed[key]}")
    unknown = sorted(set(table) - set(fields))
    if unknown:
        raise ConfigError(
            f"{where}: unknown key{'s' if len(unknown) > 1 else ''} {', '.join(unknown)} "
            f"(known: {', '.join(sorted(fields))})"
        )
    kwargs = {name: _check_type(f"{where}.{name}", value, hints[name]) for name, value in table.items()}
    try:
        return cls(**kwargs)
    except ConfigError as exc:
        raise ConfigError(f"{where}: {exc}") from None
    except TypeError as exc:  # a required field without a default
        raise ConfigError(f"{where}: {exc}") from None


def require(condition: bool, message: str) -> None:
    """Range check for ``__post_init__``: raise :class:`ConfigError` with ``message`` if not ``condition``."""
    if not condition:
        raise ConfigError(message)


# --- declared settings -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class Bound:
    """A bound that depends on other values of the same table: ``of(table)`` is the bound with the values
    in force, ``why`` the rule in words (quoted by a refusal and by the parameter page)."""

    of: Callable[[Any], float]
    why: str


@dataclass(frozen=True)
class Param:
    """The declaration of one setting (the ``"param"`` metadata of its dataclass field).

    ``min`` / ``max``: the range the configuration accepts, closed unless ``min_open`` / ``max_open`` (a
    number, or a :class:`Bound` on other values of the table); ``operator``: for a setting the configuration
    bounds loosely (e.g. a gain), the widest value a ground station may set, (lo, hi), widened to include
    the configured value; ``mavlink``: the MAVLink parameter name (at most 16 characters), None if the
    setting is not an operator parameter.
    """

    unit: str
    desc: str
    min: float | Bound = -math.inf
    max: float | Bound = math.inf
    operator: tuple[float, float] | None = None
    mavlink: str | None = None
    #: the end is excluded (``> min`` / ``< max``): for a physical quantity whose 0 means nothing (a length,
    #: a density) where no smallest meaningful value is known; never for a MAVLink parameter
    min_open: bool = False
    max_open: bool = False
    #: False for a setting that is not a number (a name, a flag, a list): declared for its description,
    #: its type checked by :func:`from_table`, no range
    numeric: bool = True


def param(
    default: Any = dataclasses.MISSING,
    *,
    unit: str = "",
    desc: str,
    min: float | Bound = -math.inf,
    max: float | Bound = math.inf,
    min_open: bool = False,
    max_open: bool = False,
    operator: tuple[float, float] | None = None,
    mavlink: str | None = None,
) -> Any:
    """A dataclass field with its default and its declaration (:class:`Param`); the dataclass's
    ``__post_init__`` calls :func:`check_declared`. A subclass that only changes the default
    (``Kp1: float = 2.0``) keeps the declaration of its base class. Without ``default`` the key is
    required. A default that is not a number (a string, a flag, a tuple) declares a setting without a range.
    """
    numeric = default is dataclasses.MISSING or (
        isinstance(default, int | float) and not isinstance(default, bool)
    )
    ranged = min != -math.inf or max != math.inf or operator is not None or min_open or max_open
    if not numeric and (ranged or mavlink is not None):
        raise TypeError(f"a setting that is not a number ({default!r}) has no range and no MAVLink name")
    if mavlink is not None and (min_open or max_open):
        raise TypeError(f"{mavlink}: a MAVLink parameter's range is closed")
    meta = Param(unit, desc, min, max, operator, mavlink, min_open, max_open, numeric)
    if isinstance(default, list | dict | set):
        raise TypeError(f"mutable default {default!r}: use a tuple")
    return dataclasses.field(default=default, metadata={"param": meta})


def declaration(cls: type, key: str) -> Param | None:
    """The declaration of ``key`` in the dataclass ``cls`` or the nearest base class that declares it."""
    for klass in cls.__mro__:
        f = getattr(klass, "__dataclass_fields__", {}).get(key)
        if f is not None and "param" in f.metadata:
            meta: Param = f.metadata["param"]
            return meta
    return None


_DECLARED: dict[type, tuple[tuple[str, Param], ...]] = {}


def declared(cls: type) -> tuple[tuple[str, Param], ...]:
    """``(key, declaration)`` of every declared setting of the dataclass ``cls``, in field order (read once
    per class: ``check_declared`` runs in every ``__post_init__``)."""
    out = _DECLARED.get(cls)
    if out is None:
        found = ((f.name, declaration(cls, f.name)) for f in dataclasses.fields(cls))
        out = _DECLARED[cls] = tuple((key, meta) for key, meta in found if meta is not None)
    return out


def _bound(bound: float | Bound, table: Any) -> float:
    return float(bound.of(table)) if isinstance(bound, Bound) else float(bound)


def declared_bounds(table: Any, key: str) -> tuple[float, float]:
    """The range ``[min, max]`` (an end excluded where declared open) of ``key`` in the dataclass instance
    ``table`` (its :class:`Bound` evaluated with the values in force); (-inf, inf) for an undeclared key."""
    meta = declaration(type(table), key)
    if meta is None:
        return -math.inf, math.inf
    return _bound(meta.min, table), _bound(meta.max, table)


def range_text(meta: Param, lo: float, hi: float) -> str:
    """The range in words, as a refusal states it: ``in [1, 45] deg``, ``>= 0.05 s (why)``."""
    unit = f" {meta.unit}" if meta.unit else ""
    whys = dict.fromkeys(b.why for b in (meta.min, meta.max) if isinstance(b, Bound))
    why = f" ({'; '.join(whys)})" if whys else ""
    return f"{_interval(meta, lo, hi, 'a finite number', 'in ')}{unit}{why}"


def _interval(meta: Param, lo: float, hi: float, finite: str, prefix: str = "") -> str:
    """``[lo, hi]``, ``(lo, hi]``, ``>= lo``, ``< hi``, ... (``finite`` when both ends are infinite)."""
    if math.isinf(hi) and math.isinf(lo):
        return finite
    if math.isinf(hi):
        return f"{'>' if meta.min_open else '>='} {lo:g}"
    if math.isinf(lo):
        return f"{'<' if meta.max_open else '<='} {hi:g}"
    return f"{prefix}{'(' if meta.min_open else '['}{lo:g}, {hi:g}{')' if meta.max_open else ']'}"


def _config_error(key: str, message: str) -> Exception:
    return ConfigError(message)


def check_declared(table: Any, error: Callable[[str, str], Exception] = _config_error) -> None:
    """Range check of every declared setting of the dataclass instance ``table`` (for ``__post_init__``):
    raise ``error(key, message)`` (default :class:`ConfigError`) for the first value that is not a finite
    number within its range."""
    for key, meta in declared(type(table)):
        if not meta.numeric:
            continue
        value = getattr(table, key)
        lo, hi = _bound(meta.min, table), _bound(meta.max, table)
        number = isinstance(value, int | float) and not isinstance(value, bool)
        if not (
            number
            and math.isfinite(value)
            and (lo < value if meta.min_open else lo <= value)
            and (value < hi if meta.max_open else value <= hi)
        ):
            got = f"{value:.9g}" if number else repr(value)
            raise error(key, f"{key} must be {range_text(meta, lo, hi)}, got {got}")


# --- the reference page ----------------------------------------------------------------------------------


def markdown_cell(text: str) -> str:
    """``text`` safe in a Markdown table cell."""
    return text.replace("|", "\\|")


def markdown_row(cells: Sequence[str]) -> str:
    """One row of a Markdown table."""
    return "| " + " | ".join(markdown_cell(c) for c in cells) + " |"


def range_cell(meta: Param, lo: float, hi: float, notes: Sequence[str] = ()) -> str:
    """The Range cell of a reference page: ``[lo, hi]``, ``(lo, hi)``, ``> lo``, ``finite``, ``-`` (not a
    number), then ``notes`` (where an end comes from) in parentheses."""
    text = _interval(meta, lo, hi, "finite") if meta.numeric else "-"
    return f"{text} ({'; '.join(notes)})" if notes else text


def bound_notes(meta: Param) -> list[str]:
    """The rule behind each end of the range that is a :class:`Bound` (one note when both ends share it)."""
    ends = [(end, b.why) for end, b in (("min", meta.min), ("max", meta.max)) if isinstance(b, Bound)]
    if len(ends) == 2 and ends[0][1] == ends[1][1]:
        return [ends[0][1]]
    return [f"{end}: {why}" for end, why in ends]


def value_text(value: Any) -> str:
    """A value as the TOML file writes it (numbers with ``:g``)."""
    if value is dataclasses.MISSING:
        return "required"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return f"{value:g}"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, tuple | list):
        return "[" + ", ".join(value_text(v) for v in value) + "]"
    return str(value)


def field_default(cls: type, key: str) -> Any:
    """The default of the field ``key`` of the dataclass ``cls`` (``dataclasses.MISSING``: required)."""
    f = {f.name: f for f in dataclasses.fields(cls)}[key]
    if f.default_factory is not dataclasses.MISSING:
        return f.default_factory()
    return f.default


MARKDOWN_HEADER = ("Config key", "Unit", "Range", "Default", "Description")


def declared_markdown(
    path: str,
    table: Any,
    *,
    mavlink: bool = False,
    value_title: str | None = None,
    level: int = 2,
    intro: str = "",
) -> list[str]:
    """The reference section of the table ``[path]``: a heading (``level``), ``intro`` and one row per
    declared key of the dataclass instance ``table`` (its ranges evaluated with its values), in field order.
    ``mavlink``: a first MAVLink column ("-": none); ``value_title``: a column of the values of ``table``
    (e.g. the packaged file's) after the dataclass's defaults."""
    head = (("MAVLink",) if mavlink else ()) + MARKDOWN_HEADER
    if value_title is not None:
        head = (*head[: 4 + mavlink], value_title, *head[4 + mavlink :])
    out = [f"{'#' * level} `[{path}]`", ""]
    if intro:
        out += [intro, ""]
    out += [markdown_row(head), "|" + "---|" * len(head)]
    for key, meta in declared(type(table)):
        lo, hi = declared_bounds(table, key)
        cells = [f"`{path}.{key}`", meta.unit or "-", range_cell(meta, lo, hi, bound_notes(meta))]
        cells.append(value_text(field_default(type(table), key)))
        if value_title is not None:
            cells.append(value_text(getattr(table, key)))
        cells.append(meta.desc)
        if mavlink:
            cells.insert(0, f"`{meta.mavlink}`" if meta.mavlink else "-")
        out.append(markdown_row(cells))
    out.append("")
    return out
