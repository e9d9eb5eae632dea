r"""The Ashikhmin–Shirley (2000) anisotropic Phong BRDF: a normalised anisotropic half-vector
lobe with Schlick's Fresnel factor, a coupled (non-Lambertian) diffuse term, and the paper's
half-vector sampler."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from brdfkit._array import Array, dot, namespace, normalize, safe_sqrt, to_numpy
from brdfkit.brdf.base import ALBEDO, BRDF, EXPONENT, register
from brdfkit.brdf.microfacet import IOR, FresnelTerm
from brdfkit.brdf.phong import (
    Component,
    MixtureSampled,
    channel_mean,
    cosine_power,
    diffuse_and_lobe,
    reflect_about,
    reflected_pdf,
)
from brdfkit.params import Domain, param

_DIFFUSE_NORMALIZATION = 28 / (23 * math.pi)
"""28/(23π): makes ∫(1 − (1 − cos θi/2)⁵) cos θi dωi · 28/(23π) = 1 (the integral is 23π/28)."""


def ashikhmin_shirley_exponent(h: Array, nu: Array, nv: Array) -> Array:
    r"""The lobe's exponent :math:`n_u\cos^2\varphi_h + n_v\sin^2\varphi_h =
    (n_u h_x^2 + n_v h_y^2)/(h_x^2 + h_y^2)`, ``(..., C)`` for unit ``h`` (..., 3).

    At h = n (φh undefined) it is (nu + nv)/2, where it does not matter: cos θh = 1.

    References
    ----------
    .. [1] M. Ashikhmin, P. Shirley, "An anisotropic Phong BRDF model", JGT 5(2), 2000, eq. 4.
    """
    xp = namespace(h, nu, nv)
    hx2, hy2 = h[..., 0:1] ** 2, h[..., 1:2] ** 2
    sin2 = hx2 + hy2
    positive = sin2 > 0
    safe = xp.where(positive, sin2, xp.ones_like(sin2))
    value = (nu * hx2 + nv * hy2) / safe
    return xp.where(positive, value, (nu + nv) / 2 + xp.zeros_like(value))


def ashikhmin_shirley_half_vector_pdf(h: Array, nu: Array, nv: Array) -> Array:
    r"""Density of the paper's half vectors, :math:`p(h) = \frac{\sqrt{(n_u+1)(n_v+1)}}{2\pi}
    (\mathbf n\cdot h)^{n_u\cos^2\varphi_h + n_v\sin^2\varphi_h}` (``nu``, ``nv`` of shape
    ``(...,)``; 0 below the surface). It integrates to 1 over the hemisphere exactly.

    References
    ----------
    .. [1] M. Ashikhmin, P. Shirley, JGT 5(2), 2000, §3 (eq. 9).
    """
    xp = namespace(h, nu, nv)
    exponent = ashikhmin_shirley_exponent(h, nu[..., None], nv[..., None])
    value = cosine_power(h[..., 2:3], exponent)[..., 0]
    return xp.sqrt((nu + 1) * (nv + 1)) / (2 * math.pi) * value


def sample_ashikhmin_shirley_half_vector(nu: Array, nv: Array, u: Array) -> Array:
    r"""Half vectors with density :func:`ashikhmin_shirley_half_vector_pdf` (the paper's eq. 9).

    :math:`\varphi_h = \arctan\bigl(\sqrt{(n_u+1)/(n_v+1)}\tan(2\pi u_1)\bigr)` in the quadrant
    of :math:`2\pi u_1` (written with ``atan2``), and :math:`\cos\theta_h =
    (1-u_2)^{1/(n_u\cos^2\varphi_h + n_v\sin^2\varphi_h + 1)}`.

    References
    ----------
    .. [1] M. Ashikhmin, P. Shirley, JGT 5(2), 2000, §3.
    """
    xp = namespace(nu, nv, u)
    two_pi_u = 2 * math.pi * u[..., 0]
    phi = xp.atan2(xp.sqrt(nu + 1) * xp.sin(two_pi_u), xp.sqrt(nv + 1) * xp.cos(two_pi_u))
    cos_phi, sin_phi = xp.cos(phi), xp.sin(phi)
    exponent = nu * cos_phi**2 + nv * sin_phi**2
    # 1 − u2 ∈ (0, 1] keeps cos θh > 0.
    cos_theta = (1 - u[..., 1]) ** (1 / (exponent + 1))
    sin_theta = safe_sqrt(1 - cos_theta * cos_theta)
    return xp.stack([sin_theta * cos_phi, sin_theta * sin_phi, cos_theta], axis=-1)


def ashikhmin_shirley_diffuse(
    cos_theta_i: Array, cos_theta_o: Array, rd: Array, rs: Array
) -> Array:
    r"""The coupled diffuse term :math:`\frac{28R_d}{23\pi}(1-R_s)
    (1-(1-\frac{\cos\theta_i}{2})^5)(1-(1-\frac{\cos\theta_o}{2})^5)`.

    Its albedo at ωo is exactly :math:`R_d(1-R_s)(1-(1-\cos\theta_o/2)^5)`.

    References
    ----------
    .. [1] M. Ashikhmin, P. Shirley, JGT 5(2), 2000, eq. 5.
    """
    return (
        _DIFFUSE_NORMALIZATION
        * rd
        * (1 - rs)
        * (1 - (1 - cos_theta_i / 2) ** 5)
        * (1 - (1 - cos_theta_o / 2) ** 5)
    )


@register("ashikhmin_shirley")
@dataclass(frozen=True, eq=False)
class AshikhminShirley(MixtureSampled):
    r"""Ashikhmin & Shirley's anisotropic Phong BRDF (2000): specular lobe plus coupled diffuse.

    .. math::

        f_r = \frac{\sqrt{(n_u+1)(n_v+1)}}{8\pi}
              \frac{(\mathbf n\cdot h)^{n_u\cos^2\varphi_h + n_v\sin^2\varphi_h}}
                   {(h\cdot k)\max(\cos\theta_i, \cos\theta_o)} F(h\cdot k)
            + \frac{28R_d}{23\pi}(1-R_s)\Bigl(1-\bigl(1-\tfrac{\cos\theta_i}{2}\bigr)^5\Bigr)
              \Bigl(1-\bigl(1-\tfrac{\cos\theta_o}{2}\bigr)^5\Bigr)

    with h the half vector, k = ωi (or ωo: h·ωi = h·ωo), φh its azimuth from the tangent x, and
    Schlick's :math:`F(c) = R_s + (1-R_s)(1-c)^5`.

    **Reciprocal**: yes (every factor is symmetric in ωi, ωo). **Energy-conserving** for
    R_d, R_s ∈ [0, 1], by the paper's construction: the specular lobe's sample weight is
    F·cos θi/max(cos θi, cos θo) ≤ F (its half-vector density is normalised exactly), and the
    diffuse term's albedo, R_d(1 − R_s)(1 − (1 − cos θo/2)⁵), fills at most what Schlick's F
    leaves; measured ≤ 1 over a sweep of exponents, R_s and θo in the tests. **Isotropic**
    when ``nv`` is omitted or equal to ``nu``.

    Sampling: the paper's half vectors (:func:`sample_ashikhmin_shirley_half_vector`),
    reflected about h (density p(h)/(4 ωo·h)), mixed with the cosine-weighted hemisphere for the
    diffuse term, chosen ∝ the channel means of Schlick's F at θo and of the diffuse albedo at
    θo; channel-varying exponents are sampled with their channel means.

    With ``eta`` given, F is instead the exact dielectric Fresnel reflectance of relative index
    η (Low et al. 2012's variant, written in Cook & Torrance's form), and R_s only couples the
    diffuse term; that variant is not claimed energy-conserving (measured, not proven).

    Parameters
    ----------
    rd : diffuse reflectance R_d ∈ [0, 1].
    rs : specular reflectance at normal incidence R_s ∈ [0, 1].
    nu : exponent n_u ∈ [0, 10⁶] along the tangent x.
    nv : exponent n_v ∈ [0, 10⁶] along y; ``None`` means n_v = n_u (isotropic).
    eta : ``None`` (Schlick's F with R_s, the paper) or a relative index of refraction
        η ∈ [0.01, 100] for the exact dielectric F.

    References
    ----------
    .. [1] M. Ashikhmin, P. Shirley, "An anisotropic Phong BRDF model", Journal of Graphics
           Tools 5(2), 25–32, 2000.
    .. [2] C. Schlick, "An inexpensive BRDF model for physically-based rendering", Computer
           Graphics Forum 13(3), 1994.
    .. [3] J. Löw, J. Kronander, A. Ynnerman, J. Unger, "BRDF models for accurate and
           efficient rendering of glossy surfaces", ACM TOG 31(1), 2012.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import AshikhminShirley
    >>> f = AshikhminShirley(rd=0.5, rs=0.05, nu=10.0)
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.1819])
    >>> np.allclose(f.eval(wi, wo), f.eval(wo, wi))
    True
    """

    rd: Any = 0.5
    rs: Any = 0.05
    nu: Any = 100.0
    nv: Any = None
    eta: Any = None

    domains: ClassVar[dict[str, Domain]] = {
        "rd": ALBEDO,
        "rs": ALBEDO,
        "nu": EXPONENT,
        "nv": EXPONENT,
        "eta": IOR,
    }

    @property
    def energy_conserving(self) -> bool:  # type: ignore[override]
        return self.eta is None

    def _fresnel(self) -> FresnelTerm:
        """Schlick's F with R_s, or the exact dielectric F of index η when ``eta`` is given."""
        if self.eta is None:
            return FresnelTerm("schlick", f0=self.rs)
        return FresnelTerm("dielectric", eta=self.eta)

    @property
    def _nv(self) -> Any:
        return self.nu if self.nv is None else self.nv

    @property
    def isotropic(self) -> bool:  # type: ignore[override]
        return self.nv is None or bool(np.array_equal(to_numpy(self.nu), to_numpy(self.nv)))

    def params(self) -> dict[str, Any]:
        """The parameters, without ``nv`` and ``eta`` when they are ``None``."""
        params = super().params()
        for name in ("nv", "eta"):
            if params[name] is None:
                del params[name]
        return params

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [
            cls(0.5, 0.05, 10.0),
            cls(0.0, 1.0, 1000.0),
            cls(0.8, 0.2, 1.0),
            cls(0.3, 0.1, 10.0, 1000.0),
            cls([0.6, 0.3, 0.1], [0.05, 0.1, 0.2], [20.0, 40.0, 80.0], 5.0),
            cls(0.0, 0.0, 300.0, eta=1.45),
        ]

    def specular(self, wi: Array, wo: Array) -> Array:
        """The specular lobe alone (its first term), ``(..., C)``; valid above the surface."""
        xp = namespace(wi, wo)
        nu, nv = param(self.nu, wi), param(self._nv, wi)
        h = normalize(wi + wo)
        k_dot_h = dot(wi, h, keepdims=True)
        cos_max = xp.maximum(wi[..., 2:3], wo[..., 2:3])
        denominator = k_dot_h * cos_max
        positive = denominator > 0
        safe = xp.where(positive, denominator, xp.ones_like(denominator))
        lobe = cosine_power(h[..., 2:3], ashikhmin_shirley_exponent(h, nu, nv))
        fresnel = self._fresnel()(k_dot_h)
        value = xp.sqrt((nu + 1) * (nv + 1)) / (8 * math.pi) * lobe * fresnel / safe
        return xp.where(positive, value, xp.zeros_like(value))

    def _eval(self, wi: Array, wo: Array) -> Array:
        rd, rs = param(self.rd, wi), param(self.rs, wi)
        diffuse = ashikhmin_shirley_diffuse(wi[..., 2:3], wo[..., 2:3], rd, rs)
        return diffuse + self.specular(wi, wo)

    def _weights(self, wo: Array) -> tuple[Array, Array]:
        """Channel means of the diffuse albedo and of Schlick's F at θo, ``(...,)``."""
        xp = namespace(wo)
        rd, rs = param(self.rd, wo), param(self.rs, wo)
        cos_o = xp.clip(wo[..., 2:3], 0.0, 1.0)
        diffuse = rd * (1 - rs) * (1 - (1 - cos_o / 2) ** 5)
        specular = self._fresnel()(cos_o)
        return channel_mean(diffuse), channel_mean(specular)

    def components(self, wo: Array) -> list[Component]:
        def lobe_pdf(wi: Array, nu: Array, nv: Array) -> Array:
            return reflected_pdf(wi, wo, lambda h: ashikhmin_shirley_half_vector_pdf(h, nu, nv))

        def lobe_sample(u: Array, nu: Array, nv: Array) -> Array:
            return reflect_about(wo, sample_ashikhmin_shirley_half_vector(nu, nv, u))

        diffuse, specular = self._weights(wo)
        return diffuse_and_lobe(wo, diffuse, specular, (self.nu, self._nv), lobe_pdf, lobe_sample)

    def _sampling_weight(self, wo: Array) -> Array:
        diffuse, specular = self._weights(wo)
        return diffuse + specular


__all__ = ["AshikhminShirley"]
