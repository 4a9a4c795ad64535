"""lathe-mirror: design, turn, render and tolerance double-lobed hyperbolic mirrors."""

__version__ = "0.1.0"
