r"""The Lafortune et al. (1997) model: a diffuse term plus generalised cosine lobes."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from brdfkit._array import Array, dot, namespace, normalize, to_numpy
from brdfkit.brdf.base import (
    ALBEDO,
    BRDF,
    EXPONENT,
    normalized_weights,
    register,
)
from brdfkit.brdf.phong import (
    Component,
    MixtureSampled,
    channel_mean,
    cosine_component,
    cosine_lobe_pdf,
    cosine_power,
    sample_cosine_lobe,
)
from brdfkit.errors import ParameterError
from brdfkit.params import Domain, param

_LOBE_PARAMS = ("cx", "cy", "cz", "n")

COEFFICIENT = Domain(-100.0, 100.0, hint="lobe coefficient")
"""The lobe coefficients C_x, C_y, C_z: [−100, 100]."""

PEAK_MAX = 1e12
"""The largest lobe peak ``max(|C_x|, |C_y|, |C_z|)ⁿ`` allowed, in sr⁻¹: far above any measured
highlight, and far from overflow in float32."""


def _lobe(value: Any, k: int, like: Array) -> Array:
    """Lobe ``k`` of a lobe-indexed parameter, as an array broadcasting against batch + (C,)."""
    xp = namespace(like, value)
    arr = param(value, like)[k]
    return xp.reshape(arr, (1,)) if arr.ndim == 0 else arr


@register("lafortune")
@dataclass(frozen=True, eq=False)
class Lafortune(MixtureSampled):
    r"""Generalised cosine lobes (Lafortune, Foo, Torrance & Greenberg 1997).

    .. math::

        f_r(\omega_i, \omega_o) = \frac{\rho_d}{\pi} + \sum_k
        \bigl[C_{x,k}\,\omega_{i,x}\omega_{o,x} + C_{y,k}\,\omega_{i,y}\omega_{o,y}
        + C_{z,k}\,\omega_{i,z}\omega_{o,z}\bigr]^{n_k}

    (a lobe is 0 where its bracket is ≤ 0). C_x = C_y < 0 < C_z gives a Phong lobe about the
    mirror direction (C_x = C_y = −1, C_z = 1 is exactly cosⁿ of the angle to reflect(ωo));
    C_x = C_y > 0 gives retro-reflection; ``|C_z| < |C_x|`` moves the peak towards grazing
    (off-specular reflection); C_x ≠ C_y makes the lobe **anisotropic**; C_x = C_y = 0
    gives a non-Lambertian diffuse lobe. **Reciprocal**: yes (the bracket is symmetric in
    ωi, ωo). **Not energy-conserving** in general: the coefficients are free fit parameters;
    a lobe's albedo is at most ``|C∘ωo|ⁿ·2π/(n+1)`` (measured per example in the tests).

    Sampling: lobe k equals :math:`\lVert C_k\circ\omega_o\rVert^{n_k}\cos^{n_k}\beta` with β
    the angle between ωi and the axis :math:`a_k = C_k\circ\omega_o/\lVert C_k\circ\omega_o
    \rVert`, so it is sampled exactly by the cosⁿ lobe about a_k, mixed with the cosine-weighted
    hemisphere (for ρd); the mixture picks lobe k with probability ∝
    :math:`\lVert C_k\circ\omega_o\rVert^{n_k}\,2\pi/(n_k+2)` (its albedo when a_k is the
    normal) and the diffuse term ∝ ρd. Channel-varying C or n are sampled with their channel
    means.

    Parameters
    ----------
    kd : diffuse albedo ρd ∈ [0, 1] (broadcast against ``batch + (C,)``).
    cx, cy, cz : lobe coefficients in [−100, 100]; the **first axis indexes the lobe**
        (``cx=[-1.0]`` is one lobe, ``cx=[-1.0, 0.5]`` two); each ``cx[k]`` broadcasts against
        ``batch + (C,)`` (per channel or per pixel).
    n : lobe exponents n_k ∈ [0, 10⁶], same first axis. Each lobe's peak
        ``max(|C_x|, |C_y|, |C_z|)ⁿ`` must be at most 10¹² sr⁻¹ (:data:`PEAK_MAX`).

    References
    ----------
    .. [1] E. P. F. Lafortune, S.-C. Foo, K. E. Torrance, D. P. Greenberg, "Non-linear
           approximation of reflectance functions", SIGGRAPH 1997, 117–126.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import Lafortune
    >>> f = Lafortune(kd=0.3, cx=[-1.0], cy=[-1.0], cz=[1.0], n=[20.0])
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.3199])
    >>> np.allclose(f.eval(wi, wo), f.eval(wo, wi))
    True
    """

    energy_conserving = False

    kd: Any = 0.3
    cx: Any = (-1.0,)
    cy: Any = (-1.0,)
    cz: Any = (1.0,)
    n: Any = (20.0,)
    domains: ClassVar[dict[str, Domain]] = {
        "kd": ALBEDO,
        "cx": COEFFICIENT,
        "cy": COEFFICIENT,
        "cz": COEFFICIENT,
        "n": EXPONENT,
    }

    def __post_init__(self) -> None:
        super().__post_init__()
        self._check_peaks()

    def _channel_values(self) -> dict[str, Any]:
        """ρd and each lobe's coefficients and exponent (the lobe axis, first, must be shared)."""
        lobes = {}
        for name in _LOBE_PARAMS:
            shape = np.shape(to_numpy(getattr(self, name)))
            if len(shape) == 0:
                raise ParameterError(
                    f"{name} must have a leading lobe axis of length ≥ 1 (e.g. {name}=[1.0]); "
                    f"got shape {shape}"
                )
            lobes[name] = shape[0]
        if len(set(lobes.values())) > 1:
            raise ParameterError(
                f"cx, cy, cz and n must have the same number of lobes; got {lobes}"
            )
        values = {"kd": self.kd}
        for name in _LOBE_PARAMS:
            for k, v in enumerate(to_numpy(getattr(self, name))):
                values[f"{name}[{k}]"] = v
        return values

    def _check_peaks(self) -> None:
        """Raise unless every lobe's peak ``max(|C_x|, |C_y|, |C_z|)ⁿ`` is at most
        :data:`PEAK_MAX`."""
        c = [
            np.abs(to_numpy(getattr(self, name)).astype(np.float64)) for name in ("cx", "cy", "cz")
        ]
        n = to_numpy(self.n).astype(np.float64)
        for k in range(n.shape[0]):
            largest = np.maximum(np.maximum(c[0][k], c[1][k]), c[2][k])
            with np.errstate(divide="ignore", invalid="ignore"):
                log_peak = np.where(n[k] > 0, n[k] * np.log(largest), 0.0)
            if np.any(log_peak > np.log(PEAK_MAX)):
                raise ParameterError(
                    f"n must keep lobe {k}'s peak max(|cx|, |cy|, |cz|)^n at most {PEAK_MAX:g} "
                    f"sr⁻¹; got {np.max(largest):g}^{np.max(n[k]):g}"
                )

    @property
    def lobe_count(self) -> int:
        """The number of cosine lobes K."""
        return int(np.shape(to_numpy(self.n))[0])

    @property
    def isotropic(self) -> bool:  # type: ignore[override]
        return bool(np.array_equal(to_numpy(self.cx), to_numpy(self.cy)))

    @classmethod
    def examples(cls) -> list[BRDF]:
        # Mirror lobe scaled to the modified Phong lobe ρs (n+2)/(2π) cosⁿα with ρs = 0.5, n = 20.
        c = (0.5 * 22 / (2 * math.pi)) ** (1 / 20)
        return [
            cls(0.5, [-c], [-c], [c], [20.0]),
            cls(0.2, [-1.0], [-1.0], [0.8], [15.0]),  # off-specular
            cls(0.3, [0.9], [0.9], [0.9], [10.0]),  # retro-reflection
            cls(0.1, [-1.1], [-0.6], [1.0], [10.0]),  # anisotropic
            cls([0.2, 0.15, 0.1], [-1.0, 0.0], [-1.0, 0.0], [1.0, 0.6], [40.0, 2.0]),  # two lobes
        ]

    def _lobes(self, like: Array) -> list[tuple[Array, Array, Array, Array]]:
        return [
            tuple(_lobe(getattr(self, name), k, like) for name in _LOBE_PARAMS)
            for k in range(self.lobe_count)
        ]

    def _eval(self, wi: Array, wo: Array) -> Array:
        value = param(self.kd, wi) / math.pi
        product = wi * wo
        for cx, cy, cz, n in self._lobes(wi):
            bracket = cx * product[..., 0:1] + cy * product[..., 1:2] + cz * product[..., 2:3]
            value = value + cosine_power(bracket, n)
        return value

    def _lobe_terms(self, wo: Array) -> list[tuple[Array, Array, Array]]:
        """Per lobe: (weight (...,), axis (..., 3), n̄ (...,)) for sampling at ``wo``."""
        xp = namespace(wo)
        batch = wo.shape[:-1]
        terms = []
        for cx, cy, cz, n in self._lobes(wo):
            scaled = [cx * wo[..., 0:1], cy * wo[..., 1:2], cz * wo[..., 2:3]]
            length = xp.sqrt(scaled[0] ** 2 + scaled[1] ** 2 + scaled[2] ** 2)  # (..., C)
            n_bar = xp.broadcast_to(channel_mean(n), batch)
            weight = channel_mean(length**n) * 2 * math.pi / (n_bar + 2)
            axis = normalize(xp.stack([channel_mean(s) for s in scaled], axis=-1))
            terms.append((xp.broadcast_to(weight, batch), axis, n_bar))
        return terms

    def components(self, wo: Array) -> list[Component]:
        xp = namespace(wo)
        terms = self._lobe_terms(wo)
        diffuse = xp.broadcast_to(channel_mean(param(self.kd, wo)), wo.shape[:-1])
        probabilities = normalized_weights([diffuse, *(weight for weight, _, _ in terms)])
        components = [cosine_component(probabilities[0])]
        for p, (_, axis, n_bar) in zip(probabilities[1:], terms, strict=True):
            components.append(
                (
                    p,
                    lambda wi, axis=axis, n_bar=n_bar: cosine_lobe_pdf(dot(wi, axis), n_bar),
                    lambda u, axis=axis, n_bar=n_bar: sample_cosine_lobe(axis, n_bar, u),
                )
            )
        return components

    def _sampling_weight(self, wo: Array) -> Array:
        xp = namespace(wo)
        total = xp.broadcast_to(channel_mean(param(self.kd, wo)), wo.shape[:-1])
        for weight, _, _ in self._lobe_terms(wo):
            total = total + weight
        return total


__all__ = ["Lafortune"]
