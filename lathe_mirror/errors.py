"""Errors that mean "the input is wrong": the CLI prints their one line and exits 2."""

from __future__ import annotations

import math


class InputError(ValueError):
    """Bad input: the message names the input and what is allowed (exit status 2)."""


class ConfigError(InputError):
    """A configuration file or key that cannot be used."""


class DesignError(InputError):
    """A design that cannot exist; the message names the input and the allowed range."""


def num(value: object) -> str:
    """A number as a message prints it: %g-like, at most 6 significant digits (never 300
    digits of a float near its limit); integers in full (TOML's are 64-bit), anything
    else as repr."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return f"{value:.6g}" if math.isfinite(value) else repr(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(num(v) for v in value) + "]"
    return repr(value)
