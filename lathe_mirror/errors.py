"""The exception family of lathe-mirror: `Error`, of three kinds.

  input     InputError (ConfigError): an input that cannot be used; the message names the
            input and what is allowed. The CLI prints its one line and exits 2.
  design    DesignError (an InputError too): a design that cannot exist; the message
            names the design input and its allowed range. Exit 2.
  internal  InternalError: the tool itself failed (a bug or an environment it cannot
            work in), not the user's input. The CLI exits 1 (as for any other exception).

`Error.kind` names the kind and `Error.exit_status` the CLI's status for it. InputError
is also a ValueError (a wrong argument) and InternalError a RuntimeError, so code that
catches those still catches them.
"""

from __future__ import annotations

import math


#: The signals that end a command, by name: the command line turns each into its exit
#: status 128 + the signal's number after removing what the command had half-written;
#: compute's workers ignore them (their parent ends them).
ENDING_SIGNALS = ("SIGINT", "SIGTERM", "SIGHUP", "SIGQUIT")


class Error(Exception):
    """Every error lathe-mirror raises on purpose (see the module doc for the kinds)."""

    kind = "internal"
    exit_status = 1


class InputError(Error, ValueError):
    """Bad input: the message names the input and what is allowed (exit status 2)."""

    kind = "input"
    exit_status = 2


class ConfigError(InputError):
    """A configuration file or key that cannot be used."""


class DesignError(InputError):
    """A design that cannot exist; the message names the input and the allowed range."""

    kind = "design"


class InternalError(Error, RuntimeError):
    """The tool failed, not the input (exit status 1)."""


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


def escaped(text: str) -> str:
    """text as a terminal may show it: every character it could act on (C0 and C1 controls
    such as ESC, DEL, format characters such as the bidi overrides, line separators) and
    every one it cannot show (surrogates, private, unassigned) written as its escape, \\x1b,
    \\u202e; a byte a file's decoding kept as a surrogate (surrogateescape) as that byte,
    \\xff. Printable text, spaces included, is returned as it is."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else _escape(c) for c in text)


def _escape(c: str) -> str:
    o = ord(c)
    if 0xDC80 <= o <= 0xDCFF:  # an undecodable byte, kept by surrogateescape
        return f"\\x{o - 0xDC00:02x}"
    if o < 0x100:
        return f"\\x{o:02x}"
    return f"\\u{o:04x}" if o < 0x10000 else f"\\U{o:08x}"
