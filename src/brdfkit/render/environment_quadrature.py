r"""Noise-free spheres under a distant environment map by deterministic quadrature.

An orthographic camera sees every pixel of a sphere along the same direction v (towards the
camera). For an isotropic BRDF the integrand :math:`f(\omega_i, v; n)\cos\theta_i` depends
only on :math:`n\cdot\omega_i`, :math:`n\cdot v` and :math:`\omega_i\cdot v`, so a pixel whose
normal is the ring normal :math:`n_0 = (\sin\theta_o, 0, \cos\theta_o)` (camera frame) rotated
by ψ about v sees the ring's kernel rotated by ψ. On a lat-long grid *about v* (θ' from v,
φ' around it) the reflected radiance is a circular cross-correlation in φ' per row:

.. math:: L_o(\theta_o, \psi) = \sum_r \Delta\Omega_r \sum_j K_{\theta_o}(\theta'_r, \varphi'_j)
          \, \bar L(\theta'_r, \varphi'_j + \psi),
          \qquad K = f(\omega, v)\,\max(n_0\cdot\omega, 0),

evaluated with one real FFT per row of the cell-averaged map :math:`\bar L` (once per map and
grid) and per row of each ring's kernel. Only wi above the surface count, as in
:func:`brdfkit.render.reflected_radiance` (a BSDF is seen one-sided).

An anisotropic BRDF also depends on the pixel's tangent. The sphere's tangents follow lines of
latitude (:class:`brdfkit.render.Sphere`), which do not turn with ψ: a pixel's tangent is
turned by an angle γ (:func:`_pixel_frames`) from the ring's tangent rotated by ψ, and the
pixel sees the kernel :math:`K_\gamma` of the ring with wi and wo both turned by −γ about
the normal. The kernels of a few γ (a period of the model's symmetry under such turns,
:func:`_rotation_symmetry`) give one correlation each; each pixel interpolates
trigonometrically in γ (:class:`_Level`). An isotropic model is the case of one γ.

Pixels interpolate the (ring, ψ) grid with a cubic 4 × 4 stencil to their own normal (the
Monte Carlo renderer's pixel-centre ray). Lambertian lobes
(:func:`~brdfkit.render.split_diffuse`) and a smooth plastic's mirror
(:func:`~brdfkit.render.split_mirror`) keep their exact terms; the quadrature covers the
rest. The grid is refined, twice as fine in every dimension per level, until the differences
between successive levels (Richardson's estimate, :func:`error_estimate`), plus the estimated
error of the interpolation in γ, put the finer image's error within the goal.

References
----------
.. [1] B. Cabral, N. Max, R. Springmeyer, "Bidirectional reflection functions from surface
       bump maps", SIGGRAPH 1987 (reflection under distant light as a convolution).
.. [2] J. Kautz, P.-P. Vázquez, W. Heidrich, H.-P. Seidel, "A unified approach to
       prefiltered environment maps", EGWR 2000.
.. [3] R. Ramamoorthi, P. Hanrahan, "A signal-processing framework for inverse rendering",
       SIGGRAPH 2001 (reflection under distant lighting as a rotational convolution).
.. [4] J. P. Boyd, *Chebyshev and Fourier Spectral Methods*, 2nd ed., Dover 2001, §§4–5
       (trigonometric interpolation; its error decays faster than any power of the count for
       smooth periodic functions).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from brdfkit.brdf.base import BRDF
from brdfkit.light.environment import EnvironmentMap

GOAL = 0.01
"""Default relative RMSE goal of :func:`quadrature_sphere`'s error estimate."""

SECOND_ORDER_RATE = 0.25
"""The slowest step ratio :func:`error_estimate` assumes once the steps shrink: a second-order
quadrature's, since each level halves the grid spacing. On the atlas's sharpest lobes (96²)
successive steps shrink by 0.22–0.27 past level 1 with bilinear interpolation (thin film
α = 0.05: 11.9, 1.00, 0.22 %), and from level −1 to 1 with the cubic stencil by 0.13–0.19
(the anisotropic examples of the atlas's cards)."""


def error_estimate(step: float, previous: float | None) -> float:
    r"""The relative RMSE of a level's image from its ``step`` (its difference from the level
    before) and the ``previous`` step.

    Where the steps shrink, at rate :math:`q = \max(\text{step}/\text{previous}, 1/4)`
    (:data:`SECOND_ORDER_RATE`; a faster apparent rate is not trusted, the first levels are not
    yet in the asymptotic regime), the error is the geometric tail
    :math:`\text{step}\,q/(1 - q)`, Richardson's estimate. With no rate seen (the first step)
    or steps that grow, it is twice the step: the first levels need not have settled — a rough
    dielectric seen from inside (η = 0.667, α = 0.3) steps 0.74 % from level 0 to 1 while
    level 1 is 1.31 % off, since its total-internal-reflection kink converges irregularly.
    """
    if previous is None or step >= previous:
        return 2.0 * step
    q = max(step / previous, SECOND_ORDER_RATE)
    return step * q / (1.0 - q)


BASE_GRID = (32, 64, 24)
"""θ' rows, φ' columns and rings (uniform in θo) of refinement level 0; each level doubles
all three (level −1 halves them)."""

MAX_LEVEL = 4
"""The finest refinement level :func:`quadrature_sphere` tries."""

FIRST_LEVEL = -1
"""The coarsest level :func:`quadrature_sphere` renders: level 0's grid halved, 1/8 of its
nodes, so that level 1 is judged by two steps (a rate) rather than by twice one step. Models
that transmit start at level 0 instead (:func:`_first_level`)."""

GAMMA_START = 8
"""Tangent angles γ per period of the first kernels of an anisotropic model at each level;
doubled while the level misses the goal and more angles may help (:func:`_refine`; the
angles are nested: doubling adds the odd ones)."""

GAMMA_MAX = 64
"""The most tangent angles per period a level spends; also those of a level rendered alone
(``quadrature_sphere(..., level=L)``), the reference that :func:`quadrature_sphere`'s
anisotropic images are checked against."""

GAMMA_SHARE = 0.5
"""The part of the goal past which the interpolation in γ is refined even where the grid
must be refined too (:func:`_refine`)."""

_SUPERSAMPLE = 4
_EVAL_CHUNK = 1 << 14
"""Directions per call of the model's ``eval``, so that its temporaries stay in the CPU's
caches (the values do not depend on it)."""
_LV_CACHE: dict[tuple, tuple[EnvironmentMap, np.ndarray]] = {}
_LOOKUP_CHUNK = 1 << 15
"""Directions per band of :func:`_cell_radiance` (whole rows of cells): the directions, the
map's lookups and their weighted sums per cell are made band by band, their temporaries in
the CPU's caches (the values do not depend on it)."""


def _grid(level: int) -> tuple[int, int, int]:
    """The (rows, cols, rings) of ``level``: :data:`BASE_GRID` × 2^level."""
    return tuple(n << level if level >= 0 else n >> -level for n in BASE_GRID)  # type: ignore


@dataclass(frozen=True)
class QuadratureImage:
    """:func:`quadrature_sphere`'s result: the linear ``image`` ``(H, W, C)``, the BRDF
    evaluations it spent (``nodes``), its estimated relative RMSE (``error``,
    :func:`error_estimate`), its refinement ``level``, the grid ``(rows, cols, rings)`` and
    the tangent angles per period it interpolated (``gammas``: 1 for an isotropic model)."""

    image: np.ndarray
    nodes: int
    error: float
    level: int
    grid: tuple[int, int, int]
    gammas: int = 1


def split_quadrature(model: BRDF) -> tuple[np.ndarray | None, BRDF | None, BRDF | None]:
    """``model`` as (summed Lambertian albedo, smooth-plastic mirror, rest for the quadrature),
    as :func:`brdfkit.render.reflected_radiance` splits it under an environment map.

    Raises
    ------
    ValueError
        where the rest has delta lobes (the quadrature cannot see them).

    Examples
    --------
    >>> from brdfkit.brdf import parse
    >>> rho, mirror, rest = split_quadrature(parse("lambertian(rho=0.5) + ggx(alpha=0.3)"))
    >>> rho, mirror, type(rest).__name__
    (0.5, None, 'GGXConductor')
    """
    from brdfkit.render.reflection_equation import split_diffuse, split_mirror

    rho, rest = split_diffuse(model)
    mirror, rest = split_mirror(rest)
    # a smooth plastic's base (s = 0) keeps the class's has_delta but has no delta left
    if rest is not None and rest.has_delta and mirror is None:
        raise ValueError(
            f"env_quadrature needs a model without delta lobes (after its exact Lambertian "
            f"and smooth-plastic mirror parts); {type(rest).__name__} has delta lobes"
        )
    return rho, mirror, rest


def _first_level(rest: BRDF) -> int:
    """The coarsest level rendered for ``rest``: :data:`FIRST_LEVEL`, or 0 for a model that
    transmits. A dielectric seen from inside (η < 1) has a kink at the critical angle that the
    grid resolves irregularly: steps of 7.2, 0.69, 0.99 and 0.46 % from level −1 on (rough
    dielectric, η = 0.667, α = 0.3, 96²), so that a rate from levels −1, 0 and 1 claims 0.23 %
    where level 1 is 0.5–1 % off. From level 0 on, level 1 is judged by twice its step."""
    return 0 if rest.transmits else FIRST_LEVEL


def _cell_radiance(env: EnvironmentMap, frame: np.ndarray, rows: int, cols: int) -> np.ndarray:
    """The map averaged (solid-angle weighted, :data:`_SUPERSAMPLE`² points) over each cell of
    the (θ', φ') grid about v, ``(rows, cols, C)``; cached per map, frame and grid."""
    key = (id(env), frame.tobytes(), rows, cols)
    hit = _LV_CACHE.get(key)
    if hit is not None and hit[0] is env:
        return hit[1]
    s = _SUPERSAMPLE
    t = (np.arange(rows * s) + 0.5) * (math.pi / (rows * s))
    p = (np.arange(cols * s) + 0.5) * (2 * math.pi / (cols * s))
    st, ct = np.sin(t)[:, None], np.cos(t)[:, None]
    cos_p, sin_p = np.cos(p), np.sin(p)
    total = np.empty((rows, cols, env.channels))
    band = max(1, _LOOKUP_CHUNK // (cols * s * s))  # rows of cells per band
    for c0 in range(0, rows, band):  # elementwise but for each cell's sum: the same values
        r = slice(c0 * s, (c0 + band) * s)
        local = np.stack(np.broadcast_arrays(st[r] * cos_p, st[r] * sin_p, ct[r]), axis=-1)
        value = env.incident_radiance(np.zeros(3), local @ frame.T) * st[r, :, None]
        total[c0 : c0 + band] = value.reshape(-1, s, cols, s, env.channels).sum(axis=(1, 3))
    weight = np.broadcast_to(st, (rows * s, cols * s))[..., None]
    cell = total / weight.reshape(rows, s, cols, s, 1).sum(axis=(1, 3))
    if len(_LV_CACHE) > 8:
        _LV_CACHE.clear()
    _LV_CACHE[key] = (env, cell)
    return cell


def _rotation_symmetry(model: BRDF) -> tuple[float, bool]:
    """``model``'s period P under a joint turn of wi and wo about the normal that the γ
    samples may span (π where f(R_π wi, R_π wo) = f(wi, wo), else 2π), and whether it is
    mirror symmetric about its tangent (f unchanged with both y negated).

    Checked numerically on fixed random pairs, half of them reflections about half vectors
    close to the normal (tilts 0.003–0.5), where the sharpest lobes are; to a relative
    1e-6. Every anisotropic model of brdfkit passes both (its lobes are aligned with the
    tangent and even in each slope); a tangent field turned against the lobe's axes is what
    fails the mirror test."""
    rng = np.random.default_rng(20240607)
    count = 512

    def upper(v: np.ndarray) -> np.ndarray:
        v = v / np.linalg.norm(v, axis=-1, keepdims=True)
        v[:, 2] = np.abs(v[:, 2]) + 1e-3
        return v / np.linalg.norm(v, axis=-1, keepdims=True)

    wo = upper(rng.normal(size=(count, 3)))
    wi = upper(rng.normal(size=(count, 3)))
    tilt = 10.0 ** rng.uniform(-2.5, -0.3, size=(count // 2, 1))
    h = upper(np.concatenate([rng.normal(size=(count // 2, 2)) * tilt,
                              np.ones((count // 2, 1))], axis=1))  # fmt: skip
    reflected = 2 * np.sum(wo[: count // 2] * h, axis=-1, keepdims=True) * h - wo[: count // 2]
    wi[: count // 2] = upper(reflected)

    def f(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.asarray(model.eval(a, b), dtype=float)

    base = f(wi, wo)
    scale = float(np.max(np.abs(base[np.isfinite(base)]), initial=0.0))

    def same(other: np.ndarray) -> bool:
        return bool(np.allclose(other, base, rtol=1e-6, atol=1e-9 * scale, equal_nan=True))

    turn, flip = np.array([-1.0, -1.0, 1.0]), np.array([1.0, -1.0, 1.0])
    period = math.pi if same(f(wi * turn, wo * turn)) else 2 * math.pi
    return period, same(f(wi * flip, wo * flip))


def _pixel_frames(
    g, frame: np.ndarray, local: np.ndarray, r: np.ndarray, psi: np.ndarray
) -> np.ndarray:
    r"""Each covered pixel's tangent angle γ in the frame of the ring normal rotated by ψ.

    The ring's frame is (tangent :math:`(\cos\theta_o, 0, -\sin\theta_o)`, bitangent y,
    normal :math:`n_0`) in the camera frame; rotated by ψ about v its tangent is
    :math:`t' = (\cos\theta_o\cos\psi, \cos\theta_o\sin\psi, -\sin\theta_o)` and its bitangent
    :math:`b' = (-\sin\psi, \cos\psi, 0)`; the pixel's own tangent (the G-buffer's, which the
    Monte Carlo renderer uses) is :math:`\cos\gamma\,t' + \sin\gamma\,b'`. The sphere's
    tangents along lines of latitude about world +z, :math:`\hat z \times n`, seen by the
    default front view (world +z the camera's y: tangent :math:`\propto (\cos\theta_o, 0,
    -\sin\theta_o\cos\psi)`) give :math:`\gamma = \operatorname{atan2}(-\cos\theta_o\sin\psi,
    \cos\psi)`: −ψ at the centre, 0 or π at the rim, turning fast near the poles.
    """
    tangent = g.tangents[g.mask] @ frame
    cos_o = local[:, 2]
    c, s = np.cos(psi), np.sin(psi)
    along = tangent[:, 0] * cos_o * c + tangent[:, 1] * cos_o * s - tangent[:, 2] * r
    across = -tangent[:, 0] * s + tangent[:, 1] * c
    return np.arctan2(across, along)


def _ring_nodes(
    x: np.ndarray, y: np.ndarray, z: np.ndarray, gammas: list[float], sin_o: float, cos_o: float
) -> tuple[np.ndarray, np.ndarray]:
    """A ring's kernel nodes ``wi`` ``(γ, n, 3)`` at the directions (x, y, z) of its local
    frame, and ``wo`` the same shape, with wi and wo both turned by −γ about the normal per
    tangent angle γ: ``wo`` is a view of one direction per γ (a stride 0 along the nodes)."""
    c = np.array([math.cos(g) for g in gammas])[:, None]
    s = np.array([math.sin(g) for g in gammas])[:, None]
    wi = np.stack([x * c + y * s, y * c - x * s, np.broadcast_to(z, (len(gammas), len(z)))], -1)
    wo = np.stack([-sin_o * c, sin_o * s, np.full_like(c, cos_o)], axis=-1)
    return wi, np.broadcast_to(wo, wi.shape)


def _kernel_values(model: BRDF, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
    """``f(wi, wo) cos θi`` ``(γ, n, C)`` of a ring's nodes ``(γ, n, 3)``
    (:func:`_ring_nodes`), up to :data:`_EVAL_CHUNK` at a time, as whole rows of γ or pieces
    of one (contiguous; elementwise: the same values). ``wo``, one direction per γ, stays a
    view, so that what a model computes per direction
    (:func:`~brdfkit.brdf.base.per_direction`) is made once per γ and chunk, not per node."""
    count, n = wi.shape[:2]
    values = np.empty((count, n, model.channels))
    rows, step = max(1, _EVAL_CHUNK // max(n, 1)), min(n, _EVAL_CHUNK)
    for g0 in range(0, count, rows):
        for c0 in range(0, n, step):
            chunk = slice(g0, g0 + rows), slice(c0, c0 + step)
            f = np.asarray(model.eval(wi[chunk], wo[chunk]), dtype=float)
            values[chunk] = f * wi[chunk][..., 2:3]
    return values


class _Level:
    r"""One refinement level: the (ring, ψ) grids of the tangent angles
    :math:`\gamma_k = kP/` :data:`GAMMA_MAX` computed so far (P the period of
    :func:`_rotation_symmetry`; an isotropic model has only γ = 0), interpolated to the
    pixels, and the images they give.

    A pixel whose tangent is turned by γ from the rotated ring tangent sees the ring's kernel
    with wi and wo both turned by −γ about the normal,
    :math:`K_\gamma(\omega) = f(R_{-\gamma}\omega, R_{-\gamma}v)\max(n_0\cdot\omega, 0)`,
    rotated by ψ: one cross-correlation per γ. A mirror-symmetric model has
    :math:`K_{-\gamma}(\varphi') = K_\gamma(-\varphi')`: the kernel of −γ is that of γ
    reversed (its correlation costs no evaluations), and those of γ ≡ −γ (0 and P/2) are even
    in φ', of which half is evaluated (the isotropic kernel's saving). Each γ's grid is
    interpolated to the pixels' (θo, ψ) by a 4 × 4 cubic stencil (:func:`_cubic_stencil`)
    as soon as it is computed; :meth:`image` interpolates those trigonometrically in γ."""

    def __init__(self, model, env, frame, grid, channels, theta, psi, gamma, period, mirror):
        rows, cols, rings = grid
        self.model, self.channels, self.cols = model, channels, cols
        self.period, self.mirror, self.gamma = period, mirror, gamma
        self.angles = np.linspace(0.0, max(float(theta.max()), 1e-6), rings)
        cell = _cell_radiance(env, frame, rows, cols)
        self.spectrum = np.fft.rfft(np.broadcast_to(cell, (rows, cols, channels)), axis=1)
        t = (np.arange(rows) + 0.5) * (math.pi / rows)
        p = (np.arange(cols) + 0.5) * (2 * math.pi / cols)
        self.d_omega = (
            np.cos(np.arange(rows) * math.pi / rows)
            - np.cos(np.arange(1, rows + 1) * math.pi / rows)
        ) * (2 * math.pi / cols)
        st, ct = np.sin(t)[:, None], np.cos(t)[:, None]
        self.u = np.broadcast_arrays(st * np.cos(p), st * np.sin(p), ct)
        self.stencil = _cubic_stencil(self.angles, cols, theta, psi)
        self.pixels: dict[int, np.ndarray] = {}  # γ index (of GAMMA_MAX) -> (pixels, C)
        self.images: dict[int, np.ndarray] = {}
        self.nodes = 0

    def ensure(self, count: int) -> None:
        """Compute the pixel values of the ``count`` tangent angles kP/count not there yet."""
        step = GAMMA_MAX // count
        wanted = [k for k in range(0, GAMMA_MAX, step) if k not in self.pixels]
        if not wanted:
            return
        if self.mirror:  # one of each pair ±γ is evaluated, the other is its reverse
            own = sorted({min(k, GAMMA_MAX - k) for k in wanted})
            partner = [GAMMA_MAX - k if 0 < k < GAMMA_MAX // 2 else None for k in own]
        else:
            own, partner = wanted, [None] * len(wanted)
        grids = self._ring_grids(own, partner)
        keys = own + [k for k in partner if k is not None]
        # a ring at −θo is the ring at θo turned by π about v, its tangent turned by π: the
        # ghost ring before the first is ring 1 at (ψ + π, γ + π), among the new samples
        turn = round(GAMMA_MAX * math.pi / self.period) % GAMMA_MAX
        where = {k: j for j, k in enumerate(keys)}
        ghost = [where[(k + turn) % GAMMA_MAX] for k in keys]
        first = np.roll(grids[ghost, 1], -(self.cols // 2), axis=1)
        ext = np.concatenate([first[:, None], grids], axis=1)  # (γ, 1 + rings, cols, C)
        ext = ext.transpose(1, 2, 0, 3).reshape(-1, len(keys) * self.channels)
        index, weight = self.stencil
        values = weight[:, :1] * ext[index[:, 0]]
        for j in range(1, index.shape[1]):
            values += weight[:, j : j + 1] * ext[index[:, j]]
        values = values.reshape(len(index), len(keys), self.channels)
        for j, k in enumerate(keys):
            self.pixels[k] = values[:, j]

    def _ring_grids(self, own: list[int], partner: list[int | None]) -> np.ndarray:
        """The (rings, cols, C) grids of the γ indices ``own``, then of each ``partner``
        (−γ, by mirror symmetry), stacked."""
        model, cols = self.model, self.cols
        half = cols // 2
        ux, uy, uz = self.u
        gammas = [k * self.period / GAMMA_MAX for k in own]
        even = [self.mirror and (2 * k) % GAMMA_MAX == 0 for k in own]
        mirrored = [j for j, k in enumerate(partner) if k is not None]
        out = np.empty((len(own) + len(mirrored), len(self.angles), cols, self.channels))
        shift = np.exp(-2j * math.pi * np.arange(half + 1) / cols)[:, None, None]
        for i, a in enumerate(self.angles):
            sin_o, cos_o = math.sin(a), math.cos(a)
            # the ring's local frame: tangent (cos θo, 0, −sin θo), bitangent y, normal n0;
            # only directions above the surface count, and rows past the last one with a
            # node above it are left out of the transforms and of the sum over rows
            z = ux * sin_o + uz * cos_o
            above = z > 0
            live = int(np.flatnonzero(above.any(axis=1))[-1]) + 1 if above.any() else 0
            x, y, z, keep = ux[:live] * cos_o - uz[:live] * sin_o, uy[:live], z[:live], above[:live]
            keep_half = keep.copy()
            keep_half[:, half:] = False
            kernels = np.zeros((len(own), live, cols, model.channels))
            for ev, k in ((False, keep), (True, keep_half)):
                js = [j for j, e in enumerate(even) if e == ev]
                if not js:
                    continue
                wi, wo = _ring_nodes(x[k], y[k], z[k], [gammas[j] for j in js], sin_o, cos_o)
                values = _kernel_values(model, wi, wo)
                self.nodes += values.shape[0] * values.shape[1]
                for v, j in zip(values, js, strict=True):
                    kernels[j][k] = v
                    if ev:
                        kernels[j][:, half:] = kernels[j][:, half - 1 :: -1]
            kernels *= self.d_omega[:live, None, None]
            # per γ the sum over rows of conj(K̂) Ŝ, as products (m, γ, rows) @ (m, rows, C);
            # the reversed kernel's transform is e^{2πim/N} conj(K̂), so −γ's correlation
            # takes e^{−2πim/N} K̂ instead
            spec = np.fft.rfft(kernels, axis=2)  # (γ, live, m, Ck)
            s_live = self.spectrum[:live].transpose(1, 0, 2)  # (m, live, C)
            if model.channels == 1:  # a grey kernel meets every channel of the map
                k_m = spec[..., 0].transpose(2, 0, 1)  # (m, γ, live)
                total = np.matmul(np.conj(k_m), s_live)
                if mirrored:
                    back = np.matmul(k_m[:, mirrored], s_live) * shift
                    total = np.concatenate([total, back], axis=1)
            else:
                k_m = spec.transpose(2, 0, 1, 3)  # (m, γ, live, C)
                total = np.einsum("mgrc,mrc->mgc", np.conj(k_m), s_live)
                if mirrored:
                    back = np.einsum("mgrc,mrc->mgc", k_m[:, mirrored], s_live) * shift
                    total = np.concatenate([total, back], axis=1)
            out[:, i] = np.fft.irfft(total, n=cols, axis=0).transpose(1, 0, 2)
        return out

    def image(self, count: int) -> np.ndarray:
        """Pixel values from the ``count`` tangent angles kP/count, trigonometric in γ."""
        if count not in self.images:
            step = GAMMA_MAX // count
            values = np.stack([self.pixels[k] for k in range(0, GAMMA_MAX, step)], axis=1)
            weights = _trigonometric_weights(self.gamma * (2 * math.pi / self.period), count)
            self.images[count] = np.einsum("pgc,pg->pc", values, weights)
        return self.images[count]


def _trigonometric_weights(beta: np.ndarray, count: int) -> np.ndarray:
    r"""Weights ``(P, count)`` of the trigonometric interpolation of ``count`` (even, or 1)
    samples at :math:`2\pi k/N` at the angles ``beta``: the Dirichlet kernel
    :math:`\sin(N d/2)\cot(d/2)/N` of the offsets d (the interpolant whose Nyquist term is a
    cosine: the real part of the FFT's series)."""
    if count == 1:
        return np.ones((len(beta), 1))
    d = beta[:, None] - np.arange(count) * (2 * math.pi / count)
    t = np.tan(d / 2)
    at_node = np.abs(t) < 1e-12
    return np.where(at_node, 1.0, np.sin(count * d / 2) / (count * np.where(at_node, 1.0, t)))


def _cubic_stencil(
    angles: np.ndarray, cols: int, theta: np.ndarray, psi: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Indices into the flattened (ghost ring at −Δθ, rings …) × cols grid and weights of
    each pixel's 4 × 4 Lagrange cubic stencil in (θo, ψ), ``(P, 16)`` each; one-sided in the
    last ring interval, periodic in ψ. Cubic rather than bilinear: at level 1 (32 tangent
    angles, 48²) the atlas's anisotropic GGX is 0.11 % off level 3 instead of 0.33 %, and
    level 0 is enough for 45 of the atlas's 78 isotropic spheres with a quadrature part."""
    rings = len(angles)
    x = theta / (angles[1] - angles[0])
    start = np.clip(np.floor(x).astype(int) - 1, -1, rings - 4)
    wx = _lagrange4(x - start)
    y = np.remainder(psi, 2 * math.pi) * (cols / (2 * math.pi))
    j0 = np.floor(y).astype(int) - 1
    wy = _lagrange4(y - j0)
    ri = start[:, None] + 1 + np.arange(4)  # + 1: the ghost ring first
    cj = (j0[:, None] + np.arange(4)) % cols
    index = (ri[:, :, None] * cols + cj[:, None, :]).reshape(len(theta), 16)
    weight = (wx[:, :, None] * wy[:, None, :]).reshape(len(theta), 16)
    return index, weight


def _lagrange4(t: np.ndarray) -> np.ndarray:
    """Weights of the cubic through nodes 0, 1, 2, 3 at ``t``, ``(..., 4)``."""
    return np.stack(
        [-(t - 1) * (t - 2) * (t - 3) / 6, t * (t - 2) * (t - 3) / 2,
         -t * (t - 1) * (t - 3) / 2, t * (t - 1) * (t - 2) / 6], axis=-1,
    )  # fmt: skip


def _refine(
    run, rest: BRDF, exact: np.ndarray, interior: np.ndarray, goal: float
) -> tuple[np.ndarray, int, float, int, int]:
    """Levels from :func:`_first_level` on until the estimate meets ``goal``: pixel values,
    nodes spent, estimate, level and tangent angles per period (:func:`quadrature_sphere`).

    At each level the tangent angles double from :data:`GAMMA_START` while the level misses
    the goal and either the grid's estimate is within it (more angles may suffice, at up to
    twice the nodes, where the next level costs eight times) or the interpolation in γ is
    estimated above :data:`GAMMA_SHARE` × goal. That estimate comes from the images of the
    angles, half of them and a quarter (:func:`error_estimate`); the grid's step is measured
    between the two levels' images of the same angles, and the level's estimate is the sum of
    the two parts (an RMSE obeys the triangle inequality)."""

    def relative(a: np.ndarray, b: np.ndarray, total: np.ndarray) -> float:
        diff, ref = (a - b)[interior], total[interior]
        return float(np.sqrt(np.mean(diff * diff) / max(np.mean(ref * ref), 1e-300)))

    spent = 0
    coarse: tuple[_Level, int] | None = None
    previous = None
    for lv in range(_first_level(rest), MAX_LEVEL + 1):
        this = run(lv)
        count = 1 if rest.isotropic else GAMMA_START
        while True:
            this.ensure(count)
            fine = this.image(count)
            total = fine + exact
            e_gamma = 0.0
            if count > 1:
                half, quarter = this.image(count // 2), this.image(count // 4)
                e_gamma = error_estimate(
                    relative(fine, half, total), relative(half, quarter, total)
                )
            step = math.inf
            if coarse is not None:
                common = min(count, coarse[1])
                step = relative(this.image(common), coarse[0].image(common), total)
            grid_error = error_estimate(step, previous)
            error = grid_error + e_gamma
            if error <= goal or count in (1, GAMMA_MAX):
                break
            if grid_error >= goal and e_gamma <= GAMMA_SHARE * goal:
                break  # the grid must be refined first
            count *= 2  # cheaper than the next level (8× the nodes) where the grid may pass
        spent += this.nodes
        if error <= goal:
            break
        coarse, previous = (this, count), (None if coarse is None else step)
    return fine, spent, error, lv, count


def quadrature_sphere(
    model: BRDF,
    env: EnvironmentMap,
    resolution: int = 96,
    *,
    goal: float = GOAL,
    level: int | None = None,
    camera=None,
    gammas: int | None = None,
) -> QuadratureImage:
    """The unit sphere under ``env`` seen by an orthographic ``camera`` (default the front
    view of :func:`brdfkit.render.render_sphere`), shaded by ``model`` without noise; an
    anisotropic model with the sphere's own tangents (along lines of latitude).

    Grid levels −1 (0 for a model that transmits, :func:`_first_level`), 0, 1, …
    (:data:`BASE_GRID` × 2^level) are rendered until the finer image's estimated relative RMSE
    over the sphere's interior (:func:`~brdfkit.render.scene.interior_mask`;
    :func:`error_estimate` from the last two level-to-level steps, plus that of the
    interpolation in γ of an anisotropic model, :func:`_refine`) is at most ``goal``, or
    :data:`MAX_LEVEL`; the finer image is returned. ``level``: render that level only
    (``error`` is then NaN), an anisotropic model with ``gammas`` tangent angles per period
    (1 or an even divisor of :data:`GAMMA_MAX`; default :data:`GAMMA_MAX`).

    Raises
    ------
    ValueError
        for a model :func:`split_quadrature` refuses, a light that is not an
        :class:`~brdfkit.light.EnvironmentMap`, a perspective camera or ``gammas`` that
        are not 1 or an even divisor of :data:`GAMMA_MAX`.

    Examples
    --------
    Under a uniform map of radiance 1/2 each pixel reflects half the directional albedo
    towards the camera, here of a pixel near the centre:

    >>> import numpy as np
    >>> from brdfkit.brdf import parse
    >>> from brdfkit.light import EnvironmentMap
    >>> from brdfkit.render import directional_albedo
    >>> model, env = parse("ggx(alpha=0.3)"), EnvironmentMap(np.full((8, 16, 3), 0.5))
    >>> result = quadrature_sphere(model, env, resolution=8)
    >>> result.image.shape, bool(result.error <= 0.01)
    ((8, 8, 3), True)
    >>> cos = np.sqrt(1 - 2 * 0.125**2)  # pixel (3, 3): its normal's cosine with the view
    >>> wo = np.array([np.sqrt(1 - cos**2), 0.0, cos])
    >>> albedo = directional_albedo(model, wo, method="quadrature").value[0]
    >>> float(abs(result.image[3, 3, 0] / (0.5 * albedo) - 1).round(2))
    0.0
    """
    from brdfkit.render.reflection_equation import _mirror_envmap, local_frames
    from brdfkit.render.scene import Camera, Sphere, gbuffer, interior_mask

    if not isinstance(env, EnvironmentMap):
        raise ValueError(f"env_quadrature needs an EnvironmentMap; got {type(env).__name__}")
    camera = camera or Camera()
    if camera.kind != "orthographic":
        raise ValueError("env_quadrature needs an orthographic camera (one view direction)")
    even_divisor = gammas is not None and gammas > 0 and gammas % 2 == 0 == GAMMA_MAX % gammas
    if gammas is not None and gammas != 1 and not even_divisor:
        raise ValueError(f"gammas must be 1 or an even divisor of {GAMMA_MAX}; got {gammas}")
    rho, mirror, rest = split_quadrature(model)
    g = gbuffer(Sphere(), camera, resolution)
    frame = np.asarray(camera.rotation, dtype=float)  # columns: the camera's x, y and v
    channels = max(model.channels, env.channels)
    normals = g.normals[g.mask]
    local = normals @ frame  # camera-frame normals
    r = np.hypot(local[:, 0], local[:, 1])
    psi = np.arctan2(local[:, 1], local[:, 0])
    exact = np.zeros((len(normals), channels))
    if rho is not None:
        exact += np.asarray(rho, dtype=float) * np.asarray(env.irradiance(normals)) / math.pi
    if mirror is not None:
        _, point, frames, wo_local, _ = local_frames(g.wo[g.mask], normals, g.points[g.mask], None)
        exact += np.asarray(_mirror_envmap(mirror, env, point, frames, wo_local))

    def image_of(values: np.ndarray) -> np.ndarray:
        image = np.zeros((resolution, resolution, channels))
        image[g.mask] = values + exact
        return image

    if rest is None:
        return QuadratureImage(image_of(np.zeros_like(exact)), 0, 0.0, 0, (0, 0, 0))
    theta = np.arcsin(np.minimum(r, 1.0))
    if rest.isotropic:
        period, mirrored, gamma = math.pi, True, np.zeros_like(theta)
    else:
        period, mirrored = _rotation_symmetry(rest)
        gamma = _pixel_frames(g, frame, local, r, psi)

    def run(lv: int) -> _Level:
        return _Level(rest, env, frame, _grid(lv), channels, theta, psi, gamma, period, mirrored)

    if level is not None:
        count = 1 if rest.isotropic else gammas or GAMMA_MAX
        one = run(level)
        one.ensure(count)
        return QuadratureImage(
            image_of(one.image(count)), one.nodes, math.nan, level, _grid(level), count
        )
    interior = interior_mask(resolution)[g.mask]
    values, nodes, error, lv, count = _refine(run, rest, exact, interior, goal)
    return QuadratureImage(image_of(values), nodes, error, lv, _grid(lv), count)


__all__ = [
    "BASE_GRID",
    "FIRST_LEVEL",
    "GAMMA_MAX",
    "GAMMA_SHARE",
    "GAMMA_START",
    "GOAL",
    "MAX_LEVEL",
    "QuadratureImage",
    "error_estimate",
    "quadrature_sphere",
    "split_quadrature",
]
