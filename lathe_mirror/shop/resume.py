"""A set-up's simulation resumed where its operations first differ from the last ones
simulated with the same stock, part, chuck, tools and lathe.

shop_program simulates a program, reads the finishing passes' depth of cut and, when a
pass cuts too deep, plans the program again with more passes and simulates it again: the
face, the roughing and the semi-finish are the same operations (most of the time), only the
finishing passes differ. The snapshots of the first run's state before each operation let
the second start at its first finishing pass: the same figures and contacts as from the
start (the replay is deterministic), at a fraction of the cost.
"""

from __future__ import annotations


class Resume:
    """What shop.stock.simulate_setup keeps of one run (resume=): the run's inputs, its
    operations, its state before each of them and each one's figures."""

    def __init__(self) -> None:
        self.inputs: tuple | None = None
        self.operations: list = []
        self.states: list = []
        self.figures: list = []

    def common(self, inputs: tuple, operations: list) -> int:
        """How many leading operations a run with these inputs shares with the kept one."""
        if self.inputs is None or self.inputs != inputs:
            return 0
        k, n = 0, min(len(operations), len(self.operations))
        while k < n and operations[k] == self.operations[k]:
            k += 1
        return k

    def keep(self, inputs: tuple, operations: list, states: list, figures: list) -> None:
        self.inputs, self.operations, self.states, self.figures = inputs, list(operations), states, figures


def run_inputs(shapes: dict, lathe, start, part, chuck, gouge_tolerance: float, rapid_rate: float) -> tuple:
    """A set-up's inputs as Resume compares them (==): geometry as WKB, the tools'
    outlines, the lathe, the tolerances."""
    import shapely

    tools = tuple(sorted(((str(k), s.kind, shapely.to_wkb(s.outline), shapely.to_wkb(s.cutting))
                          for k, s in shapes.items()), key=lambda t: t[0]))
    return (tools, lathe, shapely.to_wkb(start), shapely.to_wkb(part), shapely.to_wkb(chuck),
            float(gouge_tolerance), float(rapid_rate))

