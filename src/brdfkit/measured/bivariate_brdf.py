r"""The bivariate (θh, θd) BRDF of Romeiro, Vasilyev & Zickler (2008): a data-driven isotropic
representation, fitted from scattered measurements with a smoothness prior, per channel.

Romeiro et al. observe that isotropic BRDFs that are also nearly invariant to the half vector's
azimuth around the difference frame depend on two angles only, :math:`f(\theta_h, \theta_d)`
(Rusinkiewicz's half and difference angles). As a table on a (θh, θd) grid, per channel, it
follows a colour that changes with angle (the highlight's hue moving with θd, a goniochromatic
paint) that no single-colour analytic lobe can.

References
----------
.. [1] F. Romeiro, Y. Vasilyev, T. Zickler, "Passive reflectometry", ECCV 2008.
.. [2] S. Rusinkiewicz, "A new change of variables for efficient BRDF representation", EGWR 1998.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from brdfkit._array import Array, asarray, clamp, dot, namespace, normalize
from brdfkit.errors import ParameterError
from brdfkit.measured.tabulated import CosineSampled, MeasuredSamples

HALF_PI = math.pi / 2


def _coordinates(wi: Any, wo: Any, nh: int, nd: int, xp: Any) -> tuple[Array, Array]:
    """Continuous grid coordinates (u, v) ∈ [0, nh−1] × [0, nd−1] of the pairs: θh on MERL's
    square-root warp (dense near the highlight), θd linear."""
    h = normalize(wi + wo)
    theta_h = xp.acos(clamp(h[..., 2], -1.0, 1.0))
    theta_d = xp.acos(clamp(dot(wi, h), -1.0, 1.0))
    u = xp.sqrt(clamp(theta_h / HALF_PI, 0.0, 1.0)) * (nh - 1)
    v = clamp(theta_d / HALF_PI, 0.0, 1.0) * (nd - 1)
    return u, v


def _corners(u: Array, n: int, xp: Any) -> tuple[Array, Array]:
    """Lower node index (integer) and the fraction towards the next, along one axis."""
    i0 = xp.clip(xp.floor(u), 0.0, float(n - 2))
    return xp.astype(i0, xp.int64), u - i0


@dataclass(frozen=True, eq=False)
class Bivariate(CosineSampled):
    r"""An isotropic BRDF tabulated over (θh, θd), bilinearly interpolated, per channel.

    .. math::

        f_r(\omega_i, \omega_o) = \sum_{jk} T_{jk}\,\Lambda_j(\sqrt{\theta_h/(\pi/2)})\,
        \Lambda_k(\theta_d/(\pi/2))

    with hat functions Λ on ``nh`` nodes in :math:`\sqrt{\theta_h/(\pi/2)}` and ``nd`` nodes
    in :math:`\theta_d/(\pi/2)`. **Reciprocal**: yes (θh and θd are symmetric in ωi, ωo).
    **Isotropic**: yes. **Energy**: not claimed (measured data). Sampled cosine-weighted.

    Parameters
    ----------
    table : ``(nh, nd, C)`` non-negative BRDF values (sr⁻¹), ``nh, nd ≥ 2``.
    name : a label.

    References
    ----------
    .. [1] F. Romeiro, Y. Vasilyev, T. Zickler, "Passive reflectometry", ECCV 2008.

    Examples
    --------
    >>> import numpy as np
    >>> flat = Bivariate(np.full((2, 2, 1), 0.1))
    >>> flat.channels, flat.eval(np.array([0.6, 0.0, 0.8]), np.array([0.0, 0.6, 0.8])).tolist()
    (1, [0.1])
    """

    table: Any
    name: str = "bivariate"

    reciprocal = True

    def __post_init__(self) -> None:
        table = np.asarray(self.table, dtype=np.float64)
        if table.ndim != 3 or min(table.shape[:2]) < 2 or not np.all(np.isfinite(table)):
            raise ParameterError(
                f"table must be a finite (nh, nd, C) array with nh, nd ≥ 2; got shape {table.shape}"
            )
        if np.any(table < 0):
            raise ParameterError("table must be non-negative (BRDF values in sr⁻¹)")
        object.__setattr__(self, "table", table)
        object.__setattr__(self, "channels", table.shape[2])

    def eval(self, wi: Array, wo: Array) -> Array:
        xp = namespace(wi, wo)
        nh, nd, c = self.table.shape
        u, v = _coordinates(wi, wo, nh, nd, xp)
        i, s = _corners(u, nh, xp)
        j, t = _corners(v, nd, xp)
        flat = asarray(self.table.reshape(nh * nd, c), xp, like=wi)
        shape = i.shape

        def at(di: int, dj: int) -> Array:
            index = xp.reshape((i + di) * nd + (j + dj), (-1,))
            return xp.reshape(xp.take(flat, index, axis=0), (*shape, c))

        s, t = s[..., None], t[..., None]
        value = (1 - s) * ((1 - t) * at(0, 0) + t * at(0, 1)) + s * (
            (1 - t) * at(1, 0) + t * at(1, 1)
        )
        upper = (wi[..., 2:3] > 0) & (wo[..., 2:3] > 0)
        return xp.where(upper, value, xp.zeros_like(value))

    def to_spec(self) -> str:
        raise ValueError("a Bivariate table has no spec-string form")

    def __repr__(self) -> str:
        nh, nd, c = self.table.shape
        return f"Bivariate({self.name!r}, {nh}×{nd}×{c})"


def _design(data: MeasuredSamples, nh: int, nd: int) -> Any:
    """The sparse (N, nh·nd) matrix of bilinear weights of each measurement's (θh, θd)."""
    from scipy.sparse import csr_matrix

    u, v = _coordinates(data.wi, data.wo, nh, nd, np)
    i, s = _corners(u, nh, np)
    j, t = _corners(v, nd, np)
    rows = np.repeat(np.arange(len(u)), 4)
    cols = np.stack([i * nd + j, i * nd + j + 1, (i + 1) * nd + j, (i + 1) * nd + j + 1], -1)
    weights = np.stack([(1 - s) * (1 - t), (1 - s) * t, s * (1 - t), s * t], -1)
    return csr_matrix((weights.ravel(), (rows, cols.ravel())), shape=(len(u), nh * nd))


def _second_differences(nh: int, nd: int) -> Any:
    """Second differences of the grid along θh and along θd, stacked (the smoothness prior)."""
    from scipy.sparse import diags, identity, kron, vstack

    def d2(n: int) -> Any:
        return diags([1.0, -2.0, 1.0], [0, 1, 2], shape=(n - 2, n))

    return vstack([kron(d2(nh), identity(nd)), kron(identity(nh), d2(nd))])


def fit_bivariate(
    data: MeasuredSamples,
    nh: int = 32,
    nd: int = 16,
    smoothness: float = 1e-3,
    name: str | None = None,
) -> Bivariate:
    r"""Fit a :class:`Bivariate` table to scattered measurements, per channel.

    Minimises :math:`\sum_n w_n^2(\hat f(\omega_{i,n},\omega_{o,n}) - f_n)^2 +
    \lambda\lVert\Delta^2 T\rVert^2` per channel: a linear least-squares problem in the table
    (bilinear weights), with the second differences Δ² along both axes as the smoothness prior
    (it fills cells no measurement reaches), :math:`\lambda` = ``smoothness`` times the mean
    diagonal of the data term, and weights :math:`w_n = \cos\theta_i/(f_n\cos\theta_i + \tau)`
    (relative errors of the reflected radiance above τ, a tenth of its mean: a dark diffuse
    floor counts as much as the highlight). Negative table values are clipped to 0.

    Raises
    ------
    brdfkit.errors.ParameterError
        On a grid smaller than 3 × 3 or a negative ``smoothness``.

    References
    ----------
    .. [1] F. Romeiro, Y. Vasilyev, T. Zickler, ECCV 2008, §3–4.

    Examples
    --------
    Samples of a Lambertian surface give a flat table at ρ/π:

    >>> import numpy as np
    >>> from brdfkit.brdf import Lambertian
    >>> from brdfkit.measured import MeasuredSamples
    >>> from brdfkit.sampling import hemisphere_pairs
    >>> wi, wo = hemisphere_pairs(500)
    >>> fitted = fit_bivariate(MeasuredSamples(wi, wo, Lambertian(rho=0.5).eval(wi, wo)), 8, 8)
    >>> fitted.table.shape, float((fitted.table * np.pi).min().round(4))
    ((8, 8, 1), 0.5)
    >>> float((fitted.table * np.pi).max().round(4))
    0.5
    """
    from scipy.sparse import diags
    from scipy.sparse.linalg import spsolve

    if nh < 3 or nd < 3:
        raise ParameterError(f"nh and nd must be ≥ 3; got {nh}, {nd}")
    if not smoothness >= 0:
        raise ParameterError(f"smoothness must be ≥ 0; got {smoothness!r}")
    a = _design(data, nh, nd)
    prior = _second_differences(nh, nd)
    penalty = (prior.T @ prior).tocsc()
    cos_i = data.wi[:, 2:3]
    radiance = data.values * cos_i
    tau = 0.1 * np.mean(radiance, axis=0)
    table = np.empty((nh * nd, data.values.shape[1]))
    for k in range(data.values.shape[1]):
        w = (cos_i[:, 0] / (radiance[:, k] + tau[k] + 1e-300)) ** 2
        normal = (a.T @ diags(w) @ a).tocsc()
        scale = normal.diagonal().mean()
        lhs = normal + smoothness * scale * penalty + 1e-9 * scale * diags(np.ones(nh * nd))
        table[:, k] = spsolve(lhs.tocsc(), a.T @ (w * data.values[:, k]))
    return Bivariate(np.maximum(table, 0).reshape(nh, nd, -1), name=name or data.name)


__all__ = ["Bivariate", "fit_bivariate"]
