"""In-function imports of the project's own modules only where they keep something off a
path that does not need it (issue 26), read from the source with `ast`.

Below the command layer (lathe_mirror/commands/, cli.py, __main__.py: the CLI's start-up
may import lazily), every import of a lathe_mirror module inside a function carries a
`# lazy: <reason>` comment on one of its lines (today: a module kept off the CLI's
start-up path, `lathe-mirror --help` or a refused configuration). A new one without it
fails here: move it to the module's top, or say why it is lazy.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "lathe_mirror"
COMMAND_LAYER = ("commands",)
COMMAND_FILES = ("cli.py", "__main__.py")


def _in_function_own_imports():
    """(file, line, statement text) of each import of a lathe_mirror module inside a function."""
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE)
        if rel.parts[0] in COMMAND_LAYER or str(rel) in COMMAND_FILES:
            continue
        src = path.read_text(encoding="utf-8")
        lines = src.splitlines()
        found = []

        def visit(node, in_function):
            for child in ast.iter_child_nodes(node):
                if in_function and isinstance(child, ast.ImportFrom) and (
                        child.level or (child.module or "").startswith("lathe_mirror")):
                    found.append(child)
                if in_function and isinstance(child, ast.Import) and any(
                        a.name.startswith("lathe_mirror") for a in child.names):
                    found.append(child)
                visit(child, in_function or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef,
                                                                ast.Lambda)))

        visit(ast.parse(src), False)
        for node in found:
            # the statement's lines and a comment line right above it
            first = node.lineno - 1
            above = lines[first - 1] if first > 0 and lines[first - 1].strip().startswith("#") else ""
            yield str(rel), node.lineno, "\n".join([above] + lines[first:node.end_lineno])


def test_every_in_function_import_of_the_project_says_why():
    unmarked = [f"lathe_mirror/{f}:{n}" for f, n, text in _in_function_own_imports()
                if not re.search(r"# lazy: \S", text)]
    assert not unmarked, ("in-function imports of lathe_mirror modules without a '# lazy: <reason>' "
                          "comment (move them to the module's top, or say why): " + ", ".join(unmarked))


def test_the_lazy_ones_are_few():
    """The count the issue started from was 222 in-function imports of the project's own
    modules; what is left below the command layer is a handful, each with its reason."""
    assert len(list(_in_function_own_imports())) <= 20


def test_design_starts_without_the_heavy_libraries():
    """`lathe-mirror design` in a new process imports none of the libraries only other
    stages need (plots, OpenCV, the CAD kernel, the FFT, the optimisers, shapely): each
    costs 0.1 to 2.5 s of start-up on every command that pays it."""
    import subprocess
    import sys

    heavy = ("matplotlib", "cv2", "cadquery", "OCP", "scipy.fft", "scipy.optimize", "shapely")
    code = ("import sys\nfrom lathe_mirror.cli import main\nmain(['design'])\n"
            f"print([m for m in {heavy!r} if m in sys.modules], file=sys.stderr)\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.strip().splitlines()[-1] == "[]", proc.stderr
