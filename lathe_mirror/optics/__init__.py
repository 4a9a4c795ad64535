"""Optics: the camera, exact ray tracing off any mirror Profile, the paper's scene,
synthetic images and the distortion figures of a made mirror against the exact design.

Public API (stable names):
  trace_pixels(profile, camera, pixels_xy | radii_px=..., *, pose=...) -> RayHits
  meridian_hits(profile, t) -> MeridianHits;  trace_rays(profile, origin, dirs) -> RayHits
  image_displacement(made, mirror, camera=None, *, pose=...) -> DistortionMaps
  distortion_figures(made, mirror, camera=None, *, pose=...) -> {"lobes": [...]}
  render_image(profile, mirror, scene, camera=None, ...) -> (H, W, 3) uint8
  render_images(profiles, mirror, scene, ...) -> each profile's render_image, the samples made once
  image_difference(a, b, *, mask=None) -> {"rms", "ssim"};  image_differences(a, {name: b}, *, mask=None)
  build_scene(spec, *, mirror_top, mirror_radius) -> Scene;  reference_surface(name, mirror)
  polish_curve(profile, mirror, params) -> PolishCurve (figures against polishing time)
  optics.plots: displacement_vs_radius_png(maps), displacement_map_png(maps) -> PNG bytes
Modules: camera (pixels, rays, CameraPose), trace, distortion, radial (the 1-D shortcut),
scene, render, reference, polishing_curve, plots; stereo. The made surfaces
(programs, polished) are the machining job's (job.named_surface). Nothing here imports cadquery; submodules are imported on use.
"""

from .camera import ALIGNED, CameraPose  # noqa: F401
