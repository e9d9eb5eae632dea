"""Physics-based vision: photometric stereo, light calibration, normal integration and metrics.

Camera frame used throughout (the DiLiGenT convention, verified on its data): x to the right of
the image, y up, z towards the camera; the viewer is at (0, 0, 1) (orthographic) and light
directions point from the surface towards the light. Images are indexed ``[row, column]`` with
rows going *down*, so the y component of a direction is minus the row direction.

Modules: :mod:`~brdfkit.vision.datasets` (DiLiGenT and the classic "psm" course layout),
:mod:`~brdfkit.vision.photometric_stereo` (Lambertian least squares, robust estimators, chrome
sphere calibration), :mod:`~brdfkit.vision.normal_integration` (normals to
depth) and :mod:`~brdfkit.vision.metrics` (angular errors as the DiLiGenT benchmark computes them).
"""
