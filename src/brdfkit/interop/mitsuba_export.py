r"""brdfkit models as Mitsuba 3 BSDFs: a dict for ``mi.load_dict`` and a ``<bsdf>`` XML document.

The one place that knows which Mitsuba 3 plugin, with which options, equals which brdfkit model
(the oracle tests and the benchmarks build their Mitsuba twins here):

==============================================  ==============================================
brdfkit                                         Mitsuba 3
==============================================  ==============================================
:class:`~brdfkit.brdf.Lambertian`               ``diffuse``
:class:`~brdfkit.brdf.RoughConductor`           ``roughconductor`` (``distribution``, ``alpha``
                                                or ``alpha_u``/``alpha_v``, ``eta``/``k``), its
                                                GGX, Beckmann and anisotropic forms
:class:`~brdfkit.brdf.SmoothConductor`          ``conductor``
:class:`~brdfkit.brdf.Mirror`                   ``conductor`` (F = 1 or a conductor Fresnel)
:class:`~brdfkit.brdf.SmoothDielectric`         ``dielectric``
:class:`~brdfkit.brdf.RoughDielectric`          ``roughdielectric``
:class:`~brdfkit.brdf.SmoothPlastic`            ``plastic`` (``nonlinear``)
:class:`~brdfkit.brdf.RoughPlastic`             ``roughplastic``
:class:`~brdfkit.brdf.Principled`               ``principled`` (``specular_tint`` →
                                                ``spec_tint``, ``subsurface`` → ``flatness``)
``a + b + …`` (:class:`~brdfkit.brdf.Sum`)      nested ``blendbsdf``: lobe i drawn with chance
                                                :math:`p_i` and exported times :math:`1/p_i`
``k * a`` (:class:`~brdfkit.brdf.Scaled`)       the lobe's reflectance options times k
==============================================  ==============================================

Conventions. brdfkit's ``eval(wi, wo)`` is :math:`f_r` without the cosine; Mitsuba's
``bsdf.eval(ctx, si, v)`` with ``si.wi`` = brdfkit's ``wo`` (towards the viewer) and ``v`` =
brdfkit's ``wi`` returns :math:`f_r\,|\cos\theta_v|`. Both use the local frame z = normal,
x = tangent (``alpha_u`` along x). Indices are relative: ``int_ior = eta``, ``ext_ior = 1``
(Mitsuba's default exterior is air, 1.000277).

Exact or refused. A model is exported only where the Mitsuba plugin evaluates the same
function; an option Mitsuba cannot express is refused by name — unless ``approximate=True``,
which exports the nearest plugin and lists what differs (:func:`mitsuba_approximations`):
height-correlated Smith masking (Mitsuba evaluates the separable G1·G1), Beckmann's exact G1
(Mitsuba: Walter's rational fit), the plastics' exact internal reflectance (Mitsuba's own
numerics: ``internal="mitsuba"``), Burley's 2012 principled variant. Models without a
counterpart (Phong, Ward, Oren–Nayar, measured tables, …) are refused by name: export them as
a tabulated RGL file (:func:`brdfkit.measured.write_rgl`), which Mitsuba's ``measured`` plugin
reads. Spectral (other than 1 or 3 channels) and spatially varying parameters are refused.

References
----------
.. [1] W. Jakob, S. Speierer, N. Roussel et al., "Mitsuba 3 renderer", 2022,
       https://mitsuba-renderer.org — plugin reference (``diffuse``, ``roughconductor``,
       ``conductor``, ``dielectric``, ``roughdielectric``, ``plastic``, ``roughplastic``,
       ``principled``, ``blendbsdf``) and the scene file format.

Examples
--------
>>> from brdfkit.brdf import Lambertian, RoughConductor
>>> gold = RoughConductor(alpha=0.2, material="Au", masking="smith_separable")
>>> spec = to_mitsuba_dict(Lambertian(0.3) + gold)
>>> spec["type"], spec["weight"], spec["a"]
('blendbsdf', 0.5, {'type': 'diffuse', 'reflectance': 0.6})
>>> print(to_mitsuba_xml(Lambertian([0.2, 0.5, 0.8])), end="")
<bsdf type="diffuse" version="3.0.0">
  <rgb name="reflectance" value="0.2, 0.5, 0.8"/>
</bsdf>
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any
from xml.sax.saxutils import quoteattr

import numpy as np

from brdfkit.brdf import (
    BRDF,
    Lambertian,
    Mirror,
    Principled,
    RoughConductor,
    RoughDielectric,
    RoughPlastic,
    Scaled,
    SmoothConductor,
    SmoothDielectric,
    SmoothPlastic,
    Sum,
)
from brdfkit.errors import ParameterError
from brdfkit.interop._lobes import flattened, values
from brdfkit.io import atomic_write

TOOL = "Mitsuba 3"

PRINCIPLED_NAMES = {
    "base_color": "base_color",
    "metallic": "metallic",
    "roughness": "roughness",
    "anisotropic": "anisotropic",
    "specular": "specular",
    "specular_tint": "spec_tint",
    "sheen": "sheen",
    "sheen_tint": "sheen_tint",
    "clearcoat": "clearcoat",
    "clearcoat_gloss": "clearcoat_gloss",
    "subsurface": "flatness",
}
"""brdfkit's :class:`~brdfkit.brdf.Principled` parameter → Mitsuba's ``principled`` option."""


def to_mitsuba_dict(brdf: BRDF, *, approximate: bool = False) -> dict[str, Any]:
    """The Mitsuba 3 BSDF dict (for ``mi.load_dict``) that evaluates as ``brdf``.

    Values are plain Python: floats, booleans, strings and ``{"type": "rgb", "value": [r, g,
    b]}`` for per-channel parameters; nested BSDFs are nested dicts.

    Parameters
    ----------
    brdf : the model (see the module's table).
    approximate : export the nearest plugin where an option has no exact counterpart
        (otherwise such an option is refused); :func:`mitsuba_approximations` lists them.

    Raises
    ------
    brdfkit.errors.ParameterError
        Naming the model (and option) that has no Mitsuba 3 counterpart.
    """
    return _Exporter(approximate).bsdf(brdf, np.ones(1))


def mitsuba_approximations(brdf: BRDF) -> list[str]:
    """What differs between ``brdf`` and ``to_mitsuba_dict(brdf, approximate=True)``; empty
    when the export is exact.

    Examples
    --------
    >>> from brdfkit.brdf import RoughConductor
    >>> mitsuba_approximations(RoughConductor(alpha=0.3))  # doctest: +ELLIPSIS
    ["RoughConductor masking='smith_correlated': Mitsuba evaluates 'smith_separable' ..."]
    """
    exporter = _Exporter(approximate=True)
    exporter.bsdf(brdf, np.ones(1))
    return list(dict.fromkeys(exporter.notes))


def to_mitsuba_xml(brdf: BRDF, *, approximate: bool = False) -> str:
    """The Mitsuba 3 scene-format ``<bsdf>`` element (for ``mi.load_string`` or a file that
    ``mi.load_file`` reads) of :func:`to_mitsuba_dict`'s BSDF.

    Raises
    ------
    brdfkit.errors.ParameterError
        As :func:`to_mitsuba_dict`.
    """
    spec = to_mitsuba_dict(brdf, approximate=approximate)
    return "\n".join(_xml_lines(spec, name=None, depth=0, version="3.0.0")) + "\n"


def write_mitsuba_xml(brdf: BRDF, path: str | os.PathLike, *, approximate: bool = False) -> Path:
    """Write :func:`to_mitsuba_xml` to ``path`` atomically; returns the path."""
    text = to_mitsuba_xml(brdf, approximate=approximate)
    return atomic_write(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


# --------------------------------------------------------------------------- the correspondence
class _Exporter:
    """Walks a model tree, carrying the scale that sums and products put on each lobe."""

    def __init__(self, approximate: bool) -> None:
        self.approximate = approximate
        self.notes: list[str] = []

    def differs(self, model: BRDF, option: str, value: Any, mitsuba: str) -> None:
        """Refuse (or, approximating, note) an option Mitsuba evaluates differently."""
        note = f"{type(model).__name__} {option}={value!r}: Mitsuba evaluates {mitsuba}"
        if not self.approximate:
            raise ParameterError(
                f"{note}, so no Mitsuba 3 BSDF equals it; build the model with the option "
                "Mitsuba has, or export the nearest with approximate=True (--approximate)"
            )
        self.notes.append(note)

    def bsdf(self, brdf: BRDF, scale: np.ndarray) -> dict[str, Any]:
        for kind, export in _EXPORTERS:
            if type(brdf) is kind or (kind is RoughConductor and isinstance(brdf, kind)):
                return export(self, brdf, scale)
        raise ParameterError(
            f"{type(brdf).__name__} has no Mitsuba 3 counterpart; export it as a tabulated RGL "
            "file (write_rgl, --to rgl), which Mitsuba's 'measured' plugin reads"
        )

    # ------------------------------------------------------------------- composition
    def combination(self, brdf: Sum | Scaled, scale: np.ndarray) -> dict[str, Any]:
        """A sum of (scaled) lobes as a chain of ``blendbsdf``: lobe i drawn with probability
        :math:`p_i` and exported times :math:`1/p_i`. Mitsuba refuses RGB reflectances above 1,
        so each :math:`p_i` is at least the largest RGB reflectance :math:`B_i` of its lobe
        (:math:`p_i = B_i + (1 - \\sum B)/n`); a sum with :math:`\\sum B > 1` is refused."""
        lobes = flattened(brdf, scale, TOOL)
        if len(lobes) == 1:
            return self.bsdf(*lobes[0])
        bounds = np.array([_rgb_bound(self.bsdf(lobe, s)) for lobe, s in lobes])
        if bounds.sum() > 1:
            raise ParameterError(
                f"the lobes' RGB reflectances add to {bounds.sum():.4g} > 1, so no Mitsuba 3 "
                "blendbsdf of its reflectance-bounded plugins equals this sum"
            )
        chances = bounds + (1 - bounds.sum()) / len(lobes)
        return self._blend(
            [(lobe, s / p) for (lobe, s), p in zip(lobes, chances, strict=True)], list(chances)
        )

    def _blend(self, lobes: list[tuple[BRDF, np.ndarray]], chances: list[float]) -> dict:
        """``blendbsdf(weight = 1 − p₀, a = lobe 0, b = the rest)``, the chances renormalised
        (each lobe already carries its 1/p)."""
        if len(lobes) == 1:
            return self.bsdf(*lobes[0])
        rest = 1 - chances[0]
        return {
            "type": "blendbsdf",
            "weight": float(rest),
            "a": self.bsdf(*lobes[0]),
            "b": self._blend(lobes[1:], [p / rest for p in chances[1:]]),
        }

    # ------------------------------------------------------------------- lobes
    def lambertian(self, brdf: Lambertian, scale: np.ndarray) -> dict[str, Any]:
        return {
            "type": "diffuse",
            "reflectance": _texture(values(brdf, "rho", brdf.rho, TOOL) * scale),
        }

    def rough_conductor(self, brdf: RoughConductor, scale: np.ndarray) -> dict[str, Any]:
        spec = {"type": "roughconductor", **self._microfacet(brdf)}
        spec["sample_visible"] = bool(brdf.sample_visible)
        return {**spec, **self._conductor_fresnel(brdf, scale)}

    def delta_reflection(self, brdf: SmoothConductor | Mirror, scale: np.ndarray) -> dict:
        return {"type": "conductor", **self._conductor_fresnel(brdf, scale)}

    def smooth_dielectric(self, brdf: SmoothDielectric, scale: np.ndarray) -> dict[str, Any]:
        return {"type": "dielectric", **_indices(brdf), **_transmittances(scale)}

    def rough_dielectric(self, brdf: RoughDielectric, scale: np.ndarray) -> dict[str, Any]:
        spec = {"type": "roughdielectric", **self._microfacet(brdf), **_indices(brdf)}
        spec["sample_visible"] = bool(brdf.sample_visible)
        return {**spec, **_transmittances(scale)}

    def plastic(self, brdf: SmoothPlastic | RoughPlastic, scale: np.ndarray) -> dict[str, Any]:
        rough = isinstance(brdf, RoughPlastic)
        spec: dict[str, Any] = {"type": "roughplastic" if rough else "plastic"}
        if rough:
            spec.update(self._microfacet(brdf))
        if brdf.internal != "mitsuba":
            self.differs(brdf, "internal", brdf.internal, "its own numerics ('mitsuba')")
        if brdf.nonlinear and not np.all(scale == 1):
            raise ParameterError(
                f"a scaled {type(brdf).__name__} with nonlinear=True has no Mitsuba 3 "
                "counterpart (the internal scattering is not linear in the reflectances)"
            )
        diffuse = values(brdf, "diffuse_reflectance", brdf.diffuse_reflectance, TOOL) * scale
        specular = values(brdf, "specular_reflectance", brdf.specular_reflectance, TOOL) * scale
        return {
            **spec,
            **_indices(brdf),
            "nonlinear": bool(brdf.nonlinear),
            "diffuse_reflectance": _texture(diffuse),
            "specular_reflectance": _texture(specular),
        }

    def principled(self, brdf: Principled, scale: np.ndarray) -> dict[str, Any]:
        if not np.all(scale == 1):
            raise ParameterError(
                "a scaled or summed Principled has no Mitsuba 3 counterpart (its 'principled' "
                "plugin has no overall reflectance option)"
            )
        if brdf.variant != "mitsuba":
            self.differs(brdf, "variant", brdf.variant, "its own variant ('mitsuba')")
        spec: dict[str, Any] = {"type": "principled"}
        for ours, theirs in PRINCIPLED_NAMES.items():
            spec[theirs] = _texture(values(brdf, ours, getattr(brdf, ours), TOOL))
        return spec

    # ------------------------------------------------------------------- shared options
    def _microfacet(self, brdf: RoughConductor | RoughDielectric | RoughPlastic) -> dict:
        """``distribution`` and roughness, after checking the masking and G1 agree."""
        if brdf.masking != "smith_separable":
            self.differs(brdf, "masking", brdf.masking, "'smith_separable' (G1·G1)")
        if brdf.distribution == "beckmann" and not brdf.approximate_g1:
            self.differs(brdf, "approximate_g1", False, "Walter's rational Beckmann G1 (True)")
        spec: dict[str, Any] = {"distribution": brdf.distribution}
        alpha_u, alpha_v = getattr(brdf, "alpha_u", None), getattr(brdf, "alpha_v", None)
        if alpha_u is not None:
            spec["alpha_u"] = _scalar(brdf, "alpha_u", alpha_u)
            spec["alpha_v"] = _scalar(brdf, "alpha_v", alpha_v)
        else:
            spec["alpha"] = _scalar(brdf, "alpha", brdf.alpha)
        return spec

    def _conductor_fresnel(self, brdf: BRDF, scale: np.ndarray) -> dict[str, Any]:
        """``eta``/``k`` (or ``material="none"`` for F = 1) and ``specular_reflectance``."""
        term = brdf.fresnel_term
        reflectance = getattr(brdf, "reflectance", 1.0)
        spec: dict[str, Any] = {}
        if term.kind == "none":
            spec["material"] = "none"
        elif term.kind == "conductor":
            spec["eta"] = _texture(values(brdf, "eta", term.eta, TOOL))
            spec["k"] = _texture(values(brdf, "k", term.k, TOOL))
        else:
            raise ParameterError(
                f"{type(brdf).__name__} with a {term.kind!r} Fresnel term has no Mitsuba 3 "
                "counterpart (its conductors take eta and k)"
            )
        specular = values(brdf, "reflectance", reflectance, TOOL) * scale
        if not np.all(specular == 1):
            spec["specular_reflectance"] = _texture(specular)
        return spec


_EXPORTERS = (
    (Sum, _Exporter.combination),
    (Scaled, _Exporter.combination),
    (Lambertian, _Exporter.lambertian),
    (RoughConductor, _Exporter.rough_conductor),
    (SmoothConductor, _Exporter.delta_reflection),
    (Mirror, _Exporter.delta_reflection),
    (SmoothDielectric, _Exporter.smooth_dielectric),
    (RoughDielectric, _Exporter.rough_dielectric),
    (SmoothPlastic, _Exporter.plastic),
    (RoughPlastic, _Exporter.plastic),
    (Principled, _Exporter.principled),
)
"""Each exported class (``RoughConductor`` with its GGX/Beckmann subclasses) and its method."""


# --------------------------------------------------------------------------- values
BOUNDED = (
    "reflectance",
    "diffuse_reflectance",
    "specular_reflectance",
    "specular_transmittance",
    "base_color",
)
"""Mitsuba options whose RGB values must lie in [0, 1] (its ``SRGBReflectanceSpectrum``)."""


def _rgb_bound(spec: dict[str, Any]) -> float:
    """The largest RGB value among ``spec``'s bounded options (nested BSDFs included)."""
    bound = 0.0
    for key, value in spec.items():
        if isinstance(value, dict) and value.get("type") == "rgb":
            bound = max(bound, max(value["value"]) if key in BOUNDED else 0.0)
        elif isinstance(value, dict):
            bound = max(bound, _rgb_bound(value))
    return bound


def _scalar(model: BRDF, name: str, value: Any) -> float:
    array = values(model, name, value, TOOL)
    if array.size != 1 and not np.all(array == array[0]):
        raise ParameterError(
            f"{type(model).__name__} {name}={array.tolist()}: Mitsuba 3 takes one number"
        )
    return float(array[0])


def _texture(channels: np.ndarray) -> float | dict[str, Any]:
    """A float, or an RGB dict where the channels differ."""
    if channels.size == 1 or np.all(channels == channels[0]):
        return float(channels[0])
    return {"type": "rgb", "value": [float(v) for v in channels]}


def _indices(brdf: SmoothDielectric | RoughDielectric | SmoothPlastic | RoughPlastic) -> dict:
    return {"int_ior": _scalar(brdf, "eta", brdf.eta), "ext_ior": 1.0}


def _transmittances(scale: np.ndarray) -> dict[str, Any]:
    if np.all(scale == 1):
        return {}
    return {"specular_reflectance": _texture(scale), "specular_transmittance": _texture(scale)}


# --------------------------------------------------------------------------- XML
def _xml_lines(spec: dict[str, Any], name: str | None, depth: int, version: str | None) -> list:
    """The XML of one BSDF dict: ``<bsdf type=… name=…>`` with one element per option."""
    pad = "  " * depth
    attributes = f"type={quoteattr(spec['type'])}"
    attributes += f" name={quoteattr(name)}" if name is not None else ""
    attributes += f" version={quoteattr(version)}" if version is not None else ""
    lines = [f"{pad}<bsdf {attributes}>"]
    for key, value in spec.items():
        if key == "type":
            continue
        if isinstance(value, dict) and value.get("type") == "rgb":
            text = ", ".join(repr(v) for v in value["value"])
            lines.append(f'{pad}  <rgb name="{key}" value="{text}"/>')
        elif isinstance(value, dict):
            lines.extend(_xml_lines(value, key, depth + 1, None))
        else:
            lines.append(f"{pad}  {_xml_property(key, value)}")
    lines.append(f"{pad}</bsdf>")
    return lines


def _xml_property(key: str, value: Any) -> str:
    if isinstance(value, bool):
        return f'<boolean name="{key}" value="{"true" if value else "false"}"/>'
    if isinstance(value, str):
        return f'<string name="{key}" value={quoteattr(value)}/>'
    return f'<float name="{key}" value="{float(value)!r}"/>'


__all__ = [
    "PRINCIPLED_NAMES",
    "mitsuba_approximations",
    "to_mitsuba_dict",
    "to_mitsuba_xml",
    "write_mitsuba_xml",
]
