"""Range from one image: the two lobes as a stereo pair with radial epipolar lines.

The paper's reason for two lobes (sections 3-4): both viewpoints F1 lie on the mirror
axis, so on an aligned camera a world point and both its images lie in one meridian
plane. Unwrapped onto one azimuth x elevation grid, each epipolar line is one column of
both panoramas and disparity is a shift in elevation along it.

Modules, in the order of the computation:
  rectify      PanoramaGrid; each lobe's annulus unwrapped through the design's inverse map
  match        dense disparity: OpenCV StereoSGBM on the transposed panoramas, sub-pixel,
               left-right consistency (cv2 imported on use)
  triangulate  disparity -> range (from the stereo centre) and 3-D points
  truth        the true range of every panorama pixel in the known room (closed form)
  resolution   the range error a disparity error causes; r10(mirror), the design figure
  stereo       the whole chain on one image, and its figures (valid fraction, errors per
               range bin)

Camera frame (ARCHITECTURE.md), mm and radians inside; metres, degrees and pixels only in
the figures' names.
"""

from .resolution import r10  # noqa: F401  (the design optimiser's one definition)
