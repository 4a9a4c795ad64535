"""Every named choice of the tool, and the one parser that reads them from a user.

A choice is a `str` Enum, so its value is what a user writes (in TOML or on the command
line) and what the JSON carries. `parse(Enum, value, key)` turns a user's string into the
member or raises one InputError line naming the key and the allowed values.
"""

from __future__ import annotations

from enum import Enum
from typing import TypeVar

from .errors import InputError

E = TypeVar("E", bound=Enum)


class Strategy(str, Enum):
    """How the exact profile becomes lattice moves (toolpath/). BEST (= ARCS) is the default."""

    PAPER = "paper"
    LATTICE = "lattice"
    ARCS = "arcs"


#: The strategy with the smallest slope error on the paper's machine (toolpath/ package doc).
BEST = Strategy.ARCS


class Dialect(str, Enum):
    """G-code dialects: LinuxCNC (checked with its rs274 interpreter) and Fanuc-style."""

    LINUXCNC = "linuxcnc"
    FANUC = "fanuc"

    @property
    def extension(self) -> str:
        """File extension of a program in this dialect."""
        return "ngc" if self is Dialect.LINUXCNC else "nc"


class Surface(str, Enum):
    """Named mirror surfaces (pipeline.named_surface): the exact design, references, the
    programmed contour of each strategy, and the polished paper program."""

    EXACT = "exact"
    REFERENCE = "reference"
    UNIFORM528 = "uniform528"
    PAPER = "paper"
    LATTICE = "lattice"
    ARCS = "arcs"
    BEST = "best"
    POLISHED = "polished"


class Program(str, Enum):
    """Which programmed contour a toleranced part is turned from."""

    BEST = "best"
    PAPER = "paper"


class Distribution(str, Enum):
    """How a parameter's tolerance is read when drawing trials."""

    NORMAL = "normal"    # the tolerance is a 3-sigma bound of a normal distribution
    UNIFORM = "uniform"  # uniform within +/- the tolerance


class Mount(str, Enum):
    """How the mirror is held: a blind bore in the back, a boss (spigot), or nothing."""

    BORE = "bore"
    BOSS = "boss"
    NONE = "none"


class StepSchema(str, Enum):
    """STEP application protocol: AP214 (automotive design; read by nearly everything)
    or AP242 (managed model-based 3D engineering; newer readers)."""

    AP214 = "AP214"
    AP242 = "AP242"


class Which(str, Enum):
    """Which mirror a CAD file holds: the design (exact lobes) or the programmed contour."""

    DESIGN = "design"
    PROGRAMMED = "programmed"


class CadFormat(str, Enum):
    """CAD output format, by file content."""

    STEP = "step"
    STL = "stl"
    DXF = "dxf"


def parse(enum: type[E], value: object, key: str, *, aliases: dict[str, E] | None = None) -> E:
    """The member of `enum` whose value is `value` (case-insensitive), or an alias.

    key: what the user wrote it as: a config key ("toolpath.strategy") or a flag
    ("--strategy"). Raises InputError: "<key> = 'x': allowed a, b" (a flag: "<key> 'x':
    allowed a, b").
    """
    text = str(value)
    if aliases and text.lower() in aliases:
        return aliases[text.lower()]
    for member in enum:
        if member.value.lower() == text.lower():
            return member
    allowed = [m.value for m in enum] + sorted(aliases or ())
    sep = " " if key.startswith("-") else " = "
    raise InputError(f"{key}{sep}{value!r}: allowed {', '.join(allowed)}")
