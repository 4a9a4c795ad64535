"""The range of every numeric command-line flag, in one table (FLAGS), checked by argparse
before any work and shown by each command's --help (and the README's "Ranges of every
flag").

A flag that overrides a configuration key (`key`) takes that key's range from its one
declaration (`_keyed`, settings.keys); the key's cross-checks and cost estimates still
run when the configuration is loaded. `apply(subparsers)` walks every command's
argparse flags: each flag whose type is int or float gets a type that parses and checks
it, and its range appended to its help. A numeric flag missing from the table is a
programming error that tests/test_reliability.py catches.

Output names: `check_suffix` refuses an output file whose suffix names another format
than the one written (`toolpath -o x.step`), as `cad` does for its formats.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from pathlib import Path

from ..settings.keys import key as declared_key


@dataclass(frozen=True)
class FlagRange:
    """lo .. hi (closed; None: unbounded) in unit; inf: if given, the value inf is allowed
    too and means this. key: the configuration key the flag overrides."""

    lo: float | None
    hi: float | None
    unit: str = ""
    inf: str = ""
    key: str = ""
    why: str = ""

    def allows(self, v: float) -> bool:
        """Whether v is in the range (an int compared exactly, not through a float)."""
        if isinstance(v, float) and math.isnan(v):
            return False
        if isinstance(v, float) and math.isinf(v):
            return bool(self.inf) and v > 0
        return (self.lo is None or v >= self.lo) and (self.hi is None or v <= self.hi)

    def text(self) -> str:
        u = f" {self.unit}" if self.unit else ""
        if self.lo is not None and self.hi is not None:
            out = f"{_num(self.lo)} to {_num(self.hi)}{u}"
        elif self.lo is not None:
            out = f">= {_num(self.lo)}{u}"
        else:
            out = f"<= {_num(self.hi)}{u}"
        return out + (f", or inf ({self.inf})" if self.inf else "")


def _num(x: float) -> str:
    return str(x) if isinstance(x, int) else f"{x:g}"


_KM_IN_M = 1e6


def _keyed(name: str, why: str = "") -> FlagRange:
    """The range of a flag that sets the key `name`: the key's declared range (closed ends)."""
    k = declared_key(name)
    return FlagRange(k.lo, k.hi, k.unit, key=name, why=why)


#: Every numeric flag of every command: "command --flag" -> its range.
FLAGS: dict[str, FlagRange] = {
    "cad --stl-tolerance": _keyed("cad.stl_tolerance"),
    "calib --nose-radius": _keyed("tool.nose_radius"),
    "calib --range-m": FlagRange(0.05, _KM_IN_M, "m", inf="directions",
                                 why="the nearest range of the stereo (stereo.min_range_m) to 1000 km, "
                                 "beyond which world points are directions to rounding"),
    "compensate --gain": FlagRange(0.01, 1.0, "", why="the share of the residual the re-cut takes off; "
                                   "below 1 % a re-cut changes nothing the lattice holds"),
    "optimize --workers": _keyed("optimize.workers"),
    "report --workers": _keyed("compute.workers"),
    "run --workers": _keyed("compute.workers"),
    "render --nose-radius": _keyed("render.nose_radius"),
    "render --supersample": _keyed("render.supersample"),
    "spec --step": FlagRange(0.001, 5.0, "mm", why="the sag table's spacing in r"),
    "tolerance --trials": _keyed("tolerance.trials", why="the Monte Carlo's time estimate bounds it"),
    "tolerance --seed": _keyed("tolerance.seed"),
    "tolerance --target-yield": _keyed("tolerance.target_yield"),
    "tolerance --workers": _keyed("compute.workers"),
    "toolpath --points": _keyed("machine.max_points"),
    "toolpath --resolution": _keyed("machine.resolution"),
    "toolpath --nose-radius": _keyed("tool.nose_radius"),
}


class _Ranged:
    """argparse type: base(text), then the range check (argparse prints the message as the
    flag's one-line error, exit 2)."""

    def __init__(self, base: type, rng: FlagRange):
        self.base, self.rng = base, rng
        self.__name__ = base.__name__  # argparse's "invalid int value" names it

    def __call__(self, text: str):
        value = self.base(text)
        if not self.rng.allows(value):
            u = f" {self.rng.unit}" if self.rng.unit else ""
            raise argparse.ArgumentTypeError(f"{text}{u}: allowed {self.rng.text()}")
        return value


def numeric_flags(parser: argparse.ArgumentParser) -> dict[str, argparse.Action]:
    """{"command --flag": action} of every int or float flag of every command."""
    out = {}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                for a in sub._actions:
                    base = getattr(a.type, "base", a.type)
                    if base in (int, float) and a.option_strings:
                        out[f"{name} {a.option_strings[-1]}"] = a
    return out


def apply(parser: argparse.ArgumentParser) -> None:
    """Give every numeric flag in FLAGS its checking type and its range in --help."""
    for name, action in numeric_flags(parser).items():
        rng = FLAGS.get(name)
        if rng is None or isinstance(action.type, _Ranged):
            continue
        action.type = _Ranged(action.type, rng)
        if action.help and action.help is not argparse.SUPPRESS:
            action.help = f"{action.help} [range {rng.text()}]"


def readme_table() -> str:
    """The README's table of every flag's range (a test holds the README to it)."""
    rows = ["| flag | range | why |", "|---|---|---|"]
    for name, rng in FLAGS.items():
        why = f"as `{rng.key}`" if rng.key else ""
        if rng.why:
            why = f"{why}; {rng.why}" if why else rng.why
        rows.append(f"| `{name}` | {rng.text()} | {why} |")
    return "\n".join(rows)


# --------------------------------------------------------------------------------------
# Output suffixes

#: What a command writes to a file named by -o (or another flag), and the suffixes that
#: name that format. A name with another known suffix is refused; no suffix is allowed.
FORMATS: dict[str, tuple[str, ...]] = {
    "G-code": (".ngc", ".nc", ".tap", ".gcode", ".cnc", ".txt"),
    "TOML": (".toml",),
    "JSON": (".json",),
    "CSV": (".csv", ".txt"),
}

#: Suffixes of formats the tool (or the user's other programs) reads as something else.
KNOWN_SUFFIXES = frozenset({".step", ".stp", ".stl", ".dxf", ".png", ".jpg", ".jpeg", ".svg", ".pdf",
                            ".html", ".htm", ".json", ".toml", ".csv", ".yaml", ".yml", ".xml", ".pov",
                            ".ply", ".ngc", ".nc", ".tap", ".gcode", ".cnc", ".txt", ".x3p", ".dat",
                            ".datx", ".prf", ".iges", ".igs", ".obj", ".zip", ".gz", ".h5"})


def check_suffix(path: str | Path, fmt: str, what: str = "-o/--output") -> None:
    """InputError if path's suffix names another format than fmt (one of FORMATS): a
    G-code program named x.step would open as garbage in the program the name picks."""
    from ..errors import InputError

    suffix = Path(path).suffix.lower()
    allowed = FORMATS[fmt]
    if suffix and suffix not in allowed and suffix in KNOWN_SUFFIXES:
        raise InputError(f"{what} {path}: a {suffix!r} file cannot hold {fmt}; name it "
                         f"*{allowed[0]}" + (f" (or {', '.join('*' + s for s in allowed[1:])})"
                                              if len(allowed) > 1 else ""))
