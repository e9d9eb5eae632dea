"""Physics-based vision: photometric stereo, light calibration, normal integration and metrics.

Camera frame used throughout (the DiLiGenT convention, verified on its data): x to the right of
the image, y up, z towards the camera; the viewer is at (0, 0, 1) (orthographic) and light
directions point from the surface towards the light. Images are indexed ``[row, column]`` with
rows going *down*, so the y component of a direction is minus the row direction.

Modules: :mod:`~brdfkit.vision.datasets` (DiLiGenT and the classic "psm" course layout),
:mod:`~brdfkit.vision.synthesis` (images of given normals under distant lights, for any BRDF),
:mod:`~brdfkit.vision.photometric_stereo` (Lambertian least squares, robust estimators, chrome
sphere calibration), :mod:`~brdfkit.vision.consensus` and
:mod:`~brdfkit.vision.bivariate_stereo` (non-Lambertian photometric stereo),
:mod:`~brdfkit.vision.inverse_rendering_stereo` (normals and a microfacet reflectance fitted
together by inverse rendering, with cast shadows),
:mod:`~brdfkit.vision.uncalibrated` (lights and normals from the images alone),
:mod:`~brdfkit.vision.svbrdf` and :mod:`~brdfkit.vision.visibility` (spatially varying BRDFs,
shadows and relighting), :mod:`~brdfkit.vision.normal_integration` and
:mod:`~brdfkit.vision.bilateral_integration` (normals to depth; the pipeline of ``brdfkit
integrate`` in :mod:`~brdfkit.vision.depth_from_normals`),
:mod:`~brdfkit.vision.shape_from_shading` (depth from one image),
:mod:`~brdfkit.vision.lighting` (illumination from an image),
:mod:`~brdfkit.vision.separation` (diffuse and specular reflection apart),
:mod:`~brdfkit.vision.calibration` (linear images, camera response, HDR merging) and
:mod:`~brdfkit.vision.metrics` (angular errors as the DiLiGenT benchmark computes them).
"""
