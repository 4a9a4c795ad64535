"""Errors that mean "the input is wrong": the CLI prints their one line and exits 2."""

from __future__ import annotations


class InputError(ValueError):
    """Bad input: the message names the input and what is allowed (exit status 2)."""


class ConfigError(InputError):
    """A configuration file or key that cannot be used."""


class DesignError(InputError):
    """A design that cannot exist; the message names the input and the allowed range."""
