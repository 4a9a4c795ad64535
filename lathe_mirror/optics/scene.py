"""The paper's room (section 6, Fig. 11), closed-form ray intersection and Lambert shading.

Camera frame, mm: the floor is the plane z = -camera_height, the ceiling z = room_height
- camera_height, the walls x = x_lo / x_hi and y = y_lo / y_hi; boxes stand on the floor,
axis-aligned. Everything is a plane or a box, so a ray's hit is closed form (the slab
method, Kay & Kajiya 1986), vectorised over all rays.

Shading is Lambert plus ambient under one distant shadowless light, so each face has one
shade and edges read: colour = pigment * (ambient + diffuse * max(0, n . l)), l the unit
vector toward the light. The checker of the floor and walls is POV-Ray's: square colour
index = (floor(x / s) + floor(y / s) + floor(z / s)) mod 2, the first colour on even; its
planes are placed off the checker's own grid lines so no face sits on a square edge.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..declared.section import Conv, section_repr, setting
from ..errors import InputError
from ..inputs import check_type

# Surface ids: the room's six planes, then box faces (by axis and sign of their normal).
FLOOR, CEILING, X_LO, X_HI, Y_LO, Y_HI = range(6)
BOX_FACE0 = 6  # + 2 * axis + (1 if the normal points + else 0)
N_SURFACES = 12


@dataclass(frozen=True)
class Box:
    """An axis-aligned box: corners lo, hi (x, y, z), mm."""

    lo: tuple[float, float, float]
    hi: tuple[float, float, float]


@dataclass(frozen=True)
class Scene:
    """A square room with checkered floor and walls and boxes on the floor. mm, linear RGB.

    bounds: (x_lo, x_hi, y_lo, y_hi, z_floor, z_ceiling) of the room in the camera frame.
    floor_square, wall_square: checker square sides. light: unit vector toward the light.
    """

    bounds: tuple[float, float, float, float, float, float]
    boxes: tuple[Box, ...]
    floor_square: float
    wall_square: float
    ambient: float
    diffuse: float
    light: tuple[float, float, float]
    floor_colours: tuple[tuple[float, float, float], tuple[float, float, float]]
    x_wall_colours: tuple[tuple[float, float, float], tuple[float, float, float]]
    y_wall_colours: tuple[tuple[float, float, float], tuple[float, float, float]]
    ceiling_colour: tuple[float, float, float]
    box_colour: tuple[float, float, float]

    def __repr__(self) -> str:
        # one line: the room's size and its boxes (the colours and the lighting: its fields)
        x0, x1, y0, y1, z0, z1 = self.bounds
        return f"Scene(room {x1 - x0:g} x {y1 - y0:g} x {z1 - z0:g} mm, {len(self.boxes)} boxes)"

    def normals(self) -> np.ndarray:
        """Unit normal of every surface id, facing into the room / out of the box (12, 3)."""
        n = np.zeros((N_SURFACES, 3))
        n[FLOOR, 2], n[CEILING, 2] = 1.0, -1.0
        n[X_LO, 0], n[X_HI, 0], n[Y_LO, 1], n[Y_HI, 1] = 1.0, -1.0, 1.0, -1.0
        for axis in range(3):
            n[BOX_FACE0 + 2 * axis, axis] = -1.0
            n[BOX_FACE0 + 2 * axis + 1, axis] = 1.0
        return n

    def shades(self) -> np.ndarray:
        """Lambert factor ambient + diffuse * max(0, n . l) of every surface id (12,)."""
        return self.ambient + self.diffuse * np.maximum(0.0, self.normals() @ np.array(self.light))


@dataclass(frozen=True)
class BoxSpec:
    """A box of [[scene.boxes]]: centre (x, y) on the floor and size (x, y, z), mm."""

    centre: tuple[float, ...]
    size: tuple[float, ...]


#: [[scene.boxes]] in the file, BoxSpecs in the field.
BOXES = Conv(lambda v, w="": tuple(BoxSpec(centre=tuple(b["centre"]), size=tuple(b["size"])) for b in v),
             lambda v: [{"centre": list(b.centre), "size": list(b.size)} for b in v])


@dataclass(frozen=True)
class SceneSpec:
    """The [scene] section as given (mm; colours linear RGB 0..1; see data/scene.toml).
    build_scene checks it against the mirror and makes the Scene."""

    __repr__ = section_repr  # one line: the fields off their declared defaults

    room_size: float = setting("scene.room_size")
    room_height: float = setting("scene.room_height")
    camera_height: float = setting("scene.camera_height")
    room_centre: tuple[float, ...] = setting("scene.room_centre")
    floor_square: float = setting("scene.floor_square")
    wall_square: float = setting("scene.wall_square")
    ambient: float = setting("scene.ambient")
    diffuse: float = setting("scene.diffuse")
    light_direction: tuple[float, ...] = setting("scene.light_direction")
    floor_colours: tuple[float, ...] = setting("scene.floor_colours")
    x_wall_colours: tuple[float, ...] = setting("scene.x_wall_colours")
    y_wall_colours: tuple[float, ...] = setting("scene.y_wall_colours")
    ceiling_colour: tuple[float, ...] = setting("scene.ceiling_colour")
    box_colour: tuple[float, ...] = setting("scene.box_colour")
    boxes: tuple[BoxSpec, ...] = setting("scene.boxes", BOXES)


def build_scene(spec: SceneSpec, *, mirror_top: float = 0.0, mirror_radius: float = 0.0) -> Scene:
    """The room of `spec` as a Scene; checks that the camera, mirror and boxes fit the room.

    mirror_top (mm): the mirror's highest point above the camera; mirror_radius (mm): its
    rim radius. Raises InputError naming the key on an empty or impossible scene.
    """
    check_type(spec, "build_scene: spec", SceneSpec, "a SceneSpec (settings.scene)")
    sc = {k: getattr(spec, k) for k in spec.__dataclass_fields__}
    sc["room_centre"] = list(spec.room_centre)
    sc["boxes"] = [{"centre": list(b.centre), "size": list(b.size)} for b in spec.boxes]
    side, height, cam_h = sc["room_size"], sc["room_height"], sc["camera_height"]
    for key in ("room_size", "room_height", "camera_height", "floor_square", "wall_square"):
        if not sc[key] > 0:
            raise InputError(f"scene.{key} = {sc[key]:g} mm must be > 0")
    if not cam_h + mirror_top < height:
        raise InputError(
            f"scene.camera_height = {cam_h:g} mm: the mirror's top ({mirror_top:.1f} mm above the "
            f"camera) must stay below the ceiling (scene.room_height = {height:g} mm)"
        )
    cx, cy = _pair(sc["room_centre"], "scene.room_centre")
    half = side / 2.0
    bounds = (cx - half, cx + half, cy - half, cy + half, -cam_h, height - cam_h)
    reach = max(mirror_radius, 1.0)
    if not (bounds[0] < -reach and bounds[1] > reach and bounds[2] < -reach and bounds[3] > reach):
        raise InputError(
            f"scene.room_centre = {list(sc['room_centre'])}: the camera and mirror (radius "
            f"{mirror_radius:g} mm) must be inside the room (side {side:g} mm)"
        )
    if not sc["boxes"]:
        raise InputError(
            "scene.boxes is empty: the scene needs at least one [[scene.boxes]] "
            "(centre = [x, y], size = [x, y, z] in mm; the paper's room has three)"
        )
    boxes = []
    for i, b in enumerate(sc["boxes"]):
        key = f"scene.boxes[{i}]"
        bx, by = _pair(b["centre"], f"{key}.centre")
        size = [float(v) for v in b["size"]]
        if len(size) != 3 or min(size) <= 0:
            raise InputError(f"{key}.size = {b['size']}: give three sizes (x, y, z) > 0 mm")
        lo = (bx - size[0] / 2, by - size[1] / 2, bounds[4])
        hi = (bx + size[0] / 2, by + size[1] / 2, bounds[4] + size[2])
        if lo[0] < bounds[0] or hi[0] > bounds[1] or lo[1] < bounds[2] or hi[1] > bounds[3] or hi[2] > bounds[5]:
            raise InputError(f"{key}: the box (centre {b['centre']}, size {b['size']} mm) must fit in the room")
        if lo[0] <= reach and hi[0] >= -reach and lo[1] <= reach and hi[1] >= -reach:
            raise InputError(
                f"{key}: the box (centre {b['centre']}, size {b['size']} mm) stands on the camera's "
                f"axis; keep it clear of the mirror (radius {mirror_radius:g} mm)"
            )
        boxes.append(Box(lo, hi))
    for key in ("ambient", "diffuse"):
        if not 0 <= sc[key] <= 1:
            raise InputError(f"scene.{key} = {sc[key]:g}: allowed 0..1 (fraction of the pigment)")
    light = np.asarray(sc["light_direction"], float)
    if light.shape != (3,) or not np.linalg.norm(light) > 0:
        raise InputError(f"scene.light_direction = {sc['light_direction']}: give a non-zero (x, y, z)")
    return Scene(
        bounds=bounds,
        boxes=tuple(boxes),
        floor_square=float(sc["floor_square"]),
        wall_square=float(sc["wall_square"]),
        ambient=float(sc["ambient"]),
        diffuse=float(sc["diffuse"]),
        light=tuple(float(x) for x in -light / np.linalg.norm(light)),
        floor_colours=_colours(sc["floor_colours"], "scene.floor_colours", 2),
        x_wall_colours=_colours(sc["x_wall_colours"], "scene.x_wall_colours", 2),
        y_wall_colours=_colours(sc["y_wall_colours"], "scene.y_wall_colours", 2),
        ceiling_colour=_colours(sc["ceiling_colour"], "scene.ceiling_colour", 1)[0],
        box_colour=_colours(sc["box_colour"], "scene.box_colour", 1)[0],
    )


def intersect(scene: Scene, origin: np.ndarray, direction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First hit of rays (origins (N, 3) inside the room, directions (N, 3)).

    Returns (distance along the direction, surface id); every ray inside the closed room
    hits something.
    """
    oc, dc = _columns(origin), _columns(direction)
    return intersect_columns(scene, oc, dc)


def shade(scene: Scene, origin: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """Linear RGB in 0..1 of what rays see (N, 3)."""
    return shade_columns(scene, _columns(origin), _columns(direction))


def intersect_columns(scene: Scene, oc, dc) -> tuple[np.ndarray, np.ndarray]:
    """intersect() on the coordinates as three 1-D arrays each (x, y, z): numpy is much
    faster on contiguous columns than on a length-3 axis."""
    with np.errstate(divide="ignore"):
        inv = [1.0 / x for x in dc]  # +-inf along an axis the ray does not move on
    bounds = scene.bounds
    ids = ((X_LO, X_HI), (Y_LO, Y_HI), (FLOOR, CEILING))
    dist = None
    surface = None
    # Leaving the room: per axis, the plane ahead of the ray; keep the nearest. Choosing
    # "ahead" by the sign of 1/d also sends a zero component (1/d = +-inf) to +inf.
    for axis in range(3):
        pos = inv[axis] > 0
        ahead = np.where(pos, bounds[2 * axis + 1], bounds[2 * axis])
        s = (ahead - oc[axis]) * inv[axis]
        this = np.where(pos, ids[axis][1], ids[axis][0])
        if dist is None:
            dist, surface = s, this
        else:
            better = s < dist
            dist = np.where(better, s, dist)
            surface = np.where(better, this, surface)
    # dist and surface are np.where's fresh arrays: the boxes update them in place.
    candidates = _box_candidates(scene.boxes, oc, dc)
    for box, idx in zip(scene.boxes, candidates):
        o = [x if idx is None else x[idx] for x in oc]
        iv = [x if idx is None else x[idx] for x in inv]
        t_near = t_far = face = None
        for axis in range(3):
            t1 = (box.lo[axis] - o[axis]) * iv[axis]
            t2 = (box.hi[axis] - o[axis]) * iv[axis]
            near = np.fmin(t1, t2)
            far = np.fmax(t1, t2)
            # The face entered has its normal against the ray: + side when the ray goes -.
            this = BOX_FACE0 + 2 * axis + (iv[axis] < 0)
            if t_near is None:
                t_near, t_far, face = near, far, this
            else:
                later = near > t_near
                t_near = np.where(later, near, t_near)
                face = np.where(later, this, face)
                t_far = np.fmin(t_far, far)
        sel = slice(None) if idx is None else idx
        hit = (t_near <= t_far) & (t_near > 0) & (t_near < dist[sel])
        rows = np.flatnonzero(hit) if idx is None else idx[hit]
        dist[rows] = t_near[hit]
        surface[rows] = face[hit]
    return dist, surface


def shade_columns(scene: Scene, oc, dc) -> np.ndarray:
    """shade() on the coordinates as three 1-D arrays each (x, y, z)."""
    return pigment_table(scene)[pigment_index(scene, oc, dc)]


def pigment_table(scene: Scene) -> np.ndarray:
    """Linear RGB seen on each surface id and checker parity (N_SURFACES, 2, 3): the
    pigment (even squares, odd squares) times the face's Lambert shade. Every hit shows
    one of these 24 colours."""
    table = np.zeros((N_SURFACES, 2, 3))
    table[FLOOR] = scene.floor_colours
    table[CEILING] = (scene.ceiling_colour, scene.ceiling_colour)
    table[[X_LO, X_HI]] = scene.x_wall_colours
    table[[Y_LO, Y_HI]] = scene.y_wall_colours
    table[BOX_FACE0:] = (scene.box_colour, scene.box_colour)
    return table * scene.shades()[:, None, None]


def pigment_index(scene: Scene, oc, dc) -> tuple[np.ndarray, np.ndarray]:
    """(surface id, checker parity) of what rays (coordinate columns, mm) see: an index
    into pigment_table."""
    dist, surface = intersect_columns(scene, oc, dc)
    inv_size = np.where(surface == FLOOR, 1.0 / scene.floor_square, 1.0 / scene.wall_square)
    cells = np.floor((oc[0] + dist * dc[0]) * inv_size)
    cells += np.floor((oc[1] + dist * dc[1]) * inv_size)
    cells += np.floor((oc[2] + dist * dc[2]) * inv_size)  # small integers: exact in float
    return surface, cells.astype(np.int64) & 1


def _box_candidates(boxes, oc, dc) -> list[np.ndarray | None]:
    """Per box, the indices of the rays that may hit it (None: all of them). Conservative.

    A ray o + t d (t > 0) that meets a box meets the disc of radius R_b (the half diagonal
    of its floor rectangle) about the rectangle's centre c in plan view; with every |o_xy|
    <= r0, the plan direction d_xy then lies within asin(rho) of c, rho = (R_b + r0) / |c|
    (for rho < 1/sqrt(2), where the opposite direction is ruled out too), so
    d_xy . c / |c| >= sqrt(1 - rho^2) |d_xy|. Rays of the mirror (r0 <= 35 mm) toward a
    box metres away: about a tenth of them pass, so the slab test runs on a tenth.
    """
    ox, oy = oc[0], oc[1]
    if np.ndim(ox) == 0 or np.size(ox) == 0:
        return [None] * len(boxes)
    r0 = float(np.sqrt(np.max(ox * ox + oy * oy)))
    d_xy = None
    out = []
    for box in boxes:
        cx, cy = 0.5 * (box.lo[0] + box.hi[0]), 0.5 * (box.lo[1] + box.hi[1])
        c = float(np.hypot(cx, cy))
        r_b = 0.5 * float(np.hypot(box.hi[0] - box.lo[0], box.hi[1] - box.lo[1]))
        rho = (r_b + r0) / c if c > 0 else np.inf
        if not rho < 0.7:
            out.append(None)
            continue
        if d_xy is None:
            d_xy = np.sqrt(dc[0] * dc[0] + dc[1] * dc[1])
        cos_limit = np.sqrt(1.0 - rho * rho) - 1e-9  # margin for rounding
        out.append(np.flatnonzero(dc[0] * (cx / c) + dc[1] * (cy / c) >= cos_limit * d_xy))
    return out


def _columns(a: np.ndarray) -> list[np.ndarray]:
    a = np.asarray(a, float)
    return [np.ascontiguousarray(a[:, i]) for i in range(3)]


def _pair(value, key: str) -> tuple[float, float]:
    if len(value) != 2:
        raise InputError(f"{key} = {value}: give two numbers (x, y) in mm")
    return float(value[0]), float(value[1])


def _colours(value, key: str, n: int) -> tuple:
    v = [float(x) for x in value]
    if len(v) != 3 * n or min(v) < 0 or max(v) > 1:
        raise InputError(f"{key} = {value}: give {n} RGB triple(s), {3 * n} numbers in 0..1")
    return tuple(tuple(v[3 * i:3 * i + 3]) for i in range(n))
