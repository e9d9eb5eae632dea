"""Warps, their densities, Distribution2D and Sobol points (brdfkit.sampling)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate
from scipy.stats import binomtest

from brdfkit import sampling
from brdfkit.checks import assert_chi2, assert_chi2_planar
from brdfkit.sampling import (
    SOBOL_DIMENSIONS,
    Distribution2D,
    hemisphere_pairs,
    laine_karras,
    nested_scramble,
    query_seeds,
    reverse_bits,
    scramble_keys,
    scrambled_sobol,
    sobol,
    sobol_integers,
    square_to_cosine_hemisphere,
    square_to_cosine_hemisphere_pdf,
    square_to_spherical_triangle,
    square_to_spherical_triangle_pdf,
    square_to_uniform_cone,
    square_to_uniform_cone_pdf,
    square_to_uniform_disk_concentric,
    square_to_uniform_disk_concentric_pdf,
    square_to_uniform_hemisphere,
    square_to_uniform_hemisphere_pdf,
    square_to_uniform_sphere,
    square_to_uniform_sphere_pdf,
    square_to_uniform_triangle,
    square_to_uniform_triangle_pdf,
)

RNG = np.random.default_rng(20240611)
U = RNG.random((64, 2))

# A spherical triangle of about 0.86 sr, given with unnormalised vertices.
TRI_A, TRI_B, TRI_C = np.array([0, 0, 1.0]), np.array([1, 0, 0.5]), np.array([0, 1, 0.3])

# (name, sampler, pdf) of every directional warp, with the parameters fixed.
DIRECTIONAL = {
    "uniform_sphere": (square_to_uniform_sphere, square_to_uniform_sphere_pdf),
    "uniform_hemisphere": (square_to_uniform_hemisphere, square_to_uniform_hemisphere_pdf),
    "cosine_hemisphere": (square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf),
    "cone_narrow": (
        lambda u: square_to_uniform_cone(u, 0.9),
        lambda v: square_to_uniform_cone_pdf(v, 0.9),
    ),
    "cone_wide": (
        lambda u: square_to_uniform_cone(u, -0.45),
        lambda v: square_to_uniform_cone_pdf(v, -0.45),
    ),
    "spherical_triangle": (
        lambda u: square_to_spherical_triangle(u, TRI_A, TRI_B, TRI_C),
        lambda v: square_to_spherical_triangle_pdf(v, TRI_A, TRI_B, TRI_C),
    ),
}


def _direction(z: float, phi: float) -> np.ndarray:
    r = math.sqrt(max(0.0, 1 - z * z))
    return np.array([r * math.cos(phi), r * math.sin(phi), z])


# --------------------------------------------------------------------------- χ² of every warp
@pytest.mark.parametrize("name", list(DIRECTIONAL))
def test_directional_warps_pass_chi2(name):
    sample, pdf = DIRECTIONAL[name]
    # A narrow cone needs rows uniform in θ to be resolved; the others use equal-area rows.
    binning = "theta" if name == "cone_narrow" else "cos"
    assert_chi2(sample, pdf, binning=binning, test_count=len(DIRECTIONAL))


def test_hemisphere_warps_stay_above_the_surface_and_are_unit():
    u = RNG.random((10_000, 2))
    for warp in (square_to_uniform_hemisphere, square_to_cosine_hemisphere):
        v = warp(u)
        assert np.all(v[:, 2] >= 0)
        np.testing.assert_allclose(np.linalg.norm(v, axis=-1), 1, atol=1e-12)


def test_cone_samples_stay_inside_the_cone():
    cos_cutoff = 0.6
    v = square_to_uniform_cone(RNG.random((10_000, 2)), cos_cutoff)
    assert np.all(v[:, 2] >= cos_cutoff - 1e-12)
    np.testing.assert_allclose(np.linalg.norm(v, axis=-1), 1, atol=1e-12)


def test_concentric_disk_passes_chi2():
    assert_chi2_planar(
        square_to_uniform_disk_concentric,
        square_to_uniform_disk_concentric_pdf,
        bounds=((-1.0, 1.0), (-1.0, 1.0)),
        bins=(16, 16),
    )


def test_uniform_triangle_passes_chi2():
    assert_chi2_planar(square_to_uniform_triangle, square_to_uniform_triangle_pdf, bins=(16, 16))


# --------------------------------------------------------------------------- normalisation
@pytest.mark.parametrize(
    ("pdf", "breaks"),
    [
        (square_to_uniform_sphere_pdf, []),
        (square_to_uniform_hemisphere_pdf, [0.0]),
        (square_to_cosine_hemisphere_pdf, [0.0]),
        (lambda v: square_to_uniform_cone_pdf(v, 0.9), [0.9]),
        (lambda v: square_to_uniform_cone_pdf(v, -0.45), [-0.45]),
    ],
)
def test_directional_pdfs_integrate_to_one(pdf, breaks):
    # ∫∫ p dω with dω = dz dφ, by adaptive quadrature split at the pdf's discontinuities in z.
    value, _ = integrate.nquad(
        lambda phi, z: float(pdf(_direction(z, phi))),
        [[0, 2 * math.pi], [-1, 1]],
        opts=[{}, {"points": breaks}],
    )
    assert value == pytest.approx(1.0, abs=1e-8)


def test_disk_and_triangle_pdfs_integrate_to_one():
    disk, _ = integrate.nquad(
        lambda r, phi: (
            float(
                square_to_uniform_disk_concentric_pdf(
                    np.array([r * math.cos(phi), r * math.sin(phi)])
                )
            )
            * r
        ),
        [[0, 1.5], [0, 2 * math.pi]],
        opts=[{"points": [1.0]}, {}],
    )
    assert disk == pytest.approx(1.0, abs=1e-8)
    triangle, _ = integrate.nquad(
        lambda b2, b1: float(square_to_uniform_triangle_pdf(np.array([b1, b2]))),
        [lambda b1: [0, 1 - b1], [0, 1]],
    )
    assert triangle == pytest.approx(1.0, abs=1e-8)


def test_spherical_triangle_pdf_is_one_over_the_solid_angle():
    a, b, c = (v / np.linalg.norm(v) for v in (TRI_A, TRI_B, TRI_C))
    # Van Oosterom & Strackee (1983): tan(Ω/2) = |a·(b×c)| / (1 + a·b + b·c + c·a).
    omega = 2 * math.atan2(abs(a @ np.cross(b, c)), 1 + a @ b + b @ c + c @ a)
    centroid = (a + b + c) / np.linalg.norm(a + b + c)
    assert square_to_spherical_triangle_pdf(centroid, TRI_A, TRI_B, TRI_C) == pytest.approx(
        1 / omega, rel=1e-12
    )
    # The vertex order (orientation) does not matter.
    assert square_to_spherical_triangle_pdf(centroid, TRI_A, TRI_C, TRI_B) == pytest.approx(
        1 / omega, rel=1e-12
    )
    # Its support has solid angle Ω: the fraction of uniform sphere directions inside is Ω/4π.
    n = 200_000
    inside = (
        square_to_spherical_triangle_pdf(
            square_to_uniform_sphere(RNG.random((n, 2))), TRI_A, TRI_B, TRI_C
        )
        > 0
    )
    assert binomtest(int(inside.sum()), n, omega / (4 * math.pi)).pvalue > 1e-3
    samples = square_to_spherical_triangle(RNG.random((n, 2)), TRI_A, TRI_B, TRI_C)
    assert np.all(square_to_spherical_triangle_pdf(samples, TRI_A, TRI_B, TRI_C) > 0)


def test_spherical_triangle_vertices_are_reached():
    corners = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    v = square_to_spherical_triangle(corners, TRI_A, TRI_B, TRI_C)
    # u₀ = 0 collapses the triangle onto the edge ab, u₁ = 0 picks b; u₀ = 1, u₁ = 1 reaches c.
    np.testing.assert_allclose(v[0], TRI_B / np.linalg.norm(TRI_B), atol=1e-12)
    np.testing.assert_allclose(v[2], TRI_C / np.linalg.norm(TRI_C), atol=1e-7)


# --------------------------------------------------------------------------- concentric map
def test_concentric_disk_is_area_preserving():
    # |det ∂p/∂u| = π everywhere (the disk's area over the square's), away from the diagonals
    # where the map is continuous but not differentiable.
    u = RNG.uniform(0.01, 0.99, (2000, 2))
    u = u[np.abs(np.abs(2 * u[:, 0] - 1) - np.abs(2 * u[:, 1] - 1)) > 1e-3]
    h = 1e-6
    du = (
        square_to_uniform_disk_concentric(u + np.array([h, 0]))
        - square_to_uniform_disk_concentric(u - [h, 0])
    ) / (2 * h)
    dv = (
        square_to_uniform_disk_concentric(u + np.array([0, h]))
        - square_to_uniform_disk_concentric(u - [0, h])
    ) / (2 * h)
    det = du[:, 0] * dv[:, 1] - du[:, 1] * dv[:, 0]
    np.testing.assert_allclose(np.abs(det), math.pi, rtol=1e-6)


def test_concentric_disk_maps_boundary_to_circle_and_centre_to_origin():
    t = np.linspace(0, 1, 101)
    edges = np.concatenate(
        [
            np.stack([t, 0 * t], 1),
            np.stack([t, 1 + 0 * t], 1),
            np.stack([0 * t, t], 1),
            np.stack([1 + 0 * t, t], 1),
        ]
    )
    np.testing.assert_allclose(
        np.linalg.norm(square_to_uniform_disk_concentric(edges), axis=-1), 1, atol=1e-12
    )
    np.testing.assert_array_equal(square_to_uniform_disk_concentric(np.array([0.5, 0.5])), [0, 0])


# --------------------------------------------------------------------------- Mitsuba oracle
@pytest.mark.oracle
@pytest.mark.parametrize(
    ("name", "args"),
    [
        ("square_to_uniform_sphere", ()),
        ("square_to_uniform_hemisphere", ()),
        ("square_to_cosine_hemisphere", ()),
        ("square_to_uniform_disk_concentric", ()),
        ("square_to_uniform_triangle", ()),
        ("square_to_uniform_cone", (0.3,)),
        ("square_to_uniform_cone", (-0.7,)),
    ],
)
def test_warps_match_mitsuba(name, args):
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    ours = getattr(sampling, name)(U, *args)
    reference = np.array([list(getattr(mi.warp, name)(mi.Point2f(*u), *args)) for u in U])
    # Mitsuba's scalar_rgb computes in float32, whose rounding of 1 − r² is amplified by the
    # square root near the horizon: compare the squared components (and the signs).
    np.testing.assert_allclose(ours**2, reference**2, atol=2e-6)
    clear = np.abs(reference) > 1e-5
    np.testing.assert_array_equal(np.sign(ours[clear]), np.sign(reference[clear]))
    pdf = getattr(sampling, f"{name}_pdf")(ours, *args)
    point = mi.Vector3f if ours.shape[-1] == 3 else mi.Point2f
    reference_pdf = [getattr(mi.warp, f"{name}_pdf")(point(*v), *args) for v in ours]
    np.testing.assert_allclose(pdf, reference_pdf, rtol=2e-6)


# --------------------------------------------------------------------------- backends
# Warps of (u, convert), ``convert`` bringing other array arguments to the backend of ``u``
# (float64 vertices would promote float32 directions, as every brdfkit function does).
WARPS = {
    "uniform_sphere": lambda u, convert: square_to_uniform_sphere(u),
    "uniform_hemisphere": lambda u, convert: square_to_uniform_hemisphere(u),
    "cosine_hemisphere": lambda u, convert: square_to_cosine_hemisphere(u),
    "disk": lambda u, convert: square_to_uniform_disk_concentric(u),
    "triangle": lambda u, convert: square_to_uniform_triangle(u),
    "cone": lambda u, convert: square_to_uniform_cone(u, 0.25),
    "spherical_triangle": lambda u, convert: square_to_spherical_triangle(
        u, convert(TRI_A), convert(TRI_B), convert(TRI_C)
    ),
}


@pytest.mark.parametrize("name", list(WARPS))
def test_warps_on_every_backend(backend, name):
    u = backend(U)
    out = WARPS[name](u, backend)
    assert type(out) is type(u)
    assert out.dtype == u.dtype
    tol = 1e-5 if "32" in str(u.dtype) else 1e-12
    np.testing.assert_allclose(np.asarray(out), WARPS[name](U, np.asarray), atol=tol)


def test_torch_float32_and_gradients():
    torch = pytest.importorskip("torch")
    u = torch.tensor(U, dtype=torch.float32, requires_grad=True)
    for warp, pdf in (
        (square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf),
        (square_to_uniform_sphere, square_to_uniform_sphere_pdf),
        (lambda x: square_to_uniform_cone(x, 0.5), lambda v: square_to_uniform_cone_pdf(v, 0.5)),
    ):
        v = warp(u)
        assert isinstance(v, torch.Tensor) and v.dtype == torch.float32
        assert pdf(v).dtype == torch.float32
        (grad,) = torch.autograd.grad(v[..., 2].sum(), u)
        assert torch.all(torch.isfinite(grad))
    # The cone's half-angle is differentiable too (a spherical light's apparent size).
    cos_cutoff = torch.tensor(0.5, dtype=torch.float64, requires_grad=True)
    z = square_to_uniform_cone(torch.tensor(U), cos_cutoff)[..., 2]
    (grad,) = torch.autograd.grad(z.sum(), cos_cutoff)
    # z = 1 − (1 − cos θmax)|p|², so ∂z/∂cos θmax = |p|².
    r2 = (square_to_uniform_disk_concentric(U) ** 2).sum(-1)
    assert float(grad) == pytest.approx(r2.sum(), rel=1e-12)


def test_numpy_variates_follow_the_backend_of_the_other_arguments():
    # A NumPy u (or v) given with torch vertices or cutoff computes as if it had been made in
    # torch with their dtype, and the gradient reaches them.
    torch = pytest.importorskip("torch")
    v = square_to_uniform_hemisphere(U)
    for dtype in (torch.float32, torch.float64):
        tri = [torch.tensor(x, dtype=dtype, requires_grad=True) for x in (TRI_A, TRI_B, TRI_C)]
        cos_cutoff = torch.tensor(0.25, dtype=dtype, requires_grad=True)
        u_t, v_t = torch.tensor(U, dtype=dtype), torch.tensor(v, dtype=dtype)
        for name, f, x, x_t, args in (
            ("cone", square_to_uniform_cone, U, u_t, [cos_cutoff]),
            ("cone_pdf", square_to_uniform_cone_pdf, v, v_t, [cos_cutoff]),
            ("triangle", square_to_spherical_triangle, U, u_t, tri),
            ("triangle_pdf", square_to_spherical_triangle_pdf, v, v_t, tri),
        ):
            mixed = f(x, *args)
            assert isinstance(mixed, torch.Tensor) and mixed.dtype == dtype, name
            assert torch.equal(mixed, f(x_t, *args)), name
            grads = torch.autograd.grad(mixed.sum(), args, allow_unused=True)
            assert any(g is not None and torch.any(g != 0) for g in grads), name


# --------------------------------------------------------------------------- bad input
def test_bad_input_is_rejected():
    with pytest.raises(ValueError, match=r"u must have a last axis of length 2"):
        square_to_cosine_hemisphere(np.zeros((4, 3)))
    with pytest.raises(ValueError, match=r"u must be in \[0\.0, 1\.0\]; got 1\.5"):
        square_to_uniform_sphere(np.array([0.5, 1.5]))
    with pytest.raises(ValueError, match=r"u must be finite"):
        square_to_uniform_disk_concentric(np.array([np.nan, 0.5]))
    for bad in (1.5, -1.01, 1.0, np.nan):
        with pytest.raises(
            ValueError, match=r"cos_cutoff must be (finite and )?in \[-1\.0, 1\.0\)"
        ):
            square_to_uniform_cone(U, bad)
        with pytest.raises(ValueError, match=r"cos_cutoff"):
            square_to_uniform_cone_pdf(np.array([0, 0, 1.0]), bad)
    with pytest.raises(ValueError, match=r"v must have a last axis of length 3"):
        square_to_uniform_sphere_pdf(np.zeros((2, 2)))
    with pytest.raises(ValueError, match=r"p must have a last axis of length 2"):
        square_to_uniform_disk_concentric_pdf(np.zeros(3))
    with pytest.raises(ValueError, match=r"positive solid angle"):
        square_to_spherical_triangle(U, TRI_A, TRI_A, TRI_C)


# --------------------------------------------------------------------------- Distribution2D
def _image(rng: np.random.Generator) -> np.ndarray:
    image = rng.random((6, 9)) ** 2
    image[2] = 0.0  # an empty row
    image[:, 4] = 0.0  # an empty column
    return image


def test_distribution2d_pdf_is_the_normalised_image():
    image = _image(RNG)
    dist = Distribution2D(image)
    rows, cols = np.meshgrid(np.arange(6), np.arange(9), indexing="ij")
    centres = np.stack([(cols + 0.5) / 9, (rows + 0.5) / 6], axis=-1)
    np.testing.assert_allclose(dist.pdf(centres), image / image.mean(), rtol=1e-14)
    assert dist.integral == pytest.approx(image.mean(), rel=1e-14)
    assert dist.pdf(np.array([1.0, 0.5])) == 0 and dist.pdf(np.array([0.5, -0.1])) == 0


def test_distribution2d_samples_follow_the_image():
    image = _image(RNG)
    dist = Distribution2D(image)
    # Cells aligned with the texels, then 3×3 cells per texel (uniform inside a texel).
    assert_chi2_planar(lambda u: dist.sample(u)[0], dist.pdf, bins=(9, 6), test_count=2)
    assert_chi2_planar(lambda u: dist.sample(u)[0], dist.pdf, bins=(27, 18), test_count=2)
    points, pdf = dist.sample(RNG.random((100_000, 2)))
    assert np.all(pdf > 0) and np.all((points >= 0) & (points < 1))
    np.testing.assert_array_equal(pdf, dist.pdf(points))


def test_distribution2d_invert_is_the_exact_inverse():
    dist = Distribution2D(_image(RNG))
    u = RNG.random((100_000, 2))
    points, _ = dist.sample(u)
    np.testing.assert_allclose(dist.invert(points), u, atol=1e-12)
    # And the other way round, for points where the density is positive.
    points = points[:1000]
    np.testing.assert_allclose(dist.sample(dist.invert(points))[0], points, atol=1e-12)


def test_distribution2d_torch_float32():
    torch = pytest.importorskip("torch")
    dist = Distribution2D(torch.tensor(_image(RNG)))
    u = torch.tensor(U, dtype=torch.float32, requires_grad=True)
    points, pdf = dist.sample(u)
    assert points.dtype == torch.float32 and pdf.dtype == torch.float32
    assert points.shape == (64, 2) and pdf.shape == (64,)
    np.testing.assert_allclose(points.detach().numpy(), dist.sample(U)[0], atol=1e-6)
    # Inside a texel x is affine in u₀ with slope 1 / (W p_ij) along the row: a finite gradient.
    (grad,) = torch.autograd.grad(points[:, 0].sum(), u)
    assert torch.all(torch.isfinite(grad)) and torch.all(grad[:, 0] > 0)
    back = dist.invert(points.detach())
    assert back.dtype == torch.float32
    np.testing.assert_allclose(back.numpy(), U, atol=1e-5)  # float32 points, density ≤ 10
    assert dist.pdf(points.detach()).dtype == torch.float32


def test_distribution2d_batch_shape_and_single_texel():
    dist = Distribution2D(np.ones((1, 1)))
    u = RNG.random((3, 4, 2))
    points, pdf = dist.sample(u)
    np.testing.assert_allclose(points, u, atol=1e-15)
    np.testing.assert_array_equal(pdf, np.ones((3, 4)))


def test_distribution2d_rejects_bad_images():
    with pytest.raises(ValueError, match=r"image must be in \[0\.0, inf\]; got -1"):
        Distribution2D(np.array([[1.0, -1.0]]))
    with pytest.raises(ValueError, match=r"image must be finite"):
        Distribution2D(np.array([[1.0, np.inf]]))
    with pytest.raises(ValueError, match=r"all zeros"):
        Distribution2D(np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"2D array"):
        Distribution2D(np.ones(5))
    with pytest.raises(ValueError, match=r"points must be in \[0\.0, 1\.0\]"):
        Distribution2D(np.ones((2, 2))).invert(np.array([1.2, 0.5]))


# --------------------------------------------------------------------------- Sobol
def test_sobol_points_are_stratified():
    n, dim = 256, 5
    for scramble in (False, True):
        points = sobol(n, dim, seed=3, scramble=scramble)
        assert points.shape == (n, dim) and points.dtype == np.float64
        assert np.all((points >= 0) & (points < 1))
        # A (0, m, 1)-net in each coordinate: one point in each interval [k/n, (k+1)/n).
        for d in range(dim):
            np.testing.assert_array_equal(np.sort(np.floor(points[:, d] * n)), np.arange(n))
    np.testing.assert_array_equal(sobol(4, 2, scramble=False)[0], [0, 0])
    assert not np.array_equal(sobol(8, 2, seed=1), sobol(8, 2, seed=2))
    np.testing.assert_array_equal(sobol(8, 2, seed=1), sobol(8, 2, seed=1))


def test_sobol_rejects_bad_arguments():
    with pytest.raises(ValueError, match=r"n must be a positive integer; got 0"):
        sobol(0, 2)
    with pytest.raises(ValueError, match=r"dim must be an integer in \[1, 21201\]; got 0"):
        sobol(4, 0)


def test_sobol_integers_are_scipys_sequence():
    from scipy.stats import qmc

    for m in (1, 4, 9):
        ours = sobol_integers(0, 2**m, SOBOL_DIMENSIONS)
        theirs = qmc.Sobol(SOBOL_DIMENSIONS, scramble=False, bits=32).random(2**m) * 2.0**32
        # SciPy runs in Gray-code order: the same set of points
        np.testing.assert_array_equal(
            np.unique(ours, axis=0), np.unique(theirs.astype(np.uint32), axis=0)
        )
    with pytest.raises(ValueError, match="dim"):
        sobol_integers(0, 4, SOBOL_DIMENSIONS + 1)


def _is_net(points: np.ndarray) -> bool:
    """One point in each interval of 1/n per coordinate, and in each of the 2^m elementary
    intervals of 2^a × 2^(m−a) of the first two coordinates (Sobol's first two dimensions
    form a (0, 2)-sequence)."""
    n = points.shape[0]
    m = n.bit_length() - 1
    cells = np.floor(points * n).astype(int)
    if not all(np.array_equal(np.sort(cells[:, d]), np.arange(n)) for d in range(points.shape[1])):
        return False
    for a in range(m + 1):
        x = np.floor(points[:, 0] * 2**a).astype(int)
        y = np.floor(points[:, 1] * 2 ** (m - a)).astype(int)
        if np.unique(x * 2 ** (m - a) + y).size != n:
            return False
    return True


def test_scrambled_sobol_blocks_and_their_unions_are_nets_per_query():
    keys = scramble_keys(query_seeds(7, 6), 0, 3)
    first = scrambled_sobol(0, 16, keys)
    second = scrambled_sobol(16, 16, keys)
    assert first.shape == (6, 16, 3) and np.all((first >= 0) & (first < 1))
    for q in range(6):
        assert _is_net(first[q]) and _is_net(second[q])
        assert _is_net(np.concatenate([first[q], second[q]]))
    np.testing.assert_array_equal(np.concatenate([first, second], axis=1),
                                  scrambled_sobol(0, 32, keys))  # fmt: skip
    assert not np.array_equal(first[0], first[1])  # each query its own scramble
    # the streams of one seed are independent draws, the seeds depend on the index alone
    assert not np.array_equal(scramble_keys(query_seeds(7, 1), 1, 3), keys[:1])
    np.testing.assert_array_equal(query_seeds(7, 3, first=2), query_seeds(7, 5)[2:])


def test_scrambled_sobol_points_are_uniform():
    """Each point, over random keys, is uniform (the estimates unbiased): the mean of a
    smooth function and the occupancy of fine cells match U[0, 1) within sampling error."""
    keys = scramble_keys(query_seeds(11, 20_000), 0, 2)
    u = scrambled_sobol(5, 3, keys)  # points 5, 6, 7 of each query's sequence
    for k in range(3):
        for d in range(2):
            x = u[:, k, d]
            assert abs(np.mean(x) - 0.5) < 4 * np.sqrt(1 / 12 / x.size)
            assert abs(np.mean(np.cos(2 * np.pi * x))) < 4 * np.sqrt(0.5 / x.size)
            counts = np.bincount(np.floor(x * 64).astype(int), minlength=64)
            chi2 = np.sum((counts - x.size / 64) ** 2 / (x.size / 64))
            assert chi2 < 120, chi2  # 63 degrees of freedom: p < 1e-5


def test_nested_scramble_in_numba_equals_numpy():
    numba = pytest.importorskip("numba")
    reverse, hash_ = numba.njit(reverse_bits), numba.njit(laine_karras)
    scramble = numba.njit(lambda x, seed: reverse(hash_(reverse(x), seed)))
    rng = np.random.default_rng(3)
    x, seed = (rng.integers(0, 2**32, 200, dtype=np.uint32) for _ in range(2))
    expected = nested_scramble(x, seed)
    found = [scramble(np.uint64(a), np.uint64(b)) for a, b in zip(x, seed, strict=True)]
    np.testing.assert_array_equal(np.array(found, np.uint64), expected.astype(np.uint64))


def test_hemisphere_pairs_are_reproducible_unit_upper_directions():
    wi, wo = hemisphere_pairs(1000, seed=4)
    assert wi.shape == wo.shape == (1000, 3)
    for v in (wi, wo):
        np.testing.assert_allclose(np.linalg.norm(v, axis=-1), 1.0, atol=1e-12)
        assert np.all(v[:, 2] >= 0)
    assert not np.allclose(wi, wo)
    again = hemisphere_pairs(1000, seed=4)
    np.testing.assert_array_equal(again[0], wi)
    np.testing.assert_array_equal(again[1], wo)
    # Uniform in solid angle: the mean of cos θ over the hemisphere is 1/2.
    assert abs(float(np.mean(hemisphere_pairs(100_000)[0][:, 2])) - 0.5) < 0.005
