"""Shop classes: what a hobby, a job or a precision shop holds, as every tolerance.

`[tolerance] shop = "hobby" | "job" | "precision"` sets every [tolerance.params] and
[tolerance.machine_errors] tolerance to its class's value (config.merge applies it under
the same file's own values, so a value the user writes still overrides). "custom" (the
default) leaves the declared defaults. Each value carries where it comes from: a standard
(ISO 2768, ISO 286), a catalogue class or a shop practice; docs/reference/shop-classes.md
is this table (a test holds them equal). Edge units (mm, s, deg, urad); a normal
tolerance reads each as a 3-sigma bound.
"""

from __future__ import annotations

#: The classes, least to most precise.
SHOPS = ("hobby", "job", "precision")

#: section -> key -> (hobby, job, precision) values and the source of each class's value.
TABLE: dict[str, dict[str, tuple[tuple[float, float, float], tuple[str, str, str]]]] = {
    "params": {
        "nose_radius_mm": ((0.05, 0.02, 0.005), (
            "an unmeasured pressed insert (makers' M-class nose, about +/-0.05 mm)",
            "a ground (G-class) insert as catalogued, +/-0.02 to 0.025 mm",
            "the nose measured on a tool microscope or optical comparator, to 5 um")),
        "tool_x_mm": ((0.02, 0.005, 0.002), (
            "touch-off on the part with a handwheel step of 0.01 mm, read by eye",
            "touch-off and a measured test cut (a micrometer reads 0.002 mm; two readings)",
            "a contact tool setter (repeatability ~1 um 2-sigma, makers' data) and a test cut")),
        "tool_z_mm": ((0.05, 0.01, 0.002), (
            "face touch-off by feel, a paper feeler (0.05 mm paper)",
            "face touch-off and a measured face (a depth micrometer, 0.01 mm)",
            "a contact tool setter (repeatability ~1 um 2-sigma)")),
        "polish_time_s": ((600.0, 300.0, 60.0), (
            "polished by hand, timed to about 10 min",
            "a timed polishing run, to 5 min",
            "a machine-timed polishing cycle, to 1 min")),
        "camera_decentre_mm": ((0.2, 0.05, 0.02), (
            "a 3-D printed (FDM) mount: +/-0.2 mm, the process's usual dimensional accuracy",
            "a machined bracket to ISO 2768-1 f (+/-0.05 mm from 3 to 6 mm, the spigot's lip)",
            "a fitted spigot, ISO 286 H7/g6 at 18-30 mm: at most 0.041 mm clearance, +/-0.02 mm")),
        "camera_axial_mm": ((1.0, 0.5, 0.1), (
            "the lens's entrance pupil from its catalogue drawing, +/-1 mm",
            "the pupil estimated from the lens's data and shimmed, +/-0.5 mm",
            "the pupil measured on a nodal slide (0.1 mm)")),
        "camera_tilt_deg": ((0.5, 0.1, 0.02), (
            "a printed mount: ISO 2768-1 m angular, +/-0 deg 30' (under 10 mm)",
            "machined faces: ISO 2768-2 K perpendicularity 0.2 mm over 100 mm = 0.11 deg",
            "ground faces, 0.01 mm over 25 mm: 0.023 deg")),
        "seat_tilt_deg": ((0.3, 0.1, 0.02), (
            "a faced seat on a hobby lathe, 0.05 mm over 10 mm: 0.29 deg",
            "a faced seat, ISO 2768-2 K: 0.2 mm over 100 mm = 0.11 deg",
            "a lapped seat, its runout indicated to 0.01 mm over 25 mm: 0.023 deg")),
    },
    "machine_errors": {
        "centre_height_mm": ((0.1, 0.02, 0.005), (
            "the tool set to a centre-height gauge by eye, 0.1 mm",
            "set on a height gauge and checked by the pip left at the centre, 0.02 mm",
            "set until the facing leaves no pip under a loupe, 5 um")),
        "x_offset_mm": ((0.02, 0.005, 0.001), (
            "the X zero from a diameter measured by caliper (0.02 mm)",
            "the X zero from a diameter measured by micrometer",
            "the X zero from a measured diameter and the machine's 1 um resolution")),
        "nose_radius_error_mm": ((0.05, 0.02, 0.005), (
            "the nose taken from the insert's code: its M-class tolerance",
            "the nose from a ground insert's code: its G-class tolerance",
            "the nose measured and entered in the offset table, to 5 um")),
        "squareness_urad": ((200.0, 50.0, 10.0), (
            "a hobby lathe's cross slide, 0.02 mm over 100 mm faced (a common acceptance figure)",
            "a CNC lathe's acceptance test (ISO 13041-style), 0.005 mm over 100 mm",
            "a precision lathe, 1 um over 100 mm")),
        "backlash_mm": ((0.05, 0.005, 0.001), (
            "a hobby lathe's leadscrew, uncompensated, ~0.05 mm",
            "ball screws, compensated in the control to 5 um",
            "preloaded ball screws or direct drives, 1 um")),
    },
}


def shop_values(shop: str) -> dict[str, dict[str, float]]:
    """{"params": {...}, "machine_errors": {...}}: every tolerance of the class (edge units);
    {} for "custom" or an unknown name (the key's check names what is allowed)."""
    if shop not in SHOPS:
        return {}
    i = SHOPS.index(shop)
    return {section: {k: v[0][i] for k, v in keys.items()} for section, keys in TABLE.items()}


def apply_shop(base: dict, user: dict) -> None:
    """When `user` (a configuration file's TOML, or a flag's) sets tolerance.shop, set
    base's tolerances to the class's values, before the user's own values merge over them."""
    shop = user.get("tolerance", {}).get("shop") if isinstance(user.get("tolerance"), dict) else None
    if not isinstance(shop, str) or "tolerance" not in base:
        return
    for section, values in shop_values(shop).items():
        base["tolerance"][section].update(values)


def shop_table_markdown() -> str:
    """The classes as a Markdown table (docs/reference/shop-classes.md's body)."""
    lines = ["| section | key | hobby | job | precision |", "|---|---|---|---|---|"]
    for section, keys in TABLE.items():
        for k, (vals, src) in keys.items():
            cells = [f"{v:g}: {s}" for v, s in zip(vals, src)]
            lines.append(f"| {section} | `{k}` | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"
