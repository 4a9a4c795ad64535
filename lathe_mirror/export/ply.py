"""Point clouds as PLY (Turk 1994; the format Open3D, MeshLab, CloudCompare and trimesh read).

One `vertex` element with float x, y, z and, if given, uchar red, green, blue; binary
little-endian (compact) or ASCII (readable). No timestamp or software comment: the same
points give the same bytes.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .files import write_bytes


def ply_bytes(points: np.ndarray, colours: np.ndarray | None = None, *, binary: bool = True,
              comments: tuple[str, ...] = ()) -> bytes:
    """A PLY file of points (N, 3), written as float32 in the caller's unit, with optional
    colours (N, 3) uint8. comments: header comment lines (no newlines)."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    if colours is not None:
        colours = np.asarray(colours, dtype=np.uint8).reshape(-1, 3)
        if colours.shape[0] != pts.shape[0]:
            raise ValueError(f"ply_bytes: {pts.shape[0]} points but {colours.shape[0]} colours")
        fields += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
    if any("\n" in c or "\r" in c for c in comments):
        raise ValueError("ply_bytes: a comment must be one line")
    rows = np.zeros(pts.shape[0], dtype=fields)
    for i, axis in enumerate("xyz"):
        rows[axis] = pts[:, i]
    if colours is not None:
        for i, name in enumerate(("red", "green", "blue")):
            rows[name] = colours[:, i]
    header = ["ply", f"format {'binary_little_endian' if binary else 'ascii'} 1.0"]
    header += [f"comment {c}" for c in comments]
    header.append(f"element vertex {pts.shape[0]}")
    header += [f"property float {a}" for a in "xyz"]
    if colours is not None:
        header += [f"property uchar {c}" for c in ("red", "green", "blue")]
    header.append("end_header")
    head = ("\n".join(header) + "\n").encode("ascii")
    if binary:
        return head + rows.tobytes()
    # %.9g: nine significant digits read back to the same float32 (IEEE 754, section 5.12).
    import io

    table = np.column_stack([rows[a].astype(np.float64) for a in "xyz"])
    fmt = ["%.9g"] * 3
    if colours is not None:
        table = np.column_stack([table, colours.astype(np.float64)])
        fmt += ["%d"] * 3
    buf = io.StringIO()
    np.savetxt(buf, table, fmt=fmt, delimiter=" ", newline="\n")
    return head + buf.getvalue().encode("ascii")

def write_ply(path: str | Path, points: np.ndarray, colours: np.ndarray | None = None, *,
              binary: bool = True, comments: tuple[str, ...] = ()) -> Path:
    """Write ply_bytes(points, colours, ...) to path atomically (export.files)."""
    return write_bytes(path, ply_bytes(points, colours, binary=binary, comments=comments))
