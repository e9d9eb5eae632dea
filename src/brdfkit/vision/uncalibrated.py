r"""Uncalibrated photometric stereo: lights and normals from the images alone.

Lambertian images of ``P`` pixels under ``N`` distant lights form the rank-3 matrix
``M = L B`` (``L`` the ``(N, 3)`` lights times their intensities, ``B`` the ``(3, P)``
pseudo-normals ``b = rho n``). The pipeline:

1. **Factorisation** (Hayakawa 1994): the SVD ``M = U S V^T`` of the pixels that no light
   leaves in shadow, truncated to rank 3, gives ``L = U_3 S_3^{1/2} A^{-1}`` and
   ``B = A S_3^{1/2} V_3^T`` up to an unknown invertible ``A`` (9 unknowns). Where those
   pixels are under half the mask (lights over a wide cone, cast shadows) they lie in
   scattered patches with too few neighbours for step 2, and the factor comes instead from
   every pixel's unshadowed observations (:func:`robust_factorize`, below).
2. **Integrability** (Yuille & Snow 1997; Belhumeur, Kriegman & Yuille 1999): a surface
   ``z(x, y)`` has ``b_1 / b_3 = -z_x``, ``b_2 / b_3 = -z_y`` and so
   ``d_y(b_1 / b_3) = d_x(b_2 / b_3)``, i.e. ``b_3 d_y b_1 - b_1 d_y b_3 = b_3 d_x b_2 -
   b_2 d_x b_3``. With ``b = A e`` (``e`` the columns of the factor) and the identity
   ``(a.c)(b.d) - (a.d)(b.c) = (a x b).(c x d)`` this reads, at every pixel,
   ``(e x e_y) . c_1 - (e x e_x) . c_2 = 0`` with ``c_1 = a_3 x a_1``, ``c_2 = a_3 x a_2``
   (``a_i`` the rows of ``A``): a homogeneous linear system in 6 unknowns. Its solution
   fixes ``A`` up to the generalised bas-relief (GBR) transformation.
3. **The GBR ambiguity** (Belhumeur, Kriegman & Yuille 1999): the surfaces
   ``lambda z + mu x + nu y`` give the same images, with pseudo-normals ``b -> K b`` and lights
   ``l -> K^{-T} l``,

   ``K = [[lambda, 0, -mu], [0, lambda, -nu], [0, 0, 1]]``.

   Its three parameters are fixed by a cue: **local diffuse reflectance maxima** (Papadhimitri
   & Favaro): where the (locally uniform-albedo) shading of image ``k`` peaks, the normal points
   at the light, ``K b ∥ K^{-T} l_k``, i.e. ``Q b ∥ l_k`` with ``Q = K^T K`` — linear in the
   four entries of ``Q = [[q_1, 0, q_2], [0, q_1, q_3], [q_2, q_3, q_4]]``, solved in closed
   form; **equal light intensities** (Hayakawa 1994, §4): ``|K^{-T} l_k|`` the same for every
   light is linear in ``K^{-1} K^{-T}``, closed form again, whatever the albedo
   (:func:`resolve_gbr_equal_intensity`); or **minimum entropy of the albedo distribution**
   (Alldrin, Mallick & Kriegman 2007): the GBR that makes the albedo histogram most
   concentrated. The sign of ``lambda`` (the
   convex/concave ambiguity, which no image cue resolves) is chosen so that the normals next
   to the mask's occluding contour point outwards.

4. **Specular highlights** (Drbohlav & Šára 2002; Georghiades 2003), the cue for glossy
   objects, which needs no integrability. The rank-3 factor is fitted robustly first
   (:func:`robust_factorize`: alternating least squares on the observations that shadows and
   highlights leave alone; a specular lobe only adds to the Lambertian part, so outliers are
   one-sided). With lights of equal intensity (DiLiGenT's images are divided by theirs)
   ``|A^{-T} l̂_k| = 1`` is linear in ``C = A^{-1} A^{-T}`` (Hayakawa 1994), which fixes ``A``
   up to a rotation ``R``. Where image ``k``'s specular lobe peaks, the normal is the half
   vector of the light and the orthographic view ``v = (0, 0, 1)``:

   ``A b / |A b| = h_k = (l_k + v) / |l_k + v|``, ``l_k = A^{-T} l̂_k / |A^{-T} l̂_k|``,

   which a rotation about ``v`` leaves unchanged: the peaks fix the two tilt angles of ``R``
   (robust least squares over dozens of peaks, one per image). The rotation about the view,
   and the mirror image that explains the images and the peaks equally well, follow from
   integrability: turned about the view, or mirrored, a curved surface's normals are no
   longer integrable (:func:`integrable_view_rotation`, over every pixel). The occluding
   contour, where the normals point out of the silhouette, only tells the convex reading from
   the depth-reversed one (a half turn, as integrable): the factor's normals at the rim itself
   are the least reliable (a few grazing observations each; on a sphere of the Cornell
   acrylic, whose rim departs from Lambert's law, they are turned 12° from the rest).
   ``"auto"`` (the default) takes this cue where at least 3 images show a highlight and the
   fitted lights put the peaks within :data:`SPECULAR_CONSISTENCY` of their half vectors,
   else the entropy cue.

Finally the recovered lights (direction and relative intensity) go to a calibrated solver of
:mod:`brdfkit.vision.photometric_stereo`, which estimates the normals at every pixel, shadowed
ones included.

Frame: x right, y up, z towards the camera (see :mod:`brdfkit.vision`).

Measured on the real psm gray sphere (12 images, 8-bit; lights compared with the chrome-sphere
calibration; ``tests/vision/test_uncalibrated.py``): with the entropy cue at full resolution
the lights are 4.25° off (median; 9.1° at most) and the least-squares normals 9.07° mean
against 6.39° with the calibrated lights; the diffuse-maxima cue gives 5.67° (the shading
peaks of this real sphere lie 2-24° from the calibrated lights: its reflectance departs from
Lambert's by about 4 % rms, and 8-bit plateaus move the maxima). The fragile step is
integrability: on these images the smallest singular values of its system are within a factor
1.2-2.5 of each other (160 on a render), and the result depends on the smoothing ``sigma``,
chosen (1 px, about 1 % of the sphere's radius) on this very sphere: 0, 0.5, 1.5, 2, 3 and
4 px give lights 69°, 79°, 9.5°, 11.7°, 12.9° and 13.3° off; at half resolution the same
smoothing on the object (0.5 px) gives 4.9°, and 1 px there 11.9°. Even the best GBR within
the integrable family found (fitted to the calibrated lights, an oracle) is 3.5-25° off
depending on these choices, while the rank-3 factorisation itself admits lights within 1.4°
(the best general linear map): the factorisation is sound, integrability on real 8-bit data is
not robust.

Measured on the DiLiGenT-layout renders of ``benchmarks/bench_uncalibrated.py`` (real DiLiGenT
normals of bear, cat and pot1, every 8th pixel, 96 lights; median light error, mean over the
objects): the specular cue gives ggx 0.05 0.28°, ggx 0.1 1.35°, ggx 0.3 3.17°, the Cornell
acryl_blue, krylon_blue and garnet_red paints 3.0°, 2.7° and 5.6°, the RGL felt 2.3°, the
cayman car paint 20°; shared bivariate under these lights comes within 2.1° of itself under
the true ones but for garnet_red on cat (4.3°) and the car paint on bear (6°), and is better
on the acrylic and krylon paints. On a sphere of the Cornell acrylic (40 px radius; tested)
the lights come out 3.2° off, what the metric of equal intensities leaves; turned by the rim's
normals instead they were 6.7° off. The specular cue refuses cat under ggx 0.05 and
acryl_blue (its factor admits no equal intensities at 694 pixels). Its limits: lights of
equal (or known) intensity, a curved surface (a plane's normals are integrable at every turn)
with a visible occluding contour, and peaks where the lobe peaks at the half vector (a broad
lobe's peak shifts towards the light, hence ggx 0.3's 3°). Under
these wide lights 5-8 % of the pixels are lit and unsaturated in every image, so the GBR cues
integrate the robust factor: on the matte bear and cat the lights come out 1.4° and 3.0° off
(entropy), 1.4° and 3.1° (equal intensities), 7.6° and 5.0° (diffuse maxima); on the
glossy materials equal intensities give 1.1-11° and the entropy of the albedo, which the
highlights' residue spreads, 1.9-21° (equal intensities better on 13 of 16). On pot1
integrability fails at this resolution (its best GBR, fitted to the true lights, is 20° off
at every 4th pixel too): entropy returns lights 140° off and equal intensities refuses (the
lights it finds spread by 48 %); at every 2nd pixel the matte pot1 gives 7.3° (entropy) and
7.8° (equal intensities), bear 1.2° and 1.1°, cat 1.8° and 1.8°. On the psm photographs
(lights of unequal intensity) ``"auto"`` finds no consistent highlights and takes the
entropy cue.

References
----------
.. [1] H. Hayakawa, "Photometric stereo under a light source with arbitrary motion", JOSA A
   11(11), 3079-3089, 1994.
.. [2] A. Yuille, D. Snow, "Shape and albedo from multiple images using integrability",
   CVPR 1997.
.. [3] P. N. Belhumeur, D. J. Kriegman, A. L. Yuille, "The bas-relief ambiguity", IJCV 35(1),
   33-44, 1999.
.. [4] T. Papadhimitri, P. Favaro, "A closed-form, consistent and robust solution to
   uncalibrated photometric stereo via local diffuse reflectance maxima", IJCV 107(2),
   139-154, 2014 (first as P. Favaro, T. Papadhimitri, "A closed-form solution to uncalibrated
   photometric stereo via diffuse maxima", CVPR 2012).
.. [5] N. G. Alldrin, S. P. Mallick, D. J. Kriegman, "Resolving the generalized bas-relief
   ambiguity by entropy minimization", CVPR 2007.
.. [6] O. Drbohlav, R. Šára, "Specularities reduce ambiguity of uncalibrated photometric
   stereo", ECCV 2002, 46-60.
.. [7] A. S. Georghiades, "Incorporating the Torrance and Sparrow model of reflectance in
   uncalibrated photometric stereo", ICCV 2003, 816-823.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from brdfkit.errors import ParameterError
from brdfkit.geometry import half_vector
from brdfkit.vision import photometric_stereo
from brdfkit.vision.photometric_stereo import PhotometricStereoResult, _gray, _prepare

Cue = Literal["auto", "specular", "equal_intensity", "diffuse_maxima", "entropy"]
CUES: tuple[str, ...] = ("auto", "specular", "equal_intensity", "diffuse_maxima", "entropy")
"""The GBR cues (the ``--gbr-cue`` choices of ``brdfkit ps --uncalibrated``)."""

LIT_EVERYWHERE_SHARE = 0.5
"""The GBR cues factorise the pixels that every light reaches (:func:`factorize`) when they
are at least this share of the mask; otherwise (lights over a wide cone, cast shadows: 4 % of
the DiLiGenT bear under its 96 lights, in scattered patches that leave the integrability
derivatives no neighbours) every pixel with enough unshadowed observations
(:func:`robust_factorize`)."""

EQUAL_INTENSITY_SPREAD = 0.2
"""The ``"equal_intensity"`` cue refuses when the intensities its GBR leaves spread by more
than this (1.4826 median absolute deviation over the median). On the renders of
``benchmarks/bench_uncalibrated.py`` they spread by 0.6-7 % where integrability holds (bear,
cat) and by 46-51 % where it fails (pot1, whose lights come out 65-76° off)."""

SPECULAR_CONSISTENCY = 20.0
"""Degrees: the ``"auto"`` cue takes the specular cue's lights when the median angle between
its peaks' normals and their half vectors is at most this. On the glossy renders of
``benchmarks/bench_uncalibrated.py`` it is 1.8-16° where the lights come out within 10°, and
20-29° on the car paint (cayman), whose lights come out 12-31° off."""


@dataclass(frozen=True)
class UncalibratedResult:
    """Output of :func:`uncalibrated`.

    Attributes
    ----------
    light_directions : (N, 3) unit directions towards the lights (x right, y up, z to camera).
    light_intensities : (N,) relative intensities, median 1 (the overall scale is unknowable).
    result : the calibrated solve with those lights (normals, albedo, mask).
    gbr : ``(mu, nu, lambda)`` of the GBR transformation the cue chose, applied after the
        integrability step; ``None`` for the specular cue, which resolves the whole linear
        ambiguity without integrability.
    cue : the cue that resolved the ambiguity (``"auto"`` resolved to one of the others).
    """

    light_directions: np.ndarray
    light_intensities: np.ndarray
    result: PhotometricStereoResult
    gbr: tuple[float, float, float] | None
    cue: str


def gbr_matrix(mu: float, nu: float, lam: float) -> np.ndarray:
    """``K``, the GBR transformation of pseudo-normals ``b -> K b`` (lights go by ``K^{-T}``).

    ``K = [[lambda, 0, -mu], [0, lambda, -nu], [0, 0, 1]]``: the surface ``z`` becomes
    ``lambda z + mu x + nu y`` (up to the scale of ``b``, which only scales the albedo).

    References
    ----------
    P. N. Belhumeur, D. J. Kriegman, A. L. Yuille, IJCV 35(1), 1999, eq. 3.

    Examples
    --------
    The surface ``z`` becomes ``2 z + x``:

    >>> gbr_matrix(mu=-1.0, nu=0.0, lam=2.0).tolist()
    [[2.0, 0.0, 1.0], [0.0, 2.0, -0.0], [0.0, 0.0, 1.0]]
    """
    if lam == 0 or not np.all(np.isfinite((mu, nu, lam))):
        raise ParameterError(f"GBR needs finite mu, nu and lambda != 0; got {(mu, nu, lam)}")
    return np.array([[lam, 0.0, -mu], [0.0, lam, -nu], [0.0, 0.0, 1.0]])


def lit_everywhere(
    gray: np.ndarray, *, shadow_threshold: float = 0.05, saturation: float = 0.98
) -> np.ndarray:
    """Pixels ``(P,)`` that every light reaches and none saturates: where ``M`` is rank 3.

    An observation is a shadow when it is below ``shadow_threshold`` times the 99th percentile
    of its image, saturated when at or above ``saturation`` (images in [0, 1]).
    """
    if not 0 <= shadow_threshold < 1:
        raise ParameterError(f"shadow_threshold must be in [0, 1), got {shadow_threshold}")
    level = np.percentile(gray, 99, axis=1, keepdims=True)
    return np.all((gray > shadow_threshold * level) & (gray < saturation), axis=0)


def factorize(gray: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rank-3 factorisation ``M ≈ L B`` of an ``(N, P)`` matrix (Hayakawa 1994).

    ``M = U S V^T`` truncated to the three largest singular values:
    ``L = U_3 S_3^{1/2}``, ``B = S_3^{1/2} V_3^T`` (computed from the ``N x N`` Gram matrix,
    so the cost is ``N^2 P``).

    Returns
    -------
    L : (N, 3); B : (3, P).

    References
    ----------
    H. Hayakawa, JOSA A 11(11), 1994, §3.
    """
    eigenvalues, u = np.linalg.eigh(gray @ gray.T)
    order = np.argsort(eigenvalues)[::-1][:3]
    s = np.sqrt(np.maximum(eigenvalues[order], 0.0))
    if s[2] <= 1e-12 * s[0]:
        raise ParameterError("the images have rank below 3: the lights are coplanar or too few")
    u = u[:, order]
    v_t = (u.T @ gray) / s[:, None]
    return u * np.sqrt(s), np.sqrt(s)[:, None] * v_t


def integrability_transform(
    pseudo_normals: np.ndarray, valid: np.ndarray, *, sigma: float = 0.0
) -> np.ndarray:
    """``A`` (3, 3) making ``A e`` integrable, up to a GBR transformation (Yuille & Snow 1997).

    ``pseudo_normals`` is the ``(H, W, 3)`` map of the factor ``e`` (zero where not ``valid``).
    The map is first smoothed by a Gaussian of ``sigma`` pixels inside ``valid`` (normalised
    convolution; ``A`` commutes with it), which tames the derivatives of 8-bit images. At every
    pixel whose four neighbours are valid, central differences give ``e_x`` (along a row) and
    ``e_y`` (minus the difference down a column, as y goes up); the rows
    ``[(e x e_y)^T, -(e x e_x)^T]`` form a homogeneous system for ``(c_1, c_2)``, solved by
    the singular vector of the smallest singular value (rows scaled to unit length). Then
    ``a_3 = c_1 x c_2 / |c_1 x c_2|``, ``a_1 = c_1 x a_3``, ``a_2 = c_2 x a_3`` (which give
    back ``a_3 x a_i = c_i``); every other solution is ``K A`` with ``K`` a GBR matrix.

    Raises
    ------
    brdfkit.errors.ParameterError
        Fewer than 6 pixels with four valid neighbours, or a degenerate solution.

    References
    ----------
    A. Yuille, D. Snow, CVPR 1997, §3; P. N. Belhumeur et al., IJCV 35(1), 1999, §4.
    """
    e, v = pseudo_normals, valid
    if sigma > 0:  # normalised convolution inside ``valid``; A commutes with it
        from scipy import ndimage

        weight = ndimage.gaussian_filter(v.astype(np.float64), sigma)
        e = ndimage.gaussian_filter(e, (sigma, sigma, 0)) / np.maximum(weight, 1e-12)[..., None]
        v = ndimage.binary_erosion(v, iterations=int(np.ceil(2 * sigma)))
    centre, e_x, e_y = _central_differences(e, v)
    rows = np.concatenate([np.cross(centre, e_y), -np.cross(centre, e_x)], axis=1)
    rows /= np.maximum(np.linalg.norm(rows, axis=1, keepdims=True), 1e-300)
    _, _, v_t = np.linalg.svd(rows.T @ rows)
    c_1, c_2 = v_t[-1, :3], v_t[-1, 3:]
    a_3 = np.cross(c_1, c_2)
    if np.linalg.norm(a_3) < 1e-12:
        raise ParameterError("the integrability constraint is degenerate on these images")
    a_3 /= np.linalg.norm(a_3)
    return np.stack([np.cross(c_1, a_3), np.cross(c_2, a_3), a_3])


def _central_differences(
    field: np.ndarray, valid: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(centre, d_x, d_y)`` ``(K, 3)`` of an ``(H, W, 3)`` field at the ``K`` pixels whose
    four neighbours are ``valid``: central differences along a row (x) and up a column (y goes
    up, so minus the difference down it).

    Raises
    ------
    brdfkit.errors.ParameterError
        Fewer than 6 such pixels.
    """
    v = valid
    both = v[1:-1, 1:-1] & v[1:-1, 2:] & v[1:-1, :-2] & v[2:, 1:-1] & v[:-2, 1:-1]
    if both.sum() < 6:
        raise ParameterError(
            f"only {int(both.sum())} pixels have four lit neighbours; the integrability "
            "constraint needs at least 6 (a larger, less shadowed mask)"
        )
    d_x = (field[1:-1, 2:][both] - field[1:-1, :-2][both]) / 2
    d_y = -(field[2:, 1:-1][both] - field[:-2, 1:-1][both]) / 2
    return field[1:-1, 1:-1][both], d_x, d_y


def _local_maxima(image: np.ndarray, mask: np.ndarray, radius: int, sigma: float) -> np.ndarray:
    """Pixels (bool map) that are the strict maximum of the smoothed ``image`` in a
    ``(2 radius + 1)^2`` window lying wholly inside ``mask``."""
    from scipy import ndimage

    smooth = ndimage.gaussian_filter(np.where(mask, image, 0.0), sigma)
    weight = ndimage.gaussian_filter(mask.astype(np.float64), sigma)
    smooth = np.where(mask, smooth / np.maximum(weight, 1e-12), -np.inf)
    size = 2 * radius + 1
    peak = ndimage.maximum_filter(smooth, size=size, mode="constant", cval=-np.inf)
    inside = ndimage.binary_erosion(mask, np.ones((size, size), bool), border_value=0)
    return inside & (smooth == peak) & np.isfinite(smooth)


def _q_to_gbr(q: np.ndarray) -> tuple[float, float, float]:
    """``(mu, nu, |lambda|)`` from ``Q = K^T K`` up to scale: ``q = t (lambda^2, -lambda mu,
    -lambda nu, mu^2 + nu^2 + 1)``."""
    if q[0] < 0:
        q = -q
    if q[0] <= 0:
        raise ParameterError("the diffuse maxima do not determine the GBR (q_1 = 0)")
    m, n = -q[1] / q[0], -q[2] / q[0]
    inverse_lam2 = q[3] / q[0] - m**2 - n**2
    if inverse_lam2 <= 0:
        raise ParameterError(
            "the diffuse maxima are inconsistent with a GBR transformation (Q not positive "
            "definite): too few maxima, or they are not where the normal meets the light"
        )
    lam = 1.0 / np.sqrt(inverse_lam2)
    return float(lam * m), float(lam * n), float(lam)


def _solve_q(b: np.ndarray, l: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Least-squares ``q`` of ``(Q b) x l = 0`` over pairs ``b, l`` (rows, unit length)."""
    bx, by, bz = b.T
    zero = np.zeros_like(bx)
    # Q b = (q1 bx + q2 bz, q1 by + q3 bz, q2 bx + q3 by + q4 bz), as a (P, 3, 4) map of q.
    qb = np.stack(
        [np.stack([bx, bz, zero, zero], 1), np.stack([by, zero, bz, zero], 1),
         np.stack([zero, bx, by, bz], 1)], axis=1,
    )  # fmt: skip
    rows = np.cross(qb, l[:, :, None], axis=1)  # (P, 3, 4): each component of (Q b) x l
    rows = (rows * np.sqrt(weights)[:, None, None]).reshape(-1, 4)
    _, _, v_t = np.linalg.svd(rows, full_matrices=False)
    return v_t[-1]


def resolve_gbr_diffuse_maxima(
    gray_maps: np.ndarray,
    pseudo_normals: np.ndarray,
    lights: np.ndarray,
    mask: np.ndarray,
    *,
    radius: int = 5,
    sigma: float = 1.5,
    iterations: int = 3,
) -> tuple[float, float, float]:
    """GBR ``(mu, nu, lambda)`` from local diffuse reflectance maxima (Papadhimitri & Favaro).

    In each image the strict local maxima of the (Gaussian-smoothed) shading, away from the
    mask's edge, are where ``n ∥ l_k`` when the albedo is locally uniform; there
    ``Q b ∥ l_k`` with ``Q = K^T K``. The 4 entries of ``Q`` solve all these
    ``(Q b) x l_k = 0`` in the least-squares sense (closed form: a 4-vector SVD); ``K`` follows
    up to the sign of ``lambda`` (returned positive). Maxima whose angle between ``K b`` and
    ``K^{-T} l_k`` exceeds twice the median (shading maxima that are albedo edges or
    highlights) are dropped and the solve repeated ``iterations`` times.

    Parameters
    ----------
    gray_maps : (N, H, W) shading images.
    pseudo_normals : (H, W, 3) integrable pseudo-normals ``b`` (zero outside ``mask``).
    lights : (N, 3) lights ``l`` with ``M = L B``.
    mask : (H, W) pixels where ``b`` is known.

    Raises
    ------
    brdfkit.errors.ParameterError
        Fewer than 2 maxima, or maxima that no GBR explains.

    References
    ----------
    T. Papadhimitri, P. Favaro, IJCV 107(2), 2014, §4 (and CVPR 2012).
    """
    b_rows, l_rows = [], []
    for k, image in enumerate(gray_maps):
        peaks = _local_maxima(image, mask, radius, sigma)
        b_rows.append(pseudo_normals[peaks])
        l_rows.append(np.broadcast_to(lights[k], (int(peaks.sum()), 3)))
    b = np.concatenate(b_rows)
    l = np.concatenate(l_rows)
    if len(b) < 2:
        raise ParameterError(
            f"found {len(b)} local diffuse maxima; resolving the GBR needs at least 2"
        )
    b = b / np.linalg.norm(b, axis=1, keepdims=True)
    l = l / np.linalg.norm(l, axis=1, keepdims=True)
    weights = np.ones(len(b))
    for _ in range(iterations + 1):
        mu, nu, lam = _q_to_gbr(_solve_q(b, l, weights))
        k = gbr_matrix(mu, nu, lam)
        n = b @ k.T
        s = l @ np.linalg.inv(k)  # rows of K^{-T} l
        cosine = np.sum(n * s, 1) / (np.linalg.norm(n, axis=1) * np.linalg.norm(s, axis=1))
        angle = np.arccos(np.clip(cosine, -1, 1))
        weights = (angle <= 2 * np.median(angle) + 1e-9).astype(np.float64)
        if weights.sum() < 2:
            break
    return mu, nu, lam


def resolve_gbr_equal_intensity(lights: np.ndarray) -> tuple[float, float, float]:
    r"""GBR ``(mu, nu, lambda)`` that gives every light the same intensity.

    The true lights are :math:`l_k = K^{-T} l_k^0` (``l^0`` the integrable family's lights), so
    :math:`|l_k|^2 = l_k^{0T} C\, l_k^0` with :math:`C = K^{-1} K^{-T}`. Equal intensities
    make :math:`l^{0T} C l^0` constant: linear least squares in the six entries of the
    symmetric ``C`` (Hayakawa 1994, §4), solved in closed form. A GBR gives

    .. math:: C \propto \begin{pmatrix} (1 + \mu^2)/\lambda^2 & \mu\nu/\lambda^2 &
              \mu/\lambda \\ \mu\nu/\lambda^2 & (1 + \nu^2)/\lambda^2 & \nu/\lambda \\
              \mu/\lambda & \nu/\lambda & 1 \end{pmatrix},

    so, with ``C`` scaled to :math:`C_{33} = 1`: :math:`\mu/\lambda = C_{13}`,
    :math:`\nu/\lambda = C_{23}` and :math:`1/\lambda^2` the mean of
    :math:`C_{11} - C_{13}^2` and :math:`C_{22} - C_{23}^2`. ``lambda`` is returned positive.
    It needs lights of equal (or known, the images divided by them) intensity, as DiLiGenT's
    ``light_intensities.txt`` gives, and no assumption on the albedo.

    Parameters
    ----------
    lights : (N, 3) lights ``l^0`` of the integrable family (``M = L B``), N >= 6.

    Raises
    ------
    brdfkit.errors.ParameterError
        Fewer than 6 lights; no GBR makes the intensities equal (``1/lambda^2 <= 0``), or
        the closest leaves them more than :data:`EQUAL_INTENSITY_SPREAD` apart: the lights
        are not of equal intensity, or ``lights`` is no GBR of the true ones (integrability
        failed).

    References
    ----------
    H. Hayakawa, JOSA A 11(11), 1994, §4 (equal intensities fix the linear ambiguity up to a
    rotation); P. N. Belhumeur, D. J. Kriegman, A. L. Yuille, IJCV 35(1), 1999 (the GBR
    family left by integrability).

    Examples
    --------
    Lights of equal intensity seen through a GBR come back:

    >>> import numpy as np
    >>> from brdfkit.vision import datasets
    >>> lights = datasets.diligent_like_lights(4, 3, np.radians(40))
    >>> seen = lights @ gbr_matrix(0.3, -0.2, 1.5)  # rows of l^0 = K^T l
    >>> np.round(resolve_gbr_equal_intensity(seen), 6).tolist()
    [0.3, -0.2, 1.5]
    """
    if len(lights) < 6:
        raise ParameterError(
            f"the equal_intensity cue needs at least 6 lights (6 unknowns); got {len(lights)}"
        )
    c = _unit_quadric(lights)
    mu_over_lam, nu_over_lam = c[4] / c[2], c[5] / c[2]
    inverse_lam2 = (c[0] / c[2] - mu_over_lam**2 + c[1] / c[2] - nu_over_lam**2) / 2
    if c[2] <= 0 or inverse_lam2 <= 0:
        raise ParameterError(
            "no GBR transformation gives these lights equal intensities: the equal_intensity "
            "cue needs lights of equal intensity (or images divided by them)"
        )
    lam = 1.0 / np.sqrt(inverse_lam2)
    mu, nu = lam * mu_over_lam, lam * nu_over_lam
    intensity = np.linalg.norm(lights @ np.linalg.inv(gbr_matrix(mu, nu, lam)), axis=1)
    spread = 1.4826 * np.median(np.abs(intensity / np.median(intensity) - 1.0))
    if spread > EQUAL_INTENSITY_SPREAD:
        raise ParameterError(
            f"the closest GBR leaves the lights' intensities {spread:.0%} apart (robust spread; "
            f"at most {EQUAL_INTENSITY_SPREAD:.0%} expected): integrability failed on these "
            "images, or the lights are not of equal intensity; try another cue"
        )
    return float(mu), float(nu), float(lam)


def _albedo_entropy(rho: np.ndarray, bins: int, bandwidth: float) -> float:
    """Entropy of the density of ``rho / mean(rho)`` on ``[0, 3]``: linear binning into
    ``bins`` bins, then a Gaussian kernel of ``bandwidth`` (a Parzen estimate that varies
    continuously with ``rho``, as a minimiser needs)."""
    from scipy import ndimage

    position = np.clip(rho / rho.mean(), 0.0, 3.0) / 3.0 * (bins - 1)
    low = np.minimum(np.floor(position).astype(np.int64), bins - 2)
    upper = position - low
    density = np.bincount(low, 1.0 - upper, bins) + np.bincount(low + 1, upper, bins)
    density = ndimage.gaussian_filter1d(density, bandwidth / 3.0 * (bins - 1), mode="constant")
    p = density[density > 0] / density.sum()
    return float(-(p * np.log(p)).sum())


def resolve_gbr_entropy(
    pseudo_normals: np.ndarray, *, bins: int = 600, bandwidth: float = 0.01
) -> tuple[float, float, float]:
    """GBR ``(mu, nu, lambda)`` minimising the entropy of the albedo distribution (Alldrin 2007).

    Under ``K`` the albedo is ``rho = |K b|``; a surface made of few materials has the most
    concentrated albedo distribution at the true GBR. The albedos are normalised by their mean
    (the overall scale is not observable), their density estimated on ``[0, 3]`` (Parzen
    window of ``bandwidth``) and its Shannon entropy minimised over ``(mu, nu, log lambda)``:
    a coarse grid search, then Nelder-Mead. ``lambda`` is returned positive.

    Parameters
    ----------
    pseudo_normals : (P, 3) integrable pseudo-normals ``b``.
    bins, bandwidth : the density estimate (bandwidth in units of the mean albedo).

    References
    ----------
    N. G. Alldrin, S. P. Mallick, D. J. Kriegman, CVPR 2007, §3.
    """
    from scipy.optimize import minimize

    b = pseudo_normals

    def cost(x: np.ndarray) -> float:
        mu, nu, log_lam = x
        lam = np.exp(log_lam)
        rho = np.sqrt((lam * b[:, 0] - mu * b[:, 2]) ** 2 + (lam * b[:, 1] - nu * b[:, 2]) ** 2
                      + b[:, 2] ** 2)  # fmt: skip
        return _albedo_entropy(rho, bins, bandwidth)

    grid = [
        (mu, nu, log_lam)
        for mu in np.linspace(-2, 2, 9)
        for nu in np.linspace(-2, 2, 9)
        for log_lam in np.linspace(-1.5, 1.5, 7)
    ]
    x0 = np.array(min(grid, key=cost))
    best = minimize(cost, x0, method="Nelder-Mead", options={"xatol": 1e-5, "fatol": 1e-8})
    mu, nu, log_lam = best.x
    return float(mu), float(nu), float(np.exp(log_lam))


@dataclass(frozen=True)
class LambertianFactor:
    """Output of :func:`robust_factorize`: ``M ≈ L B`` on the inlying observations.

    Attributes
    ----------
    lights : (N, 3) the factor ``L``.
    pseudo_normals : (3, P) the factor ``B`` (zero where not ``known``).
    known : (P,) pixels with at least 6 inlying observations.
    residual : (N, P) ``M - L B``.
    noise : robust scale (1.4826 MAD) of the inlying residuals.
    """

    lights: np.ndarray
    pseudo_normals: np.ndarray
    known: np.ndarray
    residual: np.ndarray
    noise: float


def robust_factorize(
    gray: np.ndarray, usable: np.ndarray, *, threshold: float = 2.0, iterations: int = 30
) -> LambertianFactor:
    """Rank-3 factorisation of ``(N, P)`` images with shadows and highlights left out.

    Alternating least squares on the observations that are ``usable`` (neither in shadow nor
    saturated) and
    inlying: each pixel's ``b`` from its inlying observations, then each light's ``l`` from
    its inlying pixels, until the inliers no longer change (at most ``iterations`` rounds).
    An observation is an outlier when its residual ``m - l.b`` exceeds
    ``threshold`` times the robust scale of the residuals: one-sided, since a specular lobe
    only adds to the Lambertian part, so the fit settles on the lower envelope. Starts from
    :func:`factorize` of ``M`` with the unusable observations zeroed and each image clipped at
    its 90th percentile, the brighter observations left out of the first round (so that the
    first fit is not drawn to the highlights). An image with fewer than 6 inlying pixels gets
    its light from all its usable ones.

    Raises
    ------
    brdfkit.errors.ParameterError
        Fewer than 10 pixels usable in 6 or more images.

    References
    ----------
    H. Hayakawa, JOSA A 11(11), 1994 (the factorisation); the alternation is that of
    low-rank matrix completion (e.g. Buchanan & Fitzgibbon, CVPR 2005).
    """
    lit_enough = int(np.count_nonzero(usable.sum(0) >= 6))
    if lit_enough < 10:
        raise ParameterError(
            f"only {lit_enough} pixels are lit in 6 or more images; the factorisation needs at "
            "least 10 (lower shadow_threshold, or use a larger mask)"
        )
    bright = np.array([[np.percentile(row[lit], 90) if lit.any() else 0.0]
                       for row, lit in zip(gray, usable, strict=True)])  # fmt: skip
    weight = (usable & (gray <= bright)).astype(np.float64)
    lights, b = factorize(np.minimum(gray, bright) * usable)
    for _ in range(iterations):
        gram = (weight.T @ _outer_rows(lights)).reshape(-1, 3, 3)
        moment = (weight * gray).T @ lights
        known = (weight.sum(0) >= 6) & (np.linalg.det(gram) > 1e-9 * np.trace(gram, 0, 1, 2) ** 3)
        b = np.zeros((3, gray.shape[1]))
        b[:, known] = np.linalg.solve(gram[known], moment[known][..., None])[..., 0].T
        per_light = np.where(weight.sum(1, keepdims=True) >= 6, weight, usable * known)
        gram = (per_light @ _outer_rows(b.T)).reshape(-1, 3, 3)
        moment = (per_light * gray) @ b.T
        lights = (np.linalg.pinv(gram) @ moment[..., None])[..., 0]
        residual = gray - lights @ b
        noise = 1.4826 * float(np.median(np.abs(residual[usable & known])))
        inliers = usable & (residual <= threshold * noise)
        if np.array_equal(inliers, weight > 0):
            break
        weight = inliers.astype(np.float64)
    return LambertianFactor(lights, b * known, known, residual, noise)


def _unit_quadric(lights: np.ndarray) -> np.ndarray:
    """``(C_11, C_22, C_33, C_12, C_13, C_23)`` of the symmetric ``C`` with ``l^T C l = 1`` for
    every row ``l`` of ``lights``, in the least-squares sense (Hayakawa 1994, §4)."""
    x, y, z = lights.T
    rows = np.stack([x * x, y * y, z * z, 2 * x * y, 2 * x * z, 2 * y * z], axis=1)
    return np.linalg.lstsq(rows, np.ones(len(lights)), rcond=None)[0]


def _outer_rows(rows: np.ndarray) -> np.ndarray:
    """``(M, 9)``: each row's outer product with itself, flattened."""
    return (rows[:, :, None] * rows[:, None, :]).reshape(len(rows), 9)


def equal_intensity_metric(lights_hat: np.ndarray) -> np.ndarray:
    """``A_0`` with ``A = R A_0`` (``R`` orthogonal) when every light has the same intensity.

    The true lights are ``l_k = A^{-T} l̂_k``; equal intensities ``|l_k| = 1`` give
    ``l̂_k^T C l̂_k = 1`` with ``C = A^{-1} A^{-T}`` symmetric: 6 unknowns, linear least
    squares over the ``N`` lights (Hayakawa 1994, §4). ``C = W W^T`` fixes ``A_0 = W^{-1}``.

    Raises
    ------
    brdfkit.errors.ParameterError
        ``C`` is not positive definite (the intensities are far from equal).

    References
    ----------
    H. Hayakawa, JOSA A 11(11), 1994, §4.
    """
    c = _unit_quadric(lights_hat)
    metric = np.array([[c[0], c[3], c[4]], [c[3], c[1], c[5]], [c[4], c[5], c[2]]])
    eigenvalues, vectors = np.linalg.eigh(metric)
    if eigenvalues[0] <= 1e-9 * eigenvalues[-1]:
        raise ParameterError(
            "the specular cue needs lights of equal intensity (or images divided by them); "
            "these images admit none"
        )
    return np.linalg.inv(vectors * np.sqrt(eigenvalues))


def specular_highlights(
    factor: LambertianFactor, gray: np.ndarray, lit: np.ndarray, *, contrast: float = 0.2
) -> tuple[np.ndarray, np.ndarray]:
    """Pairs ``(b, l̂_k)`` (rows, ``b`` unit) at the specular peak of each image ``k``.

    The peak is the ``lit`` observation (``(N, P)``: not in shadow; saturated ones included)
    of largest residual over the Lambertian fit (with its neighbours
    within 10 % of it, averaged by residual); an image has one when that residual exceeds
    ``contrast`` times the image's 99th percentile and 10 times the noise.
    """
    b = factor.pseudo_normals / np.maximum(np.linalg.norm(factor.pseudo_normals, axis=0), 1e-300)
    level = np.percentile(gray, 99, axis=1)
    b_rows, l_rows = [], []
    for k, residual in enumerate(np.where(factor.known & lit, factor.residual, 0.0)):
        peak = residual.max()
        if peak < max(contrast * level[k], 10 * factor.noise):
            continue
        near = residual >= 0.9 * peak
        centre = b[:, near] @ residual[near]
        b_rows.append(centre / np.linalg.norm(centre))
        l_rows.append(factor.lights[k])
    return np.reshape(b_rows, (-1, 3)), np.reshape(l_rows, (-1, 3))


def _specular_residual(a: np.ndarray, b: np.ndarray, lights_hat: np.ndarray) -> np.ndarray:
    """``n - h`` (flattened) with ``n = A b / |A b|`` and ``h`` the half vector of
    ``A^{-T} l̂`` and the view ``(0, 0, 1)``."""
    n = b @ a.T
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    light = lights_hat @ np.linalg.inv(a)
    light /= np.linalg.norm(light, axis=1, keepdims=True)
    return (n - half_vector(light, np.array([0.0, 0.0, 1.0]))).ravel()


def _tilt(x: np.ndarray) -> np.ndarray:
    """The rotation by ``|x|`` about the axis ``(x_0, x_1, 0)``."""
    from scipy.spatial.transform import Rotation

    return Rotation.from_rotvec([x[0], x[1], 0.0]).as_matrix()


def resolve_tilt_specular(
    a_0: np.ndarray, b: np.ndarray, lights_hat: np.ndarray, *, scale: float = 0.02
) -> np.ndarray:
    """``T A_0`` with the tilt ``T`` that puts the normals of the specular peaks on the half
    vectors of their lights and the view (Drbohlav & Šára 2002).

    At image ``k``'s specular peak ``n = h_k = (l_k + v) / |l_k + v|``, ``v = (0, 0, 1)``;
    with ``n ∝ A b`` and ``l_k ∝ A^{-T} l̂_k`` and ``A = R A_0``
    (:func:`equal_intensity_metric`), a rotation about ``v`` leaves every such equation as it
    is, so the peaks fix the two angles of the tilt ``T`` (a rotation about an axis in the
    image plane): a grid over tilts up to 80° (10° by 20°), then robust least squares
    (soft-L1 of ``scale``, about 1°) from the three best.

    References
    ----------
    O. Drbohlav, R. Šára, "Specularities reduce ambiguity of uncalibrated photometric
    stereo", ECCV 2002; A. S. Georghiades, ICCV 2003.
    """
    from scipy.optimize import least_squares

    def residual(x: np.ndarray) -> np.ndarray:
        return _specular_residual(_tilt(x) @ a_0, b, lights_hat)

    grid = [
        angle * np.array([np.cos(azimuth), np.sin(azimuth)])
        for angle in np.radians(np.arange(0, 81, 10))
        for azimuth in np.radians(np.arange(0, 360, 20))
    ]
    costs = [float(np.median(residual(x).reshape(-1, 3) ** 2 @ np.ones(3))) for x in grid]
    starts = [grid[i] for i in np.argsort(costs)[:3]]
    fits = [least_squares(residual, x, loss="soft_l1", f_scale=scale) for x in starts]
    return _tilt(min(fits, key=lambda fit: fit.cost).x) @ a_0


def integrable_view_rotation(normals: np.ndarray, valid: np.ndarray) -> tuple[float, float]:
    """The rotation ``phi`` about the view that makes a normal field most integrable, and how
    much more integrable it is than the field turned a further 90° (0: wholly, 1: not at all).

    A surface's normals satisfy ``n_3 ∂_y n_1 - n_1 ∂_y n_3 = n_3 ∂_x n_2 - n_2 ∂_x n_3``
    (module, step 2); turned by ``phi`` about the view (``n_1 + i n_2 → e^{i phi} (n_1 + i
    n_2)``) the residual of that equation is ``cos(phi) C_1 - sin(phi) C_2`` with

    ``C_1 = (n × ∂_y n)_2 + (n × ∂_x n)_1``, ``C_2 = (n × ∂_x n)_2 - (n × ∂_y n)_1``,

    central differences at every pixel whose four neighbours are ``valid``. ``phi`` minimises
    the sum of the residuals' magnitudes (robust to depth edges): a 1° grid over ``[0, π)``
    (``phi + π`` is the depth-reversed field, as integrable) refined to 0.01°. A plane's field
    is integrable at every ``phi``; a curved surface's only at its own.

    References
    ----------
    A. Yuille, D. Snow, CVPR 1997 (the integrability constraint on pseudo-normals).
    """
    from scipy.optimize import minimize_scalar

    centre, d_x, d_y = _central_differences(normals, valid)
    along_y, along_x = np.cross(centre, d_y), np.cross(centre, d_x)
    c_1 = along_y[:, 1] + along_x[:, 0]
    c_2 = along_x[:, 1] - along_y[:, 0]

    def cost(phi: float) -> float:
        return float(np.sum(np.abs(np.cos(phi) * c_1 - np.sin(phi) * c_2)))

    grid = np.radians(np.arange(180.0))
    costs = np.array([cost(phi) for phi in grid])
    best = grid[np.argmin(costs)]
    step = np.radians(1.0)
    phi = minimize_scalar(cost, bounds=(best - step, best + step), method="bounded",
                          options={"xatol": np.radians(0.01)}).x  # fmt: skip
    return float(phi), cost(phi) / max(cost(phi + np.pi / 2), 1e-300)


def resolve_specular(
    factor: LambertianFactor, b: np.ndarray, lights_hat: np.ndarray, mask: np.ndarray
) -> np.ndarray:
    """``A`` (3, 3) with lights ``A^{-T} l̂`` and pseudo-normals ``A b̂``, from the specular
    peaks: no integrability, no GBR.

    The metric of equal intensities (:func:`equal_intensity_metric`) gives ``A`` up to a
    rotation ``R``; the specular peaks ``(b, l̂)`` (:func:`specular_highlights`) fix its tilt
    (:func:`resolve_tilt_specular`); integrability its rotation about the view
    (:func:`integrable_view_rotation`) and which of ``A`` and its mirror image
    ``diag(-1, 1, 1) A`` (both explain the images and the peaks) it is: the one whose
    normals are the more integrable. The occluding contour, where normals point out of the
    silhouette, tells the convex reading from its depth reversal (a rotation by π).

    Parameters
    ----------
    factor : :func:`robust_factorize` of the object's pixels.
    b, lights_hat : the specular peaks' pseudo-normals and lights (rows).
    mask : (H, W) the object, whose pixels ``factor`` holds in row-major order.

    References
    ----------
    O. Drbohlav, R. Šára, ECCV 2002; H. Hayakawa, JOSA A 11(11), 1994.
    """
    a_0 = equal_intensity_metric(factor.lights)
    known = np.zeros(mask.shape, bool)
    known.flat[np.flatnonzero(mask)[factor.known]] = True
    best = (np.inf, a_0)
    for mirror in (np.eye(3), np.diag([-1.0, 1.0, 1.0])):
        a = resolve_tilt_specular(mirror @ a_0, b, lights_hat)
        pseudo = a @ factor.pseudo_normals[:, factor.known]
        facing = np.sign(np.median(pseudo[2]))  # b -> -b, l -> -l: normals face the camera
        a *= facing
        normals = np.zeros((*mask.shape, 3))
        normals[known] = facing * pseudo.T
        normals /= np.maximum(np.linalg.norm(normals, axis=-1, keepdims=True), 1e-300)
        phi, non_integrability = integrable_view_rotation(normals, known)
        if _outward_sign(normals @ _rotation_z(phi).T, known) < 0:
            phi += np.pi  # the depth-reversed reading, as integrable: the convex one is kept
        if non_integrability < best[0]:
            best = (non_integrability, _rotation_z(phi) @ a)
    return best[1]


def _rotation_z(phi: float) -> np.ndarray:
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _outward_sign(normals: np.ndarray, mask: np.ndarray, width: int = 6) -> float:
    """``+1`` when the normals within ``width`` pixels of the mask's edge point outwards on
    average (x right, y up), ``-1`` otherwise: the convex reading of the bas-relief sign."""
    from scipy import ndimage

    distance = ndimage.distance_transform_edt(mask)
    rim = mask & (distance <= width)
    grad_row, grad_col = np.gradient(ndimage.gaussian_filter(distance, 2.0))
    # Outwards = down the distance gradient; y is minus the row direction.
    score = np.sum(-grad_col[rim] * normals[rim, 0] + grad_row[rim] * normals[rim, 1])
    return 1.0 if score >= 0 else -1.0


def uncalibrated(
    images: ArrayLike,
    mask: ArrayLike | None = None,
    *,
    cue: Cue = "auto",
    method: str = "least_squares",
    shadow_threshold: float = 0.05,
    sigma: float = 1.0,
) -> UncalibratedResult:
    """Uncalibrated photometric stereo: lights, then normals and albedo.

    With ``cue="specular"``: the robust factorisation (:func:`robust_factorize`), the metric
    of equal intensities and the specular peaks (:func:`resolve_specular`). With the GBR cues:
    factorisation of the fully lit pixels (:func:`factorize`; :func:`robust_factorize` of
    all where they are under :data:`LIT_EVERYWHERE_SHARE` of the mask), integrability
    (:func:`integrability_transform`), the GBR from ``cue``
    (:func:`resolve_gbr_equal_intensity`, :func:`resolve_gbr_diffuse_maxima` or
    :func:`resolve_gbr_entropy`) and the convex sign.
    Then the calibrated ``method`` of :data:`brdfkit.vision.photometric_stereo.METHODS` run
    with the lights found (the images divided by the relative intensities).

    Parameters
    ----------
    images : (N, H, W) or (N, H, W, C) linear images, N >= 3 lights of unknown direction and
        intensity.
    mask : (H, W) bool, the object; all pixels when omitted.
    cue : ``"specular"`` (glossy objects, lights of equal intensity), ``"equal_intensity"``
        (lights of equal or known intensity, any albedo), ``"diffuse_maxima"`` (closed
        form, any albedo that is locally uniform), ``"entropy"`` (objects of few albedos) or
        ``"auto"``: specular where the highlights are consistent, else entropy (the cue used
        is :attr:`UncalibratedResult.cue`).
    method : the calibrated solver for the final normals.
    shadow_threshold : see :func:`lit_everywhere`.
    sigma : smoothing (pixels) before the integrability derivatives
        (:func:`integrability_transform`).

    Raises
    ------
    brdfkit.errors.ParameterError
        Bad images or mask (as :func:`~brdfkit.vision.photometric_stereo.least_squares`), an
        unknown ``cue`` or ``method``, an image black inside the mask (its light cannot be
        estimated), too few fully lit pixels, or images the cue cannot resolve.
    brdfkit.errors.ResourceError
        The data would not fit in memory.

    References
    ----------
    See the module: Hayakawa 1994; Yuille & Snow 1997; Belhumeur et al. 1999; Papadhimitri &
    Favaro 2014; Alldrin et al. 2007; Drbohlav & Šára 2002; Georghiades 2003.

    Examples
    --------
    A glossy sphere under 20 lights of unknown direction: the highlights fix them.

    >>> import numpy as np
    >>> from brdfkit.vision import datasets, photometric_stereo
    >>> normals, mask = photometric_stereo.sphere_normals((40, 40), (19.5, 19.5), 18.0)
    >>> lights = datasets.diligent_like_lights(5, 4, np.radians(40))
    >>> data = datasets.render_synthetic(
    ...     normals, mask, lights, albedo=0.5, specular=0.3, shininess=400
    ... )
    >>> estimate = uncalibrated(data.images, mask)
    >>> estimate.cue
    'specular'
    >>> cosine = np.sum(estimate.light_directions * lights, axis=1).clip(-1.0, 1.0)
    >>> bool(np.degrees(np.arccos(cosine)).max() < 0.5)
    True
    """
    if cue not in CUES:
        raise ParameterError(f"cue must be one of {', '.join(CUES)}; got {cue!r}")
    if method not in photometric_stereo.METHODS:
        choices = ", ".join(photometric_stereo.METHODS)
        raise ParameterError(f"method must be one of {choices}; got {method!r}")
    images = np.asarray(images)
    n_lights = images.shape[0] if images.ndim in (3, 4) else 0
    placeholder = np.tile([0.0, 0.0, 1.0], (max(n_lights, 1), 1))  # lights are what we seek
    observations, _, mask = _prepare(images, placeholder, mask)
    gray = _gray(observations)
    _check_no_black_image(gray)
    lights, gbr = None, None
    if cue in ("auto", "specular"):
        lights = _specular_lights(gray, mask, shadow_threshold, required=cue == "specular")
        cue = "specular" if lights is not None else "entropy"
    if lights is None:
        lights, gbr = _integrable_lights(gray, mask, cue, shadow_threshold, sigma)
    intensity = np.linalg.norm(lights, axis=1)
    directions = lights / intensity[:, None]
    intensity = intensity / np.median(intensity)
    shape = (-1,) + (1,) * (images.ndim - 1)
    scaled = np.asarray(images, dtype=np.float64) / intensity.reshape(shape)
    result = photometric_stereo.METHODS[method](scaled, directions, mask)
    return UncalibratedResult(directions, intensity, result, gbr, cue)


def _check_no_black_image(gray: np.ndarray) -> None:
    """Refuse ``(N, P)`` images of which some are black inside the mask: no light can be
    estimated from them (a light that did not fire, a dark frame)."""
    black = np.flatnonzero(~np.any(gray > 0, axis=1))
    if black.size:
        numbers = ", ".join(str(k + 1) for k in black[:10]) + (" ..." if black.size > 10 else "")
        noun, verb, them = ("image", "is", "it") if black.size == 1 else ("images", "are", "them")
        raise ParameterError(
            f"{noun} {numbers} (counted from 1) {verb} black inside the mask: no light can be "
            f"estimated from {them}; leave {them} out, or give the lights (calibrated "
            "photometric stereo)"
        )


def _integrable_lights(
    gray: np.ndarray, mask: np.ndarray, cue: str, shadow_threshold: float, sigma: float
) -> tuple[np.ndarray, tuple[float, float, float]]:
    """Lights ``(N, 3)`` (direction times relative intensity) and the GBR: factorisation (of
    the fully lit pixels, or robust), integrability, the GBR from ``cue``, the convex sign."""
    n_lights = len(gray)
    lights_hat, b_hat, known = _integrable_factor(gray, shadow_threshold)
    height, width = mask.shape
    lit_map = np.zeros((height, width), bool)
    lit_map.flat[np.flatnonzero(mask)[known]] = True
    e_map = np.zeros((height, width, 3))
    e_map[lit_map] = b_hat.T
    a = integrability_transform(e_map, lit_map, sigma=sigma)
    b0 = a @ b_hat
    if np.median(b0[2]) < 0:  # b -> -b, l -> -l explain the images too; normals face the camera
        a = -a
        b0 = -b0
    lights0 = lights_hat @ np.linalg.inv(a)
    b0_map = np.zeros((height, width, 3))
    b0_map[lit_map] = b0.T
    if cue == "equal_intensity":
        mu, nu, lam = resolve_gbr_equal_intensity(lights0)
    elif cue == "diffuse_maxima":
        gray_maps = np.zeros((n_lights, height, width))
        gray_maps[:, mask] = gray
        mu, nu, lam = resolve_gbr_diffuse_maxima(gray_maps, b0_map, lights0, lit_map)
    else:
        mu, nu, lam = resolve_gbr_entropy(b0.T)
    k = gbr_matrix(mu, nu, lam)
    if _outward_sign(np.einsum("ij,hwj->hwi", k, b0_map), lit_map) < 0:
        mu, nu, lam = -mu, -nu, -lam  # the concave reading: K -> diag(-1, -1, 1) K
        k = gbr_matrix(mu, nu, lam)
    return lights0 @ np.linalg.inv(k), (mu, nu, lam)  # rows of K^{-T} l


def _integrable_factor(
    gray: np.ndarray, shadow_threshold: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(L, B, known)``: the rank-3 factor ``L (N, 3)``, ``B (3, K)`` of the ``K`` pixels
    ``known`` ``(P,)`` that the GBR cues integrate: the SVD of the pixels lit in every image
    where they are at least :data:`LIT_EVERYWHERE_SHARE` of the mask, else the robust
    factorisation of every pixel's unshadowed, unsaturated observations."""
    lit = lit_everywhere(gray, shadow_threshold=shadow_threshold)
    if lit.mean() >= LIT_EVERYWHERE_SHARE and lit.sum() >= 10:
        return (*factorize(gray[:, lit]), lit)
    shadowed, saturated = _unusable(gray, shadow_threshold)
    factor = robust_factorize(gray, ~shadowed & ~saturated)
    return factor.lights, factor.pseudo_normals[:, factor.known], factor.known


def _specular_lights(
    gray: np.ndarray, mask: np.ndarray, shadow_threshold: float, *, required: bool
) -> np.ndarray | None:
    """Lights ``(N, 3)`` (direction times relative intensity) from the specular cue; when not
    ``required``, ``None`` where the images do not support it: fewer than 3 specular peaks,
    intensities that cannot be equal, or peaks that the fitted lights leave more than
    :data:`SPECULAR_CONSISTENCY` degrees (median) from their half vectors."""
    shadowed, saturated = _unusable(gray, shadow_threshold)
    lit = ~shadowed
    factor = robust_factorize(gray, lit & ~saturated)
    b, lights_hat = specular_highlights(factor, gray, lit)
    if len(b) < 3:
        if not required:
            return None
        raise ParameterError(
            f"found specular highlights in {len(b)} images; the specular cue needs at least 3 "
            "(a glossy object); for a matte one use the entropy or diffuse_maxima cue"
        )
    try:
        a = resolve_specular(factor, b, lights_hat, mask)
    except ParameterError:
        if required:
            raise
        return None  # "auto": intensities far from equal, which the entropy cue does not need
    residual = np.linalg.norm(_specular_residual(a, b, lights_hat).reshape(-1, 3), axis=1)
    if not required and np.degrees(2 * np.arcsin(np.median(residual) / 2)) > SPECULAR_CONSISTENCY:
        return None
    return factor.lights @ np.linalg.inv(a)


def _unusable(gray: np.ndarray, shadow_threshold: float) -> tuple[np.ndarray, np.ndarray]:
    """``(shadowed, saturated)`` observations of ``(N, P)`` images: below ``shadow_threshold``
    times the image's 99th percentile; at or above 98 % of the image's maximum."""
    level = np.percentile(gray, 99, axis=1, keepdims=True)
    return gray <= shadow_threshold * level, gray >= 0.98 * gray.max(axis=1, keepdims=True)
