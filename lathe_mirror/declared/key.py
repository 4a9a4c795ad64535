"""What a declared key is: `Key`, one configuration key with its type, unit, default,
range (each end open or closed), the reason for the limit and its help text; from it come
the check of a value, the one-line message that refuses one, and the key's row in the
README's table (the package, lathe_mirror.declared, gathers every Key).

A limit of a key that other keys move (a design that must exist, an estimate of the
work) is declared too: `depends` names what else bounds the key, the table prints it
beside the range, and the check that applies it (design_checks, costs, a section's own
check) names the key in its message.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from ..errors import ConfigError, num


@dataclass(frozen=True)
class Key:
    """One configuration key (dotted; `*` stands for each entry of a table, `[]` for each
    item of a list of tables).

    default: the value the embedded configuration gives (None: the key is absent unless
    given, e.g. a lobe's a_over_b). kind: "float", "int", "bool", "str", "choice", "list"
    (numbers: length gives the count), "table"; inferred from the default when "".
    lo, hi: the range (None: unbounded), lo_open / hi_open: an end excluded. unit: the unit
    the file gives the value in. step: values must be whole multiples of it. choices: the
    allowed names of a named choice (or the text that says what is allowed). why: the
    reason for the limit. help: what the key is. depends: what else bounds the key (other
    keys, the design, a cost estimate), printed beside the range; lo_depends / hi_depends:
    that bound can refuse the documented low / high end with the other keys at their
    defaults (the endpoint test then asks only that the refusal names the key).
    """

    name: str
    default: Any = None
    unit: str = ""
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    length: tuple[int, int] | None = None
    choices: tuple[str, ...] | str = ()
    why: str = ""
    help: str = ""
    depends: str = ""
    lo_depends: bool = False
    hi_depends: bool = False
    step: float | None = None
    kind: str = ""

    @property
    def type(self) -> str:
        """The value's kind (see the class doc)."""
        if self.kind:
            return self.kind
        d = self.default
        if isinstance(d, bool):
            return "bool"
        if isinstance(d, int):
            return "int"
        if isinstance(d, float):
            return "float"
        if isinstance(d, str):
            return "choice" if self.choices else "str"
        if isinstance(d, list):
            return "list"
        if isinstance(d, dict):
            return "table"
        return "float"

    @property
    def numeric(self) -> bool:
        return self.lo is not None or self.hi is not None

    # ----------------------------------------------------------------------------------
    # What it allows

    def allows(self, v: float, slack: float = 0.0) -> bool:
        """Whether the number v lies in the range (not the length of a list); `slack`
        widens a closed end by that fraction of its size (for values converted back to
        the file's units)."""
        if isinstance(v, float) and not math.isfinite(v):
            return False
        if self.lo is not None:
            lo = self.lo - slack * abs(self.lo) if slack and not self.lo_open else self.lo
            if not (v > lo if self.lo_open else v >= lo):
                return False
        if self.hi is None:
            return True
        hi = self.hi + slack * abs(self.hi) if slack and not self.hi_open else self.hi
        return v < hi if self.hi_open else v <= hi

    def range_text(self) -> str:
        """The range alone: "0.1 to 1000 mm", "> 0 and <= 10 mm"."""
        u = f" {self.unit}" if self.unit else ""
        if self.lo is not None and self.hi is not None and not (self.lo_open or self.hi_open):
            out = f"{exact(self.lo)} to {exact(self.hi)}{u}"
        else:
            parts = []
            if self.lo is not None:
                parts.append(f"{'>' if self.lo_open else '>='} {exact(self.lo)}")
            if self.hi is not None:
                parts.append(f"{'<' if self.hi_open else '<='} {exact(self.hi)}")
            out = " and ".join(parts) + u
        if self.step is not None:
            out += f", a multiple of {num(self.step)}{u}"
        return out

    def text(self) -> str:
        """What the key allows, as the README and the messages print it."""
        if self.choices:
            return self.choices if isinstance(self.choices, str) else ", ".join(self.choices)
        if self.type == "bool":
            return "true or false"
        out = self.range_text() if self.numeric else ""
        if self.length is not None:
            n0, n1 = self.length
            count = f"{n0}" if n0 == n1 else f"{n0} to {n1}"
            out = f"{count} numbers, each {out}" if out else f"{count} entries"
        return out

    def note(self) -> str:
        """The reason for the limit and what else bounds the key, as one phrase."""
        return "; ".join(p for p in (self.why, f"the limit also depends on {self.depends}" if self.depends else "")
                         if p)

    # ----------------------------------------------------------------------------------
    # Checks

    def refusal(self, where: str, value: Any) -> str:
        """The one line that refuses `value` of this key (`where`: the concrete key)."""
        u = f" {self.unit}" if self.unit and not isinstance(value, (list, tuple)) else ""
        shown = num(value)
        if isinstance(value, float) and shown in {exact(x) for x in (self.lo, self.hi) if x is not None}:
            shown = repr(value)  # 1000.0001 against 1000: the digits the comparison saw
        return f"{where} = {shown}{u}: allowed {self.text()}" + (f" ({self.why})" if self.why else "")

    def check(self, where: str, value: Any, slack: float = 0.0) -> None:
        """ConfigError (one line naming `where` and what the key allows) unless value fits
        (`slack`: see allows)."""
        if value is None:
            return
        if isinstance(value, (list, tuple)) and self.length is not None:
            n0, n1 = self.length
            if not n0 <= len(value) <= n1:
                count = f"{n0}" if n0 == n1 else f"{n0} to {n1}"
                raise ConfigError(f"{where} has {len(value)} entries: allowed {count}"
                                  + (f" ({self.why})" if self.why else ""))
            items = [(f"{where}[{i}]", v) for i, v in enumerate(value)]
        else:
            items = [(where, value)]
        for at, v in items:
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                if isinstance(self.choices, tuple) and self.choices and isinstance(v, str) \
                        and v not in self.choices:
                    raise ConfigError(f"{at} = {v!r}: allowed {', '.join(repr(c) for c in self.choices)}")
                continue
            if self.numeric and not self.allows(v, slack):
                raise ConfigError(self.refusal(at, v))
            if self.step is not None and abs(v / self.step - round(v / self.step)) > 1e-6 + slack:
                raise ConfigError(self.refusal(at, v))

    def row(self) -> str:
        """The key's row of the README table: key, default, allowed, note."""
        name = self.name.replace("lobes.*.", "lobes.")
        return f"| `{name}` | {_default_text(self)} | {self.text()} | {self.note()} |"

    def help_row(self) -> str:
        """The key's row of the reference table (with its help text)."""
        name = self.name.replace("lobes.*.", "lobes.")
        return f"| `{name}` | {_default_text(self)} | {self.text()} | {self.help} | {self.note()} |"

    def help_default(self) -> str:
        """`--help` text naming the key and its default: "machine.max_points, default 528"
        (the flag's range follows it: commands.flags takes it from the same Key)."""
        return f"{self.name}, default {_default_text(self).strip('`')}"


def exact(limit: float) -> str:
    """A limit as the messages and the docs print it: num()'s short form when it reads back
    to the same number, else every digit (pi / 2 is 1.5707963267948966, not 1.5708, which
    the limit refuses)."""
    text = num(limit)
    return text if not isinstance(limit, float) or float(text) == limit else repr(limit)


def _default_text(key: Key) -> str:
    d = key.default
    if d is None:
        return ""
    if isinstance(d, dict):
        return "(table)"
    if isinstance(d, list) and d and isinstance(d[0], dict):
        return f"({len(d)} tables)"
    if isinstance(d, str):
        return f'`"{d}"`'
    return f"`{num(d)}`"
