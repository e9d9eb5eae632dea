r"""Physics checks of reflectance models: reciprocity, energy, isotropy, sampling, microfacets.

Each ``check_*`` function measures one property numerically and returns a :class:`CheckResult`
(the statistic, the tolerance it was held to, whether it passed, and what the model claims).
:func:`check` runs them all and returns a :class:`PhysicsReport` that sets each measurement
against the model's claims (:attr:`BRDF.reciprocal`, :attr:`BRDF.energy_conserving`,
:attr:`BRDF.isotropic`): the original Phong model is reported "not reciprocal (as it claims)",
and only a measurement that *contradicts* a claim makes the report inconsistent.

The properties (Nicodemus et al. 1977; Veach 1997, ch. 6):

* Helmholtz reciprocity: :math:`f_r(\omega_i, \omega_o) = f_r(\omega_o, \omega_i)`.
* Energy conservation: the directional albedo
  :math:`\rho(\omega_o) = \int_{H^2} f_r(\omega_i, \omega_o) \cos\theta_i \, d\omega_i \le 1`.
* Isotropy: :math:`f_r(R_z\omega_i, R_z\omega_o) = f_r(\omega_i, \omega_o)` for every rotation
  :math:`R_z` about the normal.
* Non-negativity: :math:`f_r \ge 0` (and 0 below the horizon for a BRDF).
* Sampling: ``weight`` = ``f·|cos θi|/pdf``, and a χ² goodness-of-fit test of ``sample`` against
  ``pdf``.
* Microfacet distributions: the projected area of the microfacets is the macro-surface's,
  :math:`\int D(\omega_m) \cos\theta_m \, d\omega_m = 1`, and the weak white furnace
  :math:`\int G_1(\omega_o, \omega_m) D(\omega_m) \langle\omega_o, \omega_m\rangle^+ d\omega_m
  = \cos\theta_o` (Heitz 2014, eq. 2 and §4).

References
----------
.. [1] F. E. Nicodemus et al., "Geometrical considerations and nomenclature for reflectance",
       NBS Monograph 160, 1977.
.. [2] E. Veach, "Robust Monte Carlo methods for light transport simulation", PhD thesis,
       Stanford, 1997, ch. 6 (reciprocity, adjoint BSDFs) and ch. 9 (multiple importance
       sampling).
.. [3] E. Heitz, "Understanding the masking-shadowing function in microfacet-based BRDFs",
       JCGT 3(2), 2014.
.. [4] R. R. Lewis, "Making shaders more physically plausible", Computer Graphics Forum 13(2),
       1994.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from brdfkit._array import Array, to_numpy
from brdfkit.brdf.base import BRDF, Sample, Scaled, Sum
from brdfkit.brdf.microfacet import MicrofacetDistribution
from brdfkit.geometry import cartesian_to_spherical, spherical_to_cartesian
from brdfkit.sampling import hemisphere_pairs, square_to_uniform_sphere

_ADJECTIVE = {
    "non-negativity": "non-negative",
    "reciprocity": "reciprocal",
    "energy": "energy-conserving",
    "isotropy": "isotropic",
    "sampling": "consistently sampled",
    "normalization": "normalized",
    "white furnace": "passes the white furnace",
}


# --------------------------------------------------------------------------- results
@dataclass(frozen=True)
class CheckResult:
    """The outcome of one physics check.

    Attributes
    ----------
    name : the property ("reciprocity", "energy", ...).
    passed : whether the measurement satisfies the property within ``tolerance``.
    value : the measured statistic (a relative error, a maximum albedo, ...).
    tolerance : the bound ``value`` was held to.
    detail : a human-readable account (where the worst case was reached, sample counts).
    claimed : what the model claims about this property (``None`` when it claims nothing).
    """

    name: str
    passed: bool
    value: float
    tolerance: float
    detail: str
    claimed: bool | None = None

    @property
    def contradicts_claim(self) -> bool:
        """Whether the measurement refutes the model's claim (claimed, yet failed)."""
        return self.claimed is True and not self.passed

    @property
    def verdict(self) -> str:
        """A short sentence: e.g. "not reciprocal (as it claims)"."""
        adjective = _ADJECTIVE.get(self.name, self.name)
        outcome = adjective if self.passed else f"not {adjective}"
        if self.claimed is None:
            return outcome
        if self.passed == self.claimed:
            return f"{outcome} (as claimed)" if self.passed else f"{outcome} (as it claims)"
        if self.passed:
            return f"{outcome} (not claimed)"
        return f"{outcome}: CONTRADICTS its claim"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (non-finite values become ``None``)."""
        return {
            "name": self.name,
            "passed": self.passed,
            "claimed": self.claimed,
            "contradicts_claim": self.contradicts_claim,
            "verdict": self.verdict,
            "value": _json_float(self.value),
            "tolerance": _json_float(self.tolerance),
            "detail": self.detail,
        }


@dataclass(frozen=True)
class PhysicsReport:
    """All physics checks of one model, set against its claims.

    Attributes
    ----------
    model : the model's spec string (:meth:`BRDF.to_spec`) or class name.
    claims : the model's claims (``reciprocal``, ``energy_conserving``, ``isotropic``, …).
    results : one :class:`CheckResult` per check, in the order run.
    """

    model: str
    claims: dict[str, bool]
    results: tuple[CheckResult, ...] = field(default_factory=tuple)

    @property
    def contradictions(self) -> list[CheckResult]:
        """The checks whose measurement refutes a claim of the model."""
        return [r for r in self.results if r.contradicts_claim]

    @property
    def consistent(self) -> bool:
        """Whether no measurement contradicts a claim."""
        return not self.contradictions

    def __getitem__(self, name: str) -> CheckResult:
        """The result of the check called ``name``."""
        for result in self.results:
            if result.name == name:
                return result
        known = ", ".join(r.name for r in self.results)
        raise KeyError(f"no check named {name!r} in this report; it has: {known}")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form of the report."""
        return {
            "model": self.model,
            "claims": dict(self.claims),
            "consistent": self.consistent,
            "checks": [r.to_dict() for r in self.results],
        }

    def to_table(self) -> Any:
        """A :class:`rich.table.Table` of the checks (green: as claimed, red: contradiction)."""
        from rich.table import Table
        from rich.text import Text

        table = Table(title=f"physics of {self.model}", title_justify="left")
        table.add_column("check")
        table.add_column("verdict")
        table.add_column("value", justify="right")
        table.add_column("tolerance", justify="right")
        table.add_column("detail", overflow="fold")
        for r in self.results:
            if r.contradicts_claim:
                style = "bold red"
            elif r.passed:
                style = "green"
            else:
                style = "yellow"
            table.add_row(
                r.name, Text(r.verdict, style), f"{r.value:.3g}", f"{r.tolerance:.3g}", r.detail
            )
        return table


def _json_float(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _model_name(brdf: BRDF) -> str:
    try:
        return brdf.to_spec()
    except ValueError:  # spatially varying parameters have no spec form
        return type(brdf).__name__


def _degrees(w: np.ndarray) -> float:
    """Polar angle of direction ``w`` in degrees (for details)."""
    return math.degrees(math.acos(float(np.clip(w[2], -1.0, 1.0))))


def _eval(brdf: BRDF, wi: Array, wo: Array) -> np.ndarray:
    return to_numpy(brdf.eval(wi, wo)).astype(np.float64)


def _worst_difference(f: np.ndarray, g: np.ndarray) -> tuple[float, int]:
    """``(max |f − g| / max(|f|, |g|), pair index)`` over ``(n, C)`` values (unscaled if all 0)."""
    scale = max(np.max(np.abs(f)), np.max(np.abs(g)))
    error = np.max(np.abs(f - g), axis=-1)
    k = int(np.argmax(error))
    return (float(error[k] / scale) if scale > 0 else float(error[k])), k


# --------------------------------------------------------------------------- BRDF checks
def check_reciprocity(
    brdf: BRDF, n: int = 4096, seed: int = 0, tolerance: float = 1e-6
) -> CheckResult:
    r"""Helmholtz reciprocity over ``n`` random pairs of upper-hemisphere directions.

    The statistic is :math:`\max |f(\omega_i, \omega_o) - f(\omega_o, \omega_i)| / \max f`
    over the pairs and channels; the check passes when it is ≤ ``tolerance``.

    References
    ----------
    .. [1] E. Veach, PhD thesis, Stanford, 1997, §6.2.
    .. [2] F. E. Nicodemus et al., NBS Monograph 160, 1977.

    Examples
    --------
    The original Phong model is not reciprocal, and says so:

    >>> from brdfkit.brdf import parse
    >>> check_reciprocity(parse("lambertian(rho=0.5)")).verdict
    'reciprocal (as claimed)'
    >>> result = check_reciprocity(parse("phong"))
    >>> result.passed, result.claimed, result.verdict
    (False, False, 'not reciprocal (as it claims)')
    """
    wi, wo = hemisphere_pairs(n, seed)
    value, k = _worst_difference(_eval(brdf, wi, wo), _eval(brdf, wo, wi))
    detail = (
        f"max |f(wi,wo) − f(wo,wi)| / max f over {n} pairs, worst at θi = "
        f"{_degrees(wi[k]):.1f}°, θo = {_degrees(wo[k]):.1f}°"
    )
    return CheckResult(
        "reciprocity", value <= tolerance, value, tolerance, detail, bool(brdf.reciprocal)
    )


def check_isotropy(
    brdf: BRDF, n: int = 4096, seed: int = 0, tolerance: float = 1e-6
) -> CheckResult:
    r"""Invariance under a random rotation :math:`R_z(\psi)` of both directions about the normal.

    The statistic is :math:`\max |f(R\omega_i, R\omega_o) - f(\omega_i, \omega_o)| / \max f`
    over ``n`` random pairs, each with its own angle ψ ∈ [0, 2π).

    References
    ----------
    .. [1] F. E. Nicodemus et al., NBS Monograph 160, 1977.

    Examples
    --------
    >>> from brdfkit.brdf import parse
    >>> check_isotropy(parse("ggx(alpha=0.3)")).verdict
    'isotropic (as claimed)'
    >>> check_isotropy(parse("ggx(alpha_u=0.1, alpha_v=0.4)")).verdict
    'not isotropic (as it claims)'
    """
    wi, wo = hemisphere_pairs(n, seed)
    psi = np.random.default_rng(seed + 1).uniform(0.0, 2 * math.pi, n)
    theta_i, phi_i = cartesian_to_spherical(wi)
    theta_o, phi_o = cartesian_to_spherical(wo)
    wi_r = spherical_to_cartesian(theta_i, phi_i + psi)
    wo_r = spherical_to_cartesian(theta_o, phi_o + psi)
    value, k = _worst_difference(_eval(brdf, wi, wo), _eval(brdf, wi_r, wo_r))
    detail = (
        f"max |f(Rwi,Rwo) − f(wi,wo)| / max f over {n} rotated pairs, worst at ψ = "
        f"{math.degrees(psi[k]):.1f}°"
    )
    return CheckResult(
        "isotropy", value <= tolerance, value, tolerance, detail, bool(brdf.isotropic)
    )


def check_nonnegativity(brdf: BRDF, n: int = 4096, seed: int = 0) -> CheckResult:
    r"""``eval`` and ``pdf`` finite and ≥ 0 on the whole sphere; ``eval`` = 0 below the horizon.

    Directions are drawn uniformly on the sphere, so a quarter of the pairs have both above
    the surface. For a model that does not transmit, :math:`f_r = 0` whenever
    :math:`\cos\theta_i \le 0` or :math:`\cos\theta_o \le 0`. The statistic is the most negative
    value found (0 when none is); any non-finite value or non-zero value below the horizon fails.

    References
    ----------
    .. [1] F. E. Nicodemus et al., NBS Monograph 160, 1977.

    Examples
    --------
    >>> from brdfkit.brdf import parse
    >>> result = check_nonnegativity(parse("ggx(alpha=0.3)"))
    >>> result.passed, result.detail
    (True, '4096 pairs on the sphere: all f, pdf ≥ 0')
    """
    rng = np.random.default_rng(seed)
    u = rng.random((2, n, 2))
    wi, wo = square_to_uniform_sphere(u[0]), square_to_uniform_sphere(u[1])
    f = _eval(brdf, wi, wo)
    pdf = to_numpy(brdf.pdf(wi, wo)).astype(np.float64)
    problems = []
    if not np.all(np.isfinite(f)):
        problems.append(f"{int(np.sum(~np.isfinite(f)))} non-finite values of f")
    if not np.all(np.isfinite(pdf)):
        problems.append(f"{int(np.sum(~np.isfinite(pdf)))} non-finite pdf values")
    if np.any(pdf < 0):
        problems.append(f"pdf down to {np.min(pdf):.3g}")
    below = (wi[:, 2] <= 0) | (wo[:, 2] <= 0)
    if not brdf.transmits and np.any(f[below] != 0):
        problems.append(
            f"{int(np.sum(np.any(f[below] != 0, axis=-1)))} non-zero values below the horizon"
        )
    value = min(float(np.nanmin(f)), 0.0) if np.any(np.isfinite(f)) else math.nan
    if value < 0:
        problems.append(f"f down to {value:.3g}")
    detail = f"{n} pairs on the sphere: " + ("; ".join(problems) if problems else "all f, pdf ≥ 0")
    return CheckResult("non-negativity", not problems, value, 0.0, detail, True)


def check_energy(
    brdf: BRDF,
    n_wo: int = 16,
    samples: int = 4096,
    seed: int = 0,
    tolerance: float = 1e-3,
    z: float = 3.0,
) -> CheckResult:
    r"""Energy conservation: the directional albedo ρ(θo) ≤ 1 over a sweep of θo.

    ρ(ωo) is estimated by :meth:`BRDF.albedo_estimate` (exact where a model knows its closed
    form) at ``n_wo`` view directions with θo evenly spread over [0°, 89°] and azimuths on a
    golden-angle spiral (so anisotropic models are probed too). For a BSDF that transmits
    (``brdf.transmits``) ρ is the total, reflectance plus transmittance
    (``hemisphere="both"``), measured in importance (flux) mode: in radiance mode a refracted
    sample carries the factor η², a change of solid angle, not of energy (Veach 1997 §5.2),
    so lobes with a ``mode`` parameter are switched to ``"importance"``. The check fails only on a
    significant violation: it passes iff
    :math:`\max_{\theta_o, c} (\hat\rho - z\,\hat\sigma) \le 1 + \text{tolerance}`,
    with :math:`\hat\sigma` the Monte Carlo standard error. The reported value is the largest
    estimate :math:`\max\hat\rho`, with its θo and standard error in the detail.

    References
    ----------
    .. [1] F. E. Nicodemus et al., NBS Monograph 160, 1977.
    .. [2] R. R. Lewis, "Making shaders more physically plausible", CGF 13(2), 1994.
    .. [3] E. Veach, PhD thesis, Stanford, 1997, §5.2 (non-symmetric scattering at refraction).

    Examples
    --------
    A rough metal with F = 1 loses energy to single scattering, but never gains any:

    >>> from brdfkit.brdf import parse
    >>> result = check_energy(parse("ggx(alpha=0.3)"), n_wo=4, samples=1024)
    >>> result.verdict, bool(0.9 < result.value < 1)
    ('energy-conserving (as claimed)', True)
    """
    theta_o = np.linspace(0.0, math.radians(89.0), n_wo)
    phi_o = np.arange(n_wo) * math.pi * (3.0 - math.sqrt(5.0))
    wo = spherical_to_cartesian(theta_o, phi_o)
    if brdf.transmits:
        measured = "reflectance + transmittance (importance mode)"
        mean, stderr = _importance_mode(brdf).albedo_estimate(
            wo, samples=samples, seed=seed, hemisphere="both"
        )
    else:
        measured = "albedo"
        mean, stderr = brdf.albedo_estimate(wo, samples=samples, seed=seed)
    mean = to_numpy(mean).astype(np.float64)
    stderr = to_numpy(stderr).astype(np.float64)
    lower = mean - z * stderr
    k, c = np.unravel_index(int(np.argmax(mean)), mean.shape)
    value = float(mean[k, c])
    passed = bool(np.all(np.isfinite(mean))) and float(np.max(lower)) <= 1.0 + tolerance
    detail = (
        f"max {measured} {value:.4f} ± {stderr[k, c]:.1e} (1σ) at θo = "
        f"{math.degrees(theta_o[k]):.1f}°"
        f" over {n_wo} directions × {samples} samples; fails only above 1 + tolerance by > "
        f"{z:g}σ"
    )
    return CheckResult("energy", passed, value, tolerance, detail, bool(brdf.energy_conserving))


def _importance_mode(brdf: BRDF) -> BRDF:
    """``brdf`` with every lobe that has a transport ``mode`` parameter in ``"importance"`` mode.

    References
    ----------
    .. [1] E. Veach, PhD thesis, Stanford, 1997, §5.2.
    """
    if isinstance(brdf, Sum):
        return Sum(tuple(_importance_mode(lobe) for lobe in brdf.lobes))
    if isinstance(brdf, Scaled):
        return Scaled(brdf.k, _importance_mode(brdf.inner))
    if getattr(brdf, "mode", None) == "radiance" and "mode" in brdf.params():
        return dataclasses.replace(brdf, mode="importance")
    return brdf


def check_sampling(
    brdf: BRDF,
    theta_o: tuple[float, ...] = (0.3, 1.0, 1.4),
    samples: int = 100_000,
    seed: int = 0,
    rtol: float = 1e-5,
    significance: float = 1e-3,
) -> CheckResult:
    r"""Consistency of :meth:`BRDF.sample` with :meth:`BRDF.eval` and :meth:`BRDF.pdf`.

    For each view direction at polar angle ``theta_o`` (radians), ``samples`` draws (3 uniforms
    each) must have unit ``wi`` and, for every non-delta sample with pdf > 0,
    :math:`\text{weight} = f(\omega_i, \omega_o)|\cos\theta_i| / p(\omega_i)` and
    ``Sample.pdf`` = ``pdf(wi, wo)`` to relative error ``rtol``; failed samples (pdf = 0, not
    delta) must have zero weight. For models without delta lobes the same draws go through
    Pearson's χ² goodness-of-fit test against ``pdf`` (:func:`brdfkit.checks.chi2_test`, on
    the upper hemisphere, or the sphere for a BSDF) at level ``significance``, Šidák-corrected
    over the view directions. The value is the largest relative error found.

    References
    ----------
    .. [1] E. Veach, PhD thesis, Stanford, 1997, ch. 9.
    .. [2] W. Jakob et al., Mitsuba 3, ``mitsuba/python/chi2.py`` (``ChiSquareTest``), 2022.

    Examples
    --------
    >>> from brdfkit.brdf import parse
    >>> check_sampling(parse("ggx(alpha=0.3)"), samples=20_000).verdict
    'consistently sampled (as claimed)'
    """
    from brdfkit.checks.chi2 import brdf_sampler, chi2_test

    worst, problems, p_values = 0.0, [], []
    for k, theta in enumerate(theta_o):
        wo = spherical_to_cartesian(np.array(theta), np.array(0.7))
        drawn: list[Sample] = []
        sample_fn, pdf_fn = brdf_sampler(brdf, wo, record=drawn)

        where = f"θo = {math.degrees(theta):.0f}°"
        if brdf.has_delta:
            u = np.random.default_rng(seed + k).random((samples, 3))
            sample_fn(u)
        else:
            result = chi2_test(
                sample_fn,
                pdf_fn,
                sphere=bool(brdf.transmits),
                n_samples=samples,
                sample_dim=3,
                significance=significance,
                test_count=len(theta_o),
                seed=seed + k,
                max_depth=_CHI2_DEPTH,
            )
            p_values.append(result.p_value)
            if not result.passed:
                messages = "".join(f"; {m}" for m in result.messages)
                problems.append(
                    f"{where}: χ² rejects sample against pdf (p = {result.p_value:.2g}{messages})"
                )
        worst = max(worst, _check_draws(brdf, wo, drawn[0], rtol, where, problems))
    chi2 = (
        "χ² skipped (delta lobes)"
        if brdf.has_delta
        else f"χ² p-values {', '.join(f'{p:.2g}' for p in p_values)}"
    )
    detail = f"{len(theta_o)} view directions × {samples} samples; {chi2}"
    if problems:
        detail += "; " + "; ".join(problems)
    return CheckResult("sampling", not problems, worst, rtol, detail, True)


_CHI2_DEPTH = 5
"""Subdivision levels of the χ² test's cell quadrature: its error stays ~1e-5 of a cell's
probability, far below the sampling noise of 1e5 samples, at a fraction of the default's cost."""


def _check_draws(
    brdf: BRDF, wo: np.ndarray, s: Sample, rtol: float, where: str, problems: list[str]
) -> float:
    """Pointwise checks of one batch of samples; returns the largest relative error."""
    wi = to_numpy(s.wi).astype(np.float64)
    weight = to_numpy(s.weight).astype(np.float64)
    s_pdf = to_numpy(s.pdf).astype(np.float64)
    delta = to_numpy(s.delta).astype(bool)
    smooth = (s_pdf > 0) & ~delta
    failed = (s_pdf <= 0) & ~delta
    length_error = np.abs(np.linalg.norm(wi[smooth | delta], axis=-1) - 1.0)
    if length_error.size and np.max(length_error) > rtol:
        problems.append(f"{where}: |wi| − 1 up to {np.max(length_error):.2g}")
    if not np.all(np.isfinite(weight)) or np.any(weight < 0):
        problems.append(f"{where}: weights not finite and ≥ 0")
    if np.any(weight[failed] != 0):
        problems.append(f"{where}: failed samples (pdf = 0) with non-zero weight")
    if not np.any(smooth):
        return 0.0
    wi_s = wi[smooth]
    wo_s = np.broadcast_to(wo, wi_s.shape)
    f = _eval(brdf, wi_s, wo_s)
    pdf = to_numpy(brdf.pdf(wi_s, wo_s)).astype(np.float64)
    with np.errstate(over="ignore", invalid="ignore"):  # a denormal pdf is reported, not warned
        expected = f * (np.abs(wi_s[:, 2]) / s_pdf[smooth])[:, None]
        weight_error = _relative_error(weight[smooth], expected)
        pdf_error = _relative_error(s_pdf[smooth], pdf)
    if weight_error > rtol:
        problems.append(f"{where}: weight ≠ f·|cos θi|/pdf (rel. error {weight_error:.2g})")
    if pdf_error > rtol:
        problems.append(f"{where}: Sample.pdf ≠ pdf(wi, wo) (rel. error {pdf_error:.2g})")
    return max(weight_error, pdf_error)


def _relative_error(actual: np.ndarray, expected: np.ndarray) -> float:
    """max |actual − expected| / |expected| (with |expected| floored at 1e-300)."""
    if actual.size == 0:
        return 0.0
    error = np.abs(actual - expected) / np.maximum(np.abs(expected), 1e-300)
    return float(np.max(np.where(actual == expected, 0.0, error)))


# --------------------------------------------------------------------------- microfacets
_PHI_NODES = 512
_THETA_BREAKS = (0.0, 1e-3, 1e-2, 0.1, 0.5, 1.0, math.pi / 2)
_THETA_NODES = 96


@functools.cache
def _hemisphere_nodes() -> tuple[np.ndarray, np.ndarray]:
    """The nodes ``m`` ``(T·P, 3)`` (read-only) and θ weights ``(T,)`` of
    :func:`_hemisphere_integral`'s rule, made once per process: every microfacet check of
    every model integrates over the same 295 k directions."""
    x, w = np.polynomial.legendre.leggauss(_THETA_NODES)
    lo, hi = np.array(_THETA_BREAKS[:-1])[:, None], np.array(_THETA_BREAKS[1:])[:, None]
    theta = (lo + (hi - lo) * (x + 1) / 2).ravel()
    theta_weight = ((hi - lo) / 2 * w).ravel() * np.sin(theta)
    phi = np.arange(_PHI_NODES) * (2 * math.pi / _PHI_NODES)
    m = spherical_to_cartesian(theta[:, None], phi[None, :]).reshape(-1, 3)
    m.flags.writeable = False
    theta_weight.flags.writeable = False
    return m, theta_weight


def _hemisphere_integral(integrand: Callable[[np.ndarray], Array]) -> np.ndarray:
    r"""∫ over the upper hemisphere of ``integrand(m)`` (``(n, 3)`` → ``(n,)`` or ``(n, C)``).

    Composite Gauss–Legendre in θ (``_THETA_NODES`` nodes on each interval between break points
    that resolve peaks down to 1e-3 rad wide at the pole) times the periodic trapezoid rule in
    φ (spectrally accurate for smooth periodic integrands), with the Jacobian sin θ; one
    vectorised call of ``integrand`` on the nodes of :func:`_hemisphere_nodes`.
    """
    m, theta_weight = _hemisphere_nodes()
    values = _field(integrand(m)).reshape(theta_weight.size, _PHI_NODES, -1)
    return np.einsum("t,tpc->c", theta_weight, values) * (2 * math.pi / _PHI_NODES)


def check_normalization(
    distribution: MicrofacetDistribution, tolerance: float = 1e-6
) -> CheckResult:
    r"""Projected-area normalization of a microfacet distribution:
    :math:`\int_{H^2} D(\omega_m) \cos\theta_m \, d\omega_m = 1`.

    The value is the largest absolute deviation from 1 (over channels), computed by quadrature.

    References
    ----------
    .. [1] E. Heitz, "Understanding the masking-shadowing function in microfacet-based BRDFs",
           JCGT 3(2), 2014, eq. 4.
    .. [2] B. Walter et al., "Microfacet models for refraction through rough surfaces",
           EGSR 2007, eq. 4.

    Examples
    --------
    >>> from brdfkit.brdf import parse
    >>> result = check_normalization(parse("ggx(alpha=0.3)").ndf)
    >>> result.passed, result.value < 1e-12
    (True, True)
    """
    integral = _hemisphere_integral(lambda m: _field(distribution.D(m)) * m[:, 2:3])
    value = float(np.max(np.abs(integral - 1.0)))
    detail = f"∫ D cos θm dωm = {_show_values(integral)} (quadrature)"
    return CheckResult("normalization", value <= tolerance, value, tolerance, detail, True)


def check_white_furnace(
    distribution: MicrofacetDistribution,
    theta_o: tuple[float, ...] = (0.0, 0.5, 1.0, 1.3, 1.5),
    tolerance: float = 1e-5,
) -> CheckResult:
    r"""The weak white furnace test of a microfacet distribution and its Smith masking:
    :math:`\int_{H^2} G_1(\omega_o, \omega_m) D(\omega_m) \langle\omega_o, \omega_m\rangle^+
    \, d\omega_m = \cos\theta_o` (the visible projected area is the macro-surface's).

    Evaluated by quadrature at the polar angles ``theta_o`` (radians); the value is the largest
    relative deviation :math:`|I/\cos\theta_o - 1|` over angles and channels.

    References
    ----------
    .. [1] E. Heitz, "Understanding the masking-shadowing function in microfacet-based BRDFs",
           JCGT 3(2), 2014, eq. 2 and §4 (the weak white furnace test).

    Examples
    --------
    >>> from brdfkit.brdf import parse
    >>> check_white_furnace(parse("beckmann(alpha=0.5)").ndf).verdict
    'passes the white furnace (as claimed)'
    """
    errors = []
    # D on the nodes _hemisphere_integral hands the integrand, the same for every θo
    density = _field(distribution.D(_hemisphere_nodes()[0]))
    for theta in theta_o:
        wo = spherical_to_cartesian(np.array(theta), np.array(0.3))

        def integrand(m: np.ndarray, wo: np.ndarray = wo) -> np.ndarray:
            projected = np.maximum(m @ wo, 0.0)[:, None]
            # wo as (1, 3): a masking term that depends on wo alone is computed once
            return _field(distribution.G1(wo[None, :], m)) * density * projected

        integral = _hemisphere_integral(integrand)
        errors.append(np.max(np.abs(integral / math.cos(theta) - 1.0)))
    k = int(np.argmax(errors))
    value = float(errors[k])
    detail = (
        f"max |∫ G1 D ⟨wo, wm⟩⁺ dωm / cos θo − 1| over θo = "
        f"{', '.join(f'{math.degrees(t):.0f}°' for t in theta_o)}; worst at "
        f"{math.degrees(theta_o[k]):.0f}°"
    )
    return CheckResult("white furnace", value <= tolerance, value, tolerance, detail, True)


def _field(values: Array) -> np.ndarray:
    """A per-direction value as NumPy ``(n, C)`` (``(n,)`` becomes ``(n, 1)``)."""
    values = to_numpy(values).astype(np.float64)
    return values[:, None] if values.ndim == 1 else values


def _show_values(values: np.ndarray) -> str:
    return ", ".join(f"{v:.6f}" for v in np.ravel(values))


# --------------------------------------------------------------------------- all checks
def check(
    brdf: BRDF, seed: int = 0, progress: Callable[[str], None] | None = None
) -> PhysicsReport:
    """Run every physics check on ``brdf`` and set the measurements against its claims.

    Runs :func:`check_nonnegativity`, :func:`check_reciprocity`, :func:`check_energy`,
    :func:`check_isotropy`, :func:`check_sampling`, and for a microfacet model (one whose
    ``ndf`` attribute is a :class:`~brdfkit.brdf.microfacet.MicrofacetDistribution`)
    :func:`check_normalization` and :func:`check_white_furnace`. ``progress`` is called with
    each check's name before it runs.

    Returns
    -------
    PhysicsReport
        Consistent unless a measurement contradicts a claim.

    References
    ----------
    .. [1] F. E. Nicodemus et al., NBS Monograph 160, 1977.
    .. [2] E. Veach, PhD thesis, Stanford, 1997, ch. 6 and 9.
    .. [3] E. Heitz, JCGT 3(2), 2014.

    Examples
    --------
    >>> from brdfkit.brdf import Lambertian
    >>> report = check(Lambertian(rho=0.5))
    >>> report.consistent, report["energy"].verdict
    (True, 'energy-conserving (as claimed)')
    >>> [result.name for result in report.results]
    ['non-negativity', 'reciprocity', 'energy', 'isotropy', 'sampling']
    """
    checks: list[tuple[str, Callable[[], CheckResult]]] = [
        ("non-negativity", lambda: check_nonnegativity(brdf, seed=seed)),
        ("reciprocity", lambda: check_reciprocity(brdf, seed=seed)),
        ("energy", lambda: check_energy(brdf, seed=seed)),
        ("isotropy", lambda: check_isotropy(brdf, seed=seed)),
        ("sampling", lambda: check_sampling(brdf, seed=seed)),
    ]
    distribution = getattr(brdf, "ndf", None)
    if isinstance(distribution, MicrofacetDistribution):
        checks += [
            ("normalization", lambda: check_normalization(distribution)),
            ("white furnace", lambda: check_white_furnace(distribution)),
        ]
    results = []
    for name, run in checks:
        if progress is not None:
            progress(name)
        results.append(run())
    claims = {
        claim: bool(getattr(brdf, claim))
        for claim in ("reciprocal", "energy_conserving", "isotropic", "has_delta", "transmits")
    }
    return PhysicsReport(_model_name(brdf), claims, tuple(results))


__all__ = [
    "CheckResult",
    "PhysicsReport",
    "check",
    "check_energy",
    "check_isotropy",
    "check_nonnegativity",
    "check_normalization",
    "check_reciprocity",
    "check_sampling",
    "check_white_furnace",
]
