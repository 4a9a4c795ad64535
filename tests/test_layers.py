"""The house plan's layering, read from the source with `ast`: no import circle, no import
from a later stage into an earlier one, no private name imported from another module.

The ranks follow the data flow (docs/architecture.md): a module may import its own
package's modules and anything of a lower rank. Imports under `if TYPE_CHECKING:` do not
run and are left out.
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "lathe_mirror"

#: Rank of each top-level module or package of lathe_mirror, in the order of the data flow.
RANKS = {
    "errors": 0, "inputs": 0, "enums": 0, "progress": 0, "version": 0,
    "declared": 0.2,
    "compute": 0.5, "results": 0.5,
    "hyperbola": 0.9, "design": 1, "cut_surface": 1.2, "design_table": 1.5,
    "path": 2, "profile": 2, "sheet": 2,
    "lathe": 3,
    "toolpath": 4,
    "nose_envelope": 5, "finish": 5,
    "polishing": 6,
    "body": 7,
    "optics": 8, "machine_errors": 5, "measure": 8.5, "job": 8.5,
    "tolerance": 9, "optimize": 9,
    "iso10110": 9.4, "shop": 9.5, "api": 9.5,
    "settings": 10,
    "config": 11,
    "notes": 12,
    "export": 13,
    "report": 14,
    "pipeline": 14.5,
    "commands": 15, "cli": 15, "__main__": 15, "__init__": 16,
}


def _modules() -> dict[str, Path]:
    out = {}
    for p in PACKAGE.rglob("*.py"):
        parts = list(p.relative_to(PACKAGE.parent).with_suffix("").parts)
        if parts[-1] == "__init__" and len(parts) > 2:
            parts = parts[:-1]
        out[".".join(parts)] = p
    return out


MODULES = _modules()


def _runtime_imports(path: Path, typing: bool = False):
    """(imported module, names) of every `from lathe_mirror... import` that runs (typing:
    and those under `if TYPE_CHECKING:`)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skip = set()
    for node in ast.walk(tree):
        if not typing and isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip.update(id(n) for n in ast.walk(node))
    mod = ".".join(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    pkg = mod.split(".")[:-1]
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg[:len(pkg) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.startswith("lathe_mirror"):
                yield target, [a.name for a in node.names]
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("lathe_mirror"):
                    yield a.name, []


def _top(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def test_every_module_has_a_rank():
    assert {_top(m) for m in MODULES} <= set(RANKS)


@pytest.mark.parametrize("module", sorted(MODULES))
def test_no_upward_import_and_no_private_name(module):
    me = _top(module)
    for target, names in _runtime_imports(MODULES[module]):
        other = _top(target)
        if other != me:
            assert RANKS[other] <= RANKS[me], f"{module} imports {target}: a later stage ({other})"
        for name in names:
            full = f"{target}.{name}"
            is_module = full in MODULES
            if name.startswith("_") and not name.startswith("__") and not is_module:
                assert target == module, f"{module} imports the private name {name} from {target}"
        assert not any(p.startswith("_") and p != "__init__" for p in target.split(".")[1:]), \
            f"{module} imports the private module {target}"


@functools.cache  # parsed once a run (each is every module's syntax tree): read, never changed
def _graph(typing: bool) -> dict[str, frozenset[str]]:
    """Each module's project imports (a name that is a module counts as it); typing: the
    imports under `if TYPE_CHECKING:` too."""
    graph: dict[str, frozenset[str]] = {}
    for module, path in MODULES.items():
        deps = set()
        for target, names in _runtime_imports(path, typing=typing):
            for name in names:
                if f"{target}.{name}" in MODULES:
                    deps.add(f"{target}.{name}")
            if target in MODULES:
                deps.add(target)
        deps.discard(module)
        graph[module] = frozenset(deps)
    return graph


@pytest.mark.parametrize("typing", [False, True], ids=["runtime", "with-type-checking"])
def test_no_import_circle(typing):
    """No circle among the imports that run, nor once the annotations' imports (under
    TYPE_CHECKING) are counted: a type needed back up the chain is a concept in the wrong
    module (settings.sections holds what the checks take, settings.model the checked
    Settings)."""
    graph = _graph(typing)
    # A package's __init__ importing its own modules is how packages work; a circle is a
    # path back to where it started through modules that are not each other's package.
    state: dict[str, int] = {}

    def visit(m: str, stack: list[str]) -> None:
        state[m] = 1
        for d in graph.get(m, ()):
            if d == "lathe_mirror" or m.startswith(d + ".") or d.startswith(m + "."):
                continue  # a module and its own package(s)
            if state.get(d) == 1:
                raise AssertionError("import circle: " + " -> ".join(stack[stack.index(d):] + [d]))
            if state.get(d) is None:
                visit(d, stack + [d])
        state[m] = 2

    for m in sorted(graph):
        if state.get(m) is None:
            visit(m, [m])


#: Most project modules (outside lathe_mirror.commands) a command module may import: a
#: command parses its flags and hands typed objects to the stages, whose logic lives below.
COMMAND_IMPORTS = 10
COMMANDS = sorted(m for m in MODULES if m.startswith("lathe_mirror.commands.") and m != "lathe_mirror.commands")


@pytest.mark.parametrize("module", COMMANDS)
def test_a_command_imports_few_of_the_projects_modules(module):
    """Every import counted, those inside functions too (a lazy import is still a
    dependency); the commands' own modules are not."""
    used = {d for d in _graph(typing=True)[module] if not d.startswith("lathe_mirror.commands")}
    assert len(used) <= COMMAND_IMPORTS, \
        f"{module} imports {len(used)} project modules (at most {COMMAND_IMPORTS}): {sorted(used)}"
