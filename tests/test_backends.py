"""Every public array function of geometry, radiometry, fresnel and sampling runs on NumPy
float64 and float32 (dtype kept) and on torch float64 tensors (results stay tensors and equal
NumPy's to 1e-10).

Each case of :data:`CASES` is ``(callable, args)`` with ``args`` NumPy float64 arrays that are
converted to the backend under test before the call; Python scalars inside the callables are
structural parameters (quadrature orders, surface radii) that the API types as ``float``/``int``.
:func:`test_cases_cover_every_public_function` fails when a public function is added to one of
these modules without a case here (or an explicit, justified exclusion).
"""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit import fresnel, geometry, radiometry, sampling

MODULES = {
    "geometry": geometry,
    "radiometry": radiometry,
    "fresnel": fresnel,
    "sampling": sampling,
}

EXCLUDED = {
    # constants, not functions
    "radiometry.HEMISPHERE_SOLID_ANGLE",
    "radiometry.SPHERE_SOLID_ANGLE",
    # a type alias (Callable), not a function
    "radiometry.Surface",
    # preset tables (dicts of Python floats)
    "fresnel.CONDUCTORS",
    "fresnel.IOR",
    # name lookups: take a string, return Python floats
    "fresnel.conductor",
    "fresnel.dielectric",
    # documented to reduce spectral tables to a float64 NumPy (3,) array (brdfkit.data.colorimetry)
    "fresnel.rgb_from_spectrum",
    # documented to return float64 NumPy arrays (a SciPy wrapper; a seeded NumPy generator)
    "sampling.sobol",
    "sampling.hemisphere_pairs",
}


FLOAT32_ULPS = 64 * float(np.finfo(np.float32).eps)


def _unit(*rows: tuple[float, float, float]) -> np.ndarray:
    """Rows normalised to unit length, float64."""
    v = np.asarray(rows, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


_rng = np.random.default_rng(20240611)
# directions of the upper hemisphere (z > 0), and pairs for half/difference coordinates
WI = _unit((0.3, -0.2, 0.9), (-0.5, 0.4, 0.6), (0.1, 0.7, 0.4), (0.0, 0.0, 1.0))
WO = _unit((-0.4, 0.1, 0.8), (0.6, 0.5, 0.3), (0.2, -0.3, 0.9), (0.5, 0.0, 0.7))
# mixed hemispheres: from above, from below, grazing from below (total internal reflection)
W_BOTH = _unit((0.3, -0.2, 0.9), (0.2, 0.1, -0.9), (0.95, 0.0, -0.1), (-0.6, 0.3, 0.5))
NORMALS = _unit((0.1, 0.2, 0.95), (0.6, -0.3, 0.2), (0.0, 0.0, -1.0), (-0.3, 0.8, 0.1))
TANGENTS = _unit((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (1.0, 1.0, 0.0), (1.0, 0.0, 0.0))
FRAME = tuple(np.asarray(e) for e in geometry.frame_from_normal(_unit((0.2, -0.4, 0.8))[0]))
U = _rng.uniform(0.0, 1.0, size=(6, 2))
COS_THETA = np.array([1.0, 0.8, 0.3, 0.05, 0.0, -0.2, -0.7, -1.0])
A, B, C = _unit((0.2, 0.1, 1.0)), _unit((0.9, 0.2, 0.6)), _unit((0.3, 0.9, 0.5))
ORIGIN3 = np.zeros(3)
# points seen from off the surfaces: above, below and beside
POINTS = np.array([[0.1, 0.2, 1.5], [-0.3, 0.4, -0.8], [2.0, -1.0, 0.3]])
IMAGE = np.array([[1.0, 2.0, 0.0, 4.0], [0.5, 0.0, 3.0, 1.0], [0.0, 0.0, 0.0, 0.0]])
DISTRIBUTION = sampling.Distribution2D(IMAGE)
GRID = np.meshgrid(np.linspace(0.05, 0.95, 3), np.linspace(0.1, 0.9, 3), indexing="ij")
TRIANGLE = (ORIGIN3, np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.2]))


def _flux_radiance(directions, points):
    """A radiance that varies with direction and position: L = cos²θ (1 + x), (..., 1)."""
    return directions[..., 2:3] ** 2 * (1 + points[..., 0:1])


CASES: dict[str, tuple] = {
    # ------------------------------------------------------------------ geometry
    "geometry.cartesian_to_spherical": (geometry.cartesian_to_spherical, (W_BOTH,)),
    "geometry.critical_angle": (geometry.critical_angle, (np.array([1.0, 1.33, 1.5, 2.4]),)),
    "geometry.frame_from_normal": (geometry.frame_from_normal, (NORMALS,)),
    "geometry.frame_from_normal[tangent]": (geometry.frame_from_normal, (NORMALS, TANGENTS)),
    "geometry.from_half_diff": (
        geometry.from_half_diff,
        (
            np.array([0.1, 0.5, 1.2]),
            np.array([-2.0, 0.3, 3.0]),
            np.array([0.2, 0.9, 0.4]),
            np.array([1.0, -0.7, 2.5]),
        ),
    ),
    "geometry.half_vector": (geometry.half_vector, (WI, WO)),
    "geometry.reflect": (geometry.reflect, (W_BOTH,)),
    "geometry.reflect[normal]": (geometry.reflect, (WI, NORMALS)),
    "geometry.refract": (geometry.refract, (W_BOTH, np.array(1.5))),
    "geometry.refract[normal]": (geometry.refract, (WI, np.array(1.33), NORMALS)),
    "geometry.spherical_to_cartesian": (
        geometry.spherical_to_cartesian,
        (np.array([0.0, 0.4, 1.3, 2.8]), np.array([0.5, -1.0, 2.0, 3.1])),
    ),
    "geometry.to_half_diff": (geometry.to_half_diff, (WI, WO)),
    "geometry.to_isotropic": (geometry.to_isotropic, (WI, WO)),
    "geometry.to_local": (lambda v, s, t, n: geometry.to_local(v, (s, t, n)), (WI, *FRAME)),
    "geometry.to_world": (lambda v, s, t, n: geometry.to_world(v, (s, t, n)), (WI, *FRAME)),
    # ------------------------------------------------------------------ radiometry
    "radiometry.basic_radiance": (
        radiometry.basic_radiance,
        (np.array([[0.2, 1.0, 3.0]]), np.array([[1.0], [1.5], [2.4]])),
    ),
    "radiometry.cap_surface": (
        lambda center, axis, u, v: radiometry.cap_surface(center, axis, 0.7, 1.1)(u, v),
        (np.array([0.1, -0.2, 0.3]), NORMALS[0], *GRID),
    ),
    "radiometry.disk_surface": (
        lambda center, normal, u, v: radiometry.disk_surface(center, normal, 0.8)(u, v),
        (np.array([0.1, -0.2, 0.3]), NORMALS[1], *GRID),
    ),
    "radiometry.intensity_lambertian": (
        radiometry.intensity_lambertian,
        (np.array([0.5, 1.0, 2.0]), np.array([[0.3], [1.2]]), np.array([[0.8], [-0.4]])),
    ),
    "radiometry.irradiance_disk_source": (
        radiometry.irradiance_disk_source,
        (
            np.array(2.0),
            np.array([0.5, 1.0, 2.0]),
            np.array([1.0, 0.3, 2.5]),
            np.array([0.0, 1.5, 0.7]),
        ),
    ),
    "radiometry.irradiance_point_source": (
        radiometry.irradiance_point_source,
        (np.array([1.0, 2.0, 3.0]), np.array([0.0, 0.0, 2.0]), POINTS, NORMALS[:3]),
    ),
    "radiometry.irradiance_sphere_source": (
        radiometry.irradiance_sphere_source,
        # facing the sphere, tilted so that it straddles the horizon, facing away
        (
            np.array([1.0, 0.5]),
            np.array([0.0, 0.0, 3.0]),
            np.array(1.0),
            np.zeros((3, 3)),
            _unit((0.0, 0.1, 1.0), (1.0, 0.0, 0.2), (0.0, 0.3, -1.0)),
        ),
    ),
    "radiometry.radiance_across_interface": (
        radiometry.radiance_across_interface,
        (np.array([0.3, 1.0, 2.0]), np.array([1.0, 1.5, 1.33]), np.array([1.5, 1.0, 2.4])),
    ),
    "radiometry.radiance_from_exitance": (
        radiometry.radiance_from_exitance,
        (np.array([0.0, 1.0, 5.5]),),
    ),
    "radiometry.radiance_from_intensity": (
        radiometry.radiance_from_intensity,
        (np.array([1.0, 2.0]), np.array([[0.5], [2.0]]), np.array([[1.0], [0.3]])),
    ),
    "radiometry.radiant_flux": (
        lambda like, corner, edge_u, edge_v: radiometry.radiant_flux(
            _flux_radiance,
            radiometry.rectangle_surface(corner, edge_u, edge_v),
            1.0,
            order=4,
            like=like,
        ),
        (
            np.zeros(()),
            np.array([0.0, 0.0, 0.0]),
            np.array([1.0, 0.0, 0.0]),
            np.array([0.0, 2.0, 0.5]),
        ),
    ),
    "radiometry.rectangle_surface": (
        lambda corner, edge_u, edge_v, u, v: radiometry.rectangle_surface(corner, edge_u, edge_v)(
            u, v
        ),
        (
            np.array([0.1, 0.2, 0.0]),
            np.array([1.0, 0.0, 0.2]),
            np.array([0.0, 2.0, 0.0]),
            *GRID,
        ),
    ),
    "radiometry.solid_angle_cap": (radiometry.solid_angle_cap, (np.array([0.0, 0.3, 1.57, 3.1]),)),
    "radiometry.solid_angle_disk": (
        lambda center, normal, radius, point: radiometry.solid_angle_disk(
            center, normal, radius, point, order=32
        ),
        (ORIGIN3, NORMALS[0], np.array(0.9), POINTS),
    ),
    "radiometry.solid_angle_disk_on_axis": (
        radiometry.solid_angle_disk_on_axis,
        (np.array([0.5, 1.0, 2.0]), np.array([0.1, 1.0, 30.0])),
    ),
    "radiometry.solid_angle_patch": (
        radiometry.solid_angle_patch,
        (ORIGIN3, NORMALS[:3], np.array([0.01, 0.02, 0.005]), POINTS),
    ),
    "radiometry.solid_angle_polygon": (
        radiometry.solid_angle_polygon,
        # a non-convex pentagon in z = 0
        (
            np.array(
                [
                    [0.0, 0.0, 0.0],
                    [2.0, 0.0, 0.0],
                    [2.0, 2.0, 0.0],
                    [1.0, 0.5, 0.0],
                    [0.0, 2.0, 0.0],
                ]
            ),
            POINTS,
        ),
    ),
    "radiometry.solid_angle_polygon[signed]": (
        lambda vertices, point: radiometry.solid_angle_polygon(vertices, point, signed=True),
        (np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 2.0, 0.0], [0.0, 2.0, 0.0]]), POINTS),
    ),
    "radiometry.solid_angle_rectangle": (
        radiometry.solid_angle_rectangle,
        (np.array([-0.5, -0.5, 0.0]), np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.5, 0.3]), POINTS),
    ),
    "radiometry.solid_angle_sphere": (
        radiometry.solid_angle_sphere,
        # outside, outside, inside
        (
            np.array([0.0, 0.0, 0.5]),
            np.array(0.4),
            np.array([[0.1, 0.2, 1.5], [2.0, -1.0, 0.3], [0.1, 0.0, 0.6]]),
        ),
    ),
    "radiometry.solid_angle_surface": (
        lambda a, b, c, point: radiometry.solid_angle_surface(
            radiometry.triangle_surface(a, b, c), point, order=8
        ),
        (*TRIANGLE, POINTS),
    ),
    "radiometry.solid_angle_triangle": (
        radiometry.solid_angle_triangle,
        (*TRIANGLE, POINTS),
    ),
    "radiometry.solid_angle_triangle[signed]": (
        lambda a, b, c, point: radiometry.solid_angle_triangle(a, b, c, point, signed=True),
        (*TRIANGLE, POINTS),
    ),
    "radiometry.triangle_surface": (
        lambda a, b, c, u, v: radiometry.triangle_surface(a, b, c)(u, v),
        (*TRIANGLE, *GRID),
    ),
    # ------------------------------------------------------------------ fresnel
    "fresnel.f0_from_conductor": (
        fresnel.f0_from_conductor,
        (np.array(fresnel.CONDUCTORS["Au"][0]), np.array(fresnel.CONDUCTORS["Au"][1])),
    ),
    "fresnel.f0_from_ior": (fresnel.f0_from_ior, (np.array([1.0, 1.33, 1.5, 2.419, 0.5]),)),
    "fresnel.fresnel": (fresnel.fresnel, (COS_THETA, np.array(1.5))),
    "fresnel.fresnel_conductor": (
        fresnel.fresnel_conductor,
        (
            COS_THETA[:, None],
            np.array(fresnel.CONDUCTORS["Cu"][0]),
            np.array(fresnel.CONDUCTORS["Cu"][1]),
        ),
    ),
    "fresnel.fresnel_conductor[polarized]": (
        lambda cos_theta_i, eta, k: fresnel.fresnel_conductor(cos_theta_i, eta, k, polarized=True),
        (
            COS_THETA[:, None],
            np.array(fresnel.CONDUCTORS["Al"][0]),
            np.array(fresnel.CONDUCTORS["Al"][1]),
        ),
    ),
    "fresnel.fresnel_dielectric": (
        fresnel.fresnel_dielectric,
        (COS_THETA, np.array([1.5, 1.0, 1.33, 2.4, 0.7, 1.5, 1.1, 1.5])),
    ),
    "fresnel.fresnel_dielectric[polarized]": (
        lambda cos_theta_i, eta: fresnel.fresnel_dielectric(cos_theta_i, eta, polarized=True),
        (COS_THETA, np.array(1.5)),
    ),
    "fresnel.schlick": (fresnel.schlick, (COS_THETA[:, None], np.array([0.04, 0.5, 0.95]))),
    # ------------------------------------------------------------------ sampling
    "sampling.Distribution2D.sample": (DISTRIBUTION.sample, (U,)),
    "sampling.Distribution2D.pdf": (
        DISTRIBUTION.pdf,
        (np.vstack([U, [[1.2, 0.5], [-0.1, 0.3]]]),),
    ),
    "sampling.Distribution2D.invert": (DISTRIBUTION.invert, (U,)),
    "sampling.square_to_cosine_hemisphere": (sampling.square_to_cosine_hemisphere, (U,)),
    "sampling.square_to_cosine_hemisphere_pdf": (
        sampling.square_to_cosine_hemisphere_pdf,
        (W_BOTH,),
    ),
    "sampling.square_to_spherical_triangle": (
        sampling.square_to_spherical_triangle,
        (U, A, B, C),
    ),
    "sampling.square_to_spherical_triangle_pdf": (
        sampling.square_to_spherical_triangle_pdf,
        (np.vstack([_unit((0.45, 0.4, 0.7)), W_BOTH]), A, B, C),
    ),
    "sampling.square_to_uniform_cone": (sampling.square_to_uniform_cone, (U, np.array(0.6))),
    "sampling.square_to_uniform_cone_pdf": (
        sampling.square_to_uniform_cone_pdf,
        (W_BOTH, np.array(0.6)),
    ),
    "sampling.square_to_uniform_disk_concentric": (
        sampling.square_to_uniform_disk_concentric,
        (U,),
    ),
    "sampling.square_to_uniform_disk_concentric_pdf": (
        sampling.square_to_uniform_disk_concentric_pdf,
        (np.array([[0.1, 0.2], [0.9, 0.5], [-0.3, 0.3]]),),
    ),
    "sampling.square_to_uniform_hemisphere": (sampling.square_to_uniform_hemisphere, (U,)),
    "sampling.square_to_uniform_hemisphere_pdf": (
        sampling.square_to_uniform_hemisphere_pdf,
        (W_BOTH,),
    ),
    "sampling.square_to_uniform_sphere": (sampling.square_to_uniform_sphere, (U,)),
    "sampling.square_to_uniform_sphere_pdf": (sampling.square_to_uniform_sphere_pdf, (W_BOTH,)),
    "sampling.square_to_uniform_triangle": (sampling.square_to_uniform_triangle, (U,)),
    "sampling.square_to_uniform_triangle_pdf": (
        sampling.square_to_uniform_triangle_pdf,
        (np.array([[0.2, 0.3], [0.7, 0.6], [-0.1, 0.5]]),),
    ),
}


def _public_name(case: str) -> str:
    """``module.name`` of a case key (``module.name[variant]`` or ``module.Class.method``)."""
    return ".".join(case.split("[")[0].split(".")[:2])


def _leaves(result) -> list:
    """The arrays of a (possibly nested tuple) result, in order."""
    if isinstance(result, tuple | list):
        return [leaf for item in result for leaf in _leaves(item)]
    return [result]


def test_cases_cover_every_public_function() -> None:
    public = {f"{module}.{name}" for module, mod in MODULES.items() for name in mod.__all__}
    covered = {_public_name(case) for case in CASES}
    assert not EXCLUDED - public, f"stale exclusions: {sorted(EXCLUDED - public)}"
    unknown = {
        name for name in covered if not hasattr(MODULES[name.split(".")[0]], name.split(".")[1])
    }
    assert not unknown, f"cases for names the modules lack: {sorted(unknown)}"
    missing = public - EXCLUDED - covered
    assert not missing, f"public functions without a backend case: {sorted(missing)}"


@pytest.mark.parametrize("case", sorted(CASES))
def test_backends(case: str) -> None:
    function, args = CASES[case]
    assert all(a.dtype == np.float64 for a in args)

    # (a) NumPy float64: the reference
    reference = _leaves(function(*args))
    for leaf in reference:
        assert isinstance(leaf, np.ndarray | np.generic), type(leaf)
        assert leaf.dtype in (np.float64, np.bool_), leaf.dtype
        assert np.all(np.isfinite(leaf)), "the reference must be finite to be compared"

    # (b) NumPy float32: floating results stay float32 and agree with float64 to 64 ulps of
    # float32 (the library's own on-surface tolerance); bool masks are equal
    single = _leaves(function(*(a.astype(np.float32) for a in args)))
    assert len(single) == len(reference)
    for leaf, expected in zip(single, reference, strict=True):
        assert isinstance(leaf, np.ndarray | np.generic), type(leaf)
        assert leaf.dtype == (np.float32 if expected.dtype == np.float64 else expected.dtype)
        assert leaf.shape == expected.shape
        np.testing.assert_allclose(leaf, expected, rtol=FLOAT32_ULPS, atol=FLOAT32_ULPS)

    # (c) torch float64: tensors out, equal to the NumPy float64 result
    torch = pytest.importorskip("torch")
    tensors = _leaves(function(*(torch.from_numpy(a.copy()) for a in args)))
    assert len(tensors) == len(reference)
    for leaf, expected in zip(tensors, reference, strict=True):
        assert isinstance(leaf, torch.Tensor), type(leaf)
        assert leaf.dtype == (torch.float64 if expected.dtype == np.float64 else torch.bool)
        np.testing.assert_allclose(leaf.detach().numpy(), expected, rtol=1e-10, atol=1e-10)
