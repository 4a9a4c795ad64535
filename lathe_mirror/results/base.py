"""The typed results' machinery: a frozen dataclass per result, its JSON by `to_dict()`.

A result's fields are its JSON's keys, in the JSON's order; `to_dict()` gives that JSON
(the report writes it), `from_dict()` reads it back (strict: an unknown or missing key
is an error, so a stage that grows a figure grows its type). Field options:

- `key("G2/G3")`   the JSON key where it is not a Python name;
- `omitted()`      a figure present only for some results (omitted from the JSON when None);

`repr()` is one line of at most REPR_CHARS: the numbers, and the size of each container
(`to_dict()` has everything). `from_dict()` of data that is not the type's JSON raises
ResultError (an lm.InputError) naming the type and the keys.

Containers inside a result are tuples (JSON lists) and dicts keyed by name (a mirror, a
program, a parameter). A result that is a table also has `table()`: a numpy structured
array, one row per entry.
"""

from __future__ import annotations

import dataclasses
import functools
import types
import typing
from typing import Any

import numpy as np

from ..errors import InputError

#: dataclass options of every result: immutable, no per-instance dict, keywords only
#: (an optional figure may sit between required ones, as in the JSON); the repr is
#: Result's short one.
RESULT = dict(frozen=True, slots=True, kw_only=True, repr=False)

#: Longest repr of a result (characters): a notebook line, not the JSON.
REPR_CHARS = 300


def key(name: str, **kw) -> Any:
    """A field written under the JSON key `name`."""
    return dataclasses.field(metadata={"key": name}, **kw)


def omitted(name: str | None = None) -> Any:
    """A field that only some results carry: None, and then absent from the JSON."""
    return dataclasses.field(default=None, metadata={"omit": True, **({"key": name} if name else {})})


class ResultError(InputError):
    """Data handed to a result's from_dict that is not its JSON."""


class Result:
    """Base of the typed results: `to_dict()` (the JSON, key order kept) and `from_dict()`."""

    __slots__ = ()

    def __repr__(self) -> str:
        parts = [f"{f.name}={_brief(getattr(self, f.name))}" for f in dataclasses.fields(self)
                 if not (getattr(self, f.name) is None and f.metadata.get("omit"))]
        text = f"{type(self).__name__}({', '.join(parts)})"
        return text if len(text) <= REPR_CHARS else text[:REPR_CHARS - 4] + "...)"

    def __getitem__(self, key: str) -> Any:
        """The JSON's value at `key` (to_dict()[key]), for code written against the dicts
        the stages return; attributes are the typed way."""
        d = self.to_dict()
        if key not in d:
            raise ResultError(f"{type(self).__name__}[{key!r}]: no such figure; it has {list(d)[:8]}")
        return d[key]

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if v is None and f.metadata.get("omit"):
                continue
            out[f.metadata.get("key", f.name)] = plain(v)
        return out

    @classmethod
    def from_dict(cls, d: dict[str, Any]):
        """The result from its JSON-ready dict (as `to_dict()` gives it)."""
        if not isinstance(d, dict):
            raise ResultError(f"{cls.__name__}.from_dict: expected a dict ({cls.__name__}.to_dict()), got "
                              f"{type(d).__name__}")
        hints = _hints(cls)
        fields = dataclasses.fields(cls)
        names = {f.metadata.get("key", f.name): f for f in fields}
        unknown = [k for k in d if k not in names]
        if unknown:
            raise ResultError(f"{cls.__name__}.from_dict: figures it does not declare: {unknown[:6]} (is this "
                              f"{cls.__name__}.to_dict()? a stage that grew a figure declares it in its type)")
        required = [k for k, f in names.items() if k not in d and f.default is dataclasses.MISSING
                    and f.default_factory is dataclasses.MISSING]
        if required:
            raise ResultError(f"{cls.__name__}.from_dict: figures missing: {required[:6]}")
        kw = {}
        for k, v in d.items():
            try:
                kw[names[k].name] = _convert(hints[names[k].name], v)
            except ResultError as exc:  # a nested result's: say where it sits
                raise ResultError(f"{cls.__name__}.from_dict: {k}: {exc}") from None
        return cls(**kw)


@functools.cache
def _hints(cls) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def _convert(tp: Any, v: Any) -> Any:
    """v (plain JSON-ready data) as the annotated type tp."""
    if v is None:
        return None
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        for a in args:  # a result where the data is a dict, else the first that fits
            if isinstance(a, type) and issubclass(a, Result):
                if isinstance(v, dict):
                    return a.from_dict(v)
                continue
            return _convert(a, v)
        return v
    if isinstance(tp, type) and issubclass(tp, Result):
        return tp.from_dict(v)
    if origin is tuple and isinstance(v, (list, tuple)):
        args = typing.get_args(tp)
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_convert(args[0], x) for x in v)
        if args and len(args) == len(v):
            return tuple(_convert(a, x) for a, x in zip(args, v))
        return tuple(v)
    if origin is dict and isinstance(v, dict):
        _, vt = typing.get_args(tp) or (Any, Any)
        return {k: _convert(vt, x) for k, x in v.items()}
    return v


def plain(v: Any) -> Any:
    """v as plain JSON-ready data: results (and another room's typed objects with a
    to_dict(), e.g. iso10110.PartSpec) as their dicts, tuples as lists."""
    if isinstance(v, Result):
        return v.to_dict()
    if callable(getattr(v, "to_dict", None)) and not isinstance(v, type):
        return plain(v.to_dict())
    if isinstance(v, (tuple, list)):
        return [plain(x) for x in v]
    if isinstance(v, dict):
        return {k: plain(x) for k, x in v.items()}
    return v


def _brief(v: Any) -> str:
    """A field's value as a repr shows it: numbers and short strings in full, containers
    by their size."""
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, str):
        return repr(v) if len(v) <= 40 else repr(v[:37] + "...")
    if isinstance(v, Result):
        return f"{type(v).__name__}(...)"
    if isinstance(v, np.ndarray):
        return f"array{v.shape}"
    if isinstance(v, (tuple, list)):
        if len(v) <= 3 and all(isinstance(x, (int, float)) for x in v):
            return "(" + ", ".join(_brief(x) for x in v) + ")"
        return f"<{len(v)} items>"
    if isinstance(v, dict):
        keys = ", ".join(str(k) for k in list(v)[:4])
        return "{" + keys + (", ..." if len(v) > 4 else "") + "}"
    return repr(v) if len(repr(v)) <= 40 else f"<{type(v).__name__}>"


def structured(rows: list[tuple], columns: list[tuple[str, Any]]) -> np.ndarray:
    """A numpy structured array of rows (tuples in the columns' order)."""
    return np.array(rows, dtype=np.dtype(columns))


@dataclasses.dataclass(**RESULT)
class Range(Result):
    """An interval: JSON {"min": .., "max": ..}."""

    min: float
    max: float

    def __iter__(self):
        return iter((self.min, self.max))


@dataclasses.dataclass(**RESULT)
class Stat(Result):
    """An RMS and a maximum over pixels or points: JSON {"rms": .., "max": ..}; where some
    values were NaN, over the finite ones, and nan_excluded counts those left out."""

    rms: float
    max: float
    nan_excluded: int | None = omitted()
