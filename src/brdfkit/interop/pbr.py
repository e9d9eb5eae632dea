r"""brdfkit models as the metallic-roughness material that glTF 2.0, MaterialX (OpenPBR) and USD
(UsdPreviewSurface) share: one conversion, three writers.

The target is the glTF 2.0 BRDF (Khronos, Appendix B): GGX with height-correlated Smith
masking, roughness :math:`r` with :math:`\alpha = r^2`, Schlick's Fresnel from
:math:`F_0`; a metal (``metallic`` = 1) reflects :math:`F_0` = ``base_color``; a dielectric
mixes a Lambertian ``base_color`` under a specular layer,
:math:`f = F\,f_{spec} + (1 - F)\,f_{diffuse}`, with
:math:`F_0 = ((\eta - 1)/(\eta + 1))^2 \cdot` ``specular_color``. What converts:

=====================================  ===========================================================
brdfkit                                metallic-roughness
=====================================  ===========================================================
:class:`~brdfkit.brdf.Lambertian`      base colour ρ, specular weight 0 (exact)
one GGX or Beckmann lobe (a metal)     metallic 1, base colour :math:`F(\theta=0)`, roughness
                                       :math:`\sqrt{\alpha}`
Lambertian + a GGX or Beckmann lobe    the usual fit, a dielectric: base colour ρ, roughness
                                       :math:`\sqrt\alpha`, ior η (dielectric Fresnel) or 1.5
                                       with ``specular_color`` :math:`= F_0/0.04`
smooth or rough plastic                dielectric: base colour = diffuse reflectance, ior η,
                                       roughness :math:`\sqrt\alpha` (0 when smooth)
smooth or rough dielectric             transmission 1, ior η, roughness :math:`\sqrt\alpha`
:class:`~brdfkit.brdf.Principled`      base colour, metallic, roughness as they are; ior from
                                       Burley's :math:`F_0 = 0.08\,` ``specular``; specular colour
                                       the tint :math:`\mathrm{mix}(1, C_{tint},` ``specular_tint``
                                       :math:`)`; clearcoat and its roughness
                                       :math:`\sqrt{\mathrm{mix}(0.1, 0.001, g)}`; sheen colour
                                       ``sheen`` · mix(1, C_tint, ``sheen_tint``)
=====================================  ===========================================================

The approximations are listed with each conversion (:attr:`PBRMaterial.approximations`): the
Fresnel curve (Schlick from :math:`F_0` where brdfkit's is exact), the layering (glTF weights the
diffuse by 1 − F; a brdfkit sum does not), Beckmann as GGX, anisotropy as the isotropic
:math:`\sqrt{\alpha_x\alpha_y}`, Burley's GTR1 clearcoat as GGX and his sheen as the Charlie
sheen, the subsurface (flatness) dropped. Other models (Phong, Ward, measured tables…) are
refused by name: fit a metallic-roughness model first (``brdfkit fit --model 'lambertian +
ggx'``).

References
----------
.. [1] The Khronos Group, "glTF 2.0 Specification", Appendix B (BRDF implementation), 2021;
       KHR_materials_clearcoat, _sheen, _specular, _ior, _transmission.
.. [2] B. Burley, "Physically-Based Shading at Disney", SIGGRAPH 2012 course notes.

Examples
--------
>>> from brdfkit.brdf import Lambertian, RoughConductor
>>> m = pbr_material(Lambertian([0.5, 0.2, 0.1]) + RoughConductor(alpha=0.04, eta=1.5, k=0.0))
>>> m.base_color.tolist(), m.metallic, round(m.roughness, 6), round(m.ior, 6)
([0.5, 0.2, 0.1], 0.0, 0.2, 1.5)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from brdfkit.brdf import (
    BRDF,
    Lambertian,
    Principled,
    RoughDielectric,
    RoughPlastic,
    SmoothDielectric,
    SmoothPlastic,
)
from brdfkit.brdf.microfacet_reflection import MicrofacetReflection
from brdfkit.errors import ParameterError
from brdfkit.fresnel import f0_from_ior
from brdfkit.interop._lobes import flattened, values
from brdfkit.io import luminance

TOOL = "glTF/MaterialX/USD"
GLTF_IOR = 1.5
"""glTF's default index (F0 = 0.04)."""


@dataclass(frozen=True)
class PBRMaterial:
    """The metallic-roughness parameters (module docstring), linear RGB colours."""

    base_color: np.ndarray
    metallic: float = 0.0
    roughness: float = 1.0
    ior: float = GLTF_IOR
    specular_weight: float = 1.0
    specular_color: np.ndarray = field(default_factory=lambda: np.ones(3))
    transmission: float = 0.0
    clearcoat: float = 0.0
    clearcoat_roughness: float = 0.0
    sheen_color: np.ndarray = field(default_factory=lambda: np.zeros(3))
    sheen_roughness: float = 0.0
    approximations: tuple[str, ...] = ()


def ior_from_f0(f0: float) -> float:
    r"""The index whose normal-incidence reflectance is ``f0``:
    :math:`\eta = (1 + \sqrt{F_0})/(1 - \sqrt{F_0})` (the inverse of
    :func:`brdfkit.fresnel.f0_from_ior`)."""
    root = math.sqrt(min(max(f0, 0.0), 0.99))
    return (1 + root) / (1 - root)


def dielectric_f0(material: PBRMaterial) -> np.ndarray:
    r"""The dielectric layer's normal-incidence reflectance per channel,
    :math:`\min(((\eta - 1)/(\eta + 1))^2 \cdot` ``specular_color`` :math:`, 1) \cdot`
    ``specular_weight`` (glTF's KHR_materials_specular)."""
    f0 = f0_from_ior(np.asarray(material.ior, dtype=np.float64))
    return np.minimum(f0 * material.specular_color, 1.0) * material.specular_weight


def pbr_material(brdf: BRDF) -> PBRMaterial:
    """The metallic-roughness material nearest to ``brdf`` (module docstring).

    Raises
    ------
    brdfkit.errors.ParameterError
        Naming the model that has no metallic-roughness counterpart.
    """
    lobes = flattened(brdf, np.ones(1), TOOL)
    lobes = [pair for lobe, scale in lobes for pair in _with_diffuse_split(lobe, scale)]
    kinds = [_kind(lobe) for lobe, _ in lobes]
    if len(lobes) == 1 and kinds[0] in _SINGLE:
        return _SINGLE[kinds[0]](*lobes[0])
    if set(kinds) <= {"diffuse", "microfacet"} and kinds.count("microfacet") <= 1:
        return _diffuse_and_specular(lobes, kinds)
    names = ", ".join(sorted({type(lobe).__name__ for lobe, _ in lobes}))
    raise ParameterError(
        f"{names} has no {TOOL} counterpart: their materials are metallic-roughness (GGX over "
        "Lambertian, principled, plastic, dielectric); fit one first, e.g. brdfkit fit --model "
        "'lambertian + ggx'"
    )


# --------------------------------------------------------------------------- lobes
def _with_diffuse_split(lobe: BRDF, scale: np.ndarray) -> list[tuple[BRDF, np.ndarray]]:
    """A microfacet model with its own Lambertian base (Cook–Torrance's ``diffuse``) as the
    two lobes it evaluates as."""
    mixture = getattr(lobe, "mixture", None)
    if mixture is None:
        return [(lobe, scale)]
    return flattened(mixture, scale, TOOL)


def _kind(lobe: BRDF) -> str:
    if isinstance(lobe, Lambertian):
        return "diffuse"
    if isinstance(lobe, MicrofacetReflection) and type(lobe.ndf).__name__ in ("GGX", "Beckmann"):
        return "microfacet"
    if isinstance(lobe, (SmoothPlastic, RoughPlastic)):
        return "plastic"
    if isinstance(lobe, (SmoothDielectric, RoughDielectric)):
        return "dielectric"
    if isinstance(lobe, Principled):
        return "principled"
    return type(lobe).__name__


def _rgb(values_: np.ndarray) -> np.ndarray:
    return np.broadcast_to(values_, (3,)).astype(np.float64)


def _clipped(name: str, rgb: np.ndarray, notes: list[str]) -> np.ndarray:
    if np.any(rgb > 1) or np.any(rgb < 0):
        notes.append(f"{name} {np.round(rgb, 4).tolist()} clipped to [0, 1]")
    return np.clip(rgb, 0.0, 1.0)


def _microfacet(lobe: MicrofacetReflection, notes: list[str]) -> tuple[float, np.ndarray]:
    """(roughness √α, F0 per channel) of a GGX/Beckmann lobe, noting what differs."""
    ndf = lobe.ndf
    ax = float(np.mean(values(lobe, "alpha_x", ndf.alpha_x, TOOL)))
    ay = float(np.mean(values(lobe, "alpha_y", ndf.alpha_y, TOOL)))
    if ax != ay:
        notes.append(f"anisotropic roughness ({ax:.4g}, {ay:.4g}) as isotropic √(αx αy)")
    if type(ndf).__name__ == "Beckmann":
        notes.append("Beckmann distribution as GGX of the same α")
    if lobe.masking != "smith_correlated":
        notes.append(f"masking {lobe.masking!r} as height-correlated Smith")
    if lobe.fresnel_term.kind != "none":
        notes.append(f"{lobe.fresnel_term.kind} Fresnel as Schlick's from F0")
    f0 = np.asarray(lobe.fresnel_term(np.ones((1, 1))), dtype=np.float64).reshape(-1)
    return math.sqrt(math.sqrt(ax * ay)), _rgb(f0)


def _diffuse_and_specular(lobes: list, kinds: list[str]) -> PBRMaterial:
    notes: list[str] = []
    rho = sum(
        (_rgb(values(lobe, "rho", lobe.rho, TOOL) * scale) for (lobe, scale), kind in
         zip(lobes, kinds, strict=True) if kind == "diffuse"),
        np.zeros(3),
    )  # fmt: skip
    specular = [
        (lobe, scale) for (lobe, scale), k in zip(lobes, kinds, strict=True) if k != "diffuse"
    ]
    if not specular:
        return PBRMaterial(base_color=_clipped("base colour", rho, notes), specular_weight=0.0,
                           approximations=tuple(notes))  # fmt: skip
    lobe, scale = specular[0]
    roughness, f0 = _microfacet(lobe, notes)
    f0 = f0 * _rgb(scale)
    if not np.any(rho > 0):
        return PBRMaterial(base_color=_clipped("F0", f0, notes), metallic=1.0,
                           roughness=roughness, approximations=tuple(notes))  # fmt: skip
    notes.append("the diffuse weighted by 1 − F under the specular layer (a sum is not)")
    term = lobe.fresnel_term
    if term.kind == "dielectric" and np.size(term.eta) == 1:
        ior, colour = float(np.reshape(term.eta, ())), _rgb(scale)
    else:
        ior, colour = GLTF_IOR, f0 / 0.04
    return PBRMaterial(
        base_color=_clipped("base colour", rho, notes),
        roughness=roughness,
        ior=ior,
        specular_color=colour,
        approximations=tuple(notes),
    )


def _plastic(lobe: SmoothPlastic | RoughPlastic, scale: np.ndarray) -> PBRMaterial:
    notes = ["the coating's internal reflections as glTF's 1 − F layering"]
    rough = isinstance(lobe, RoughPlastic)
    roughness = math.sqrt(float(values(lobe, "alpha", lobe.alpha, TOOL)[0])) if rough else 0.0
    diffuse = _rgb(values(lobe, "diffuse_reflectance", lobe.diffuse_reflectance, TOOL) * scale)
    specular = _rgb(values(lobe, "specular_reflectance", lobe.specular_reflectance, TOOL) * scale)
    return PBRMaterial(
        base_color=_clipped("base colour", diffuse, notes),
        roughness=roughness,
        ior=float(values(lobe, "eta", lobe.eta, TOOL)[0]),
        specular_color=specular,
        approximations=tuple(notes),
    )


def _dielectric(lobe: SmoothDielectric | RoughDielectric, scale: np.ndarray) -> PBRMaterial:
    notes = ["thin-walled transmission (no volume)"]
    roughness = 0.0
    if isinstance(lobe, RoughDielectric):
        roughness = _dielectric_roughness(lobe, notes)
    if not np.all(scale == 1):
        notes.append(f"the scale {scale.tolist()} dropped")
    return PBRMaterial(
        base_color=np.ones(3),
        roughness=roughness,
        ior=float(values(lobe, "eta", lobe.eta, TOOL)[0]),
        transmission=1.0,
        approximations=tuple(notes),
    )


def _dielectric_roughness(lobe: RoughDielectric, notes: list[str]) -> float:
    """√α of a rough dielectric (√(αu αv) when anisotropic)."""
    alphas = [lobe.alpha] if lobe.alpha_u is None else [lobe.alpha_u, lobe.alpha_v]
    a = [float(np.mean(values(lobe, "alpha", v, TOOL))) for v in alphas]
    if lobe.distribution == "beckmann":
        notes.append("Beckmann distribution as GGX of the same α")
    if a[0] != a[-1]:
        notes.append(f"anisotropic roughness ({a[0]:.4g}, {a[-1]:.4g}) as isotropic √(αu αv)")
    return math.sqrt(math.sqrt(a[0] * a[-1]))


def _principled(lobe: Principled, scale: np.ndarray) -> PBRMaterial:
    notes = [
        "Burley's GTR1 clearcoat as a GGX coat, his sheen as the Charlie sheen, his lobes "
        "(added) as the layers of a metallic-roughness material"
    ]
    p = {name: values(lobe, name, getattr(lobe, name), TOOL) for name in (
        "base_color", "metallic", "roughness", "anisotropic", "specular", "specular_tint",
        "sheen", "sheen_tint", "clearcoat", "clearcoat_gloss", "subsurface")}  # fmt: skip
    scalar = {name: float(v[0]) for name, v in p.items() if name != "base_color"}
    base = _rgb(p["base_color"])
    lum = float(luminance(base)[0])
    tint = base / lum if lum > 0 else np.ones(3)
    if scalar["anisotropic"] > 0:
        notes.append("anisotropy dropped (the isotropic roughness kept)")
    if scalar["subsurface"] > 0:
        notes.append("subsurface (flatness) dropped")
    if not np.all(scale == 1):
        notes.append(f"the scale {scale.tolist()} applied to the base colour")
    gloss = scalar["clearcoat_gloss"]
    sheen = scalar["sheen"] * (1 + scalar["sheen_tint"] * (tint - 1))
    return PBRMaterial(
        base_color=_clipped("base colour", base * _rgb(scale), notes),
        metallic=scalar["metallic"],
        roughness=scalar["roughness"],
        ior=ior_from_f0(0.08 * scalar["specular"]),
        specular_color=1 + scalar["specular_tint"] * (tint - 1),
        clearcoat=scalar["clearcoat"],
        clearcoat_roughness=math.sqrt(0.1 + (0.001 - 0.1) * gloss),
        sheen_color=_clipped("sheen colour", sheen, notes),
        sheen_roughness=0.5 if scalar["sheen"] > 0 else 0.0,
        approximations=tuple(notes),
    )


_SINGLE = {"plastic": _plastic, "dielectric": _dielectric, "principled": _principled}


__all__ = ["GLTF_IOR", "PBRMaterial", "dielectric_f0", "ior_from_f0", "pbr_material"]
