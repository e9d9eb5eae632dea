r"""Named real materials: published fits of analytic models to the MERL measurements, as
ordinary BRDFs.

The parameter tables (``brdfkit/data/materials/bbm_fits.json``, BSD-3, licence beside them)
are those the BRDF benchmark project ``bbm`` collected: Ngan, Durand & Matusik's (2005) fits of
seven models to 86 MERL materials, Löw et al.'s (2012) fits (E1 and E2 error metrics) and
Bagher et al.'s (2012) fits to 100. Each preset is the fit's Lambertian plus its specular
model, converted to brdfkit's models so that its value equals ``bbm``'s C++ (``ngan.h``,
``low.h``, ``bagher.h``) exactly:

============================  =====================================================================
fit (``bbm`` model)           brdfkit
============================  =====================================================================
``ngan_ward``                 ``Ward(kd=ρ, ks=albedo, alpha_x=roughness, normalization="ward")``
``ngan_wardduer``             the same with ``normalization="duer"``
``ngan_blinnphong``           ``ModifiedPhong(kd=ρ, ks=albedo, n=sharpness)`` (``ngan.h``'s
                              "Blinn-Phong" is an alias of the modified Phong lobe about the
                              mirror direction, not a half-vector lobe)
``ngan_lafortune``            ``Lambertian(ρ) + albedo·(n+2)/(2π) · Lafortune(C/M, n)``,
                              M = max(abs(C_xy), abs(C_z)): Ngan's extra factor
                              (n+2)/(2π max(C_z², C_xy²)^{n/2}) folded into the coefficients
``ngan_cooktorrance``         ``Lambertian(ρ) + (4·albedo/π) · CookTorrance(m, schlick, f0=eta)``
                              (Beckmann with 1/π, V-groove, Schlick with "eta" = F0, over
                              π cos θi cos θo)
``ngan_ashikhminshirley``     ``Lambertian(ρ) + albedo · AshikhminShirley(rd=0, rs=F0, nu=n)``
``low_cooktorrance_E*``       ``Lambertian(ρ) + 4·albedo · CookTorrance(m, dielectric, eta)``
                              (Beckmann without 1/π, Cook's Fresnel of index η)
``low_ashikhminshirley_E*``   ``Lambertian(ρ) + albedo · AshikhminShirley(rd=0, nu=n, eta=η)``
``low_lowmicrofacet_E2``      ``Lambertian(ρ) + LowMicrofacet(A, B, C, eta)``
``low_lowsmooth_E2``          ``Lambertian(ρ) + LowSmooth(A, B, C, eta)``
``bagher_sgd``                ``Lambertian(ρ) + BagherSGD(ks=albedo·K, ...)``, eta = [F0, F1]
``ngan_he``                   not converted (see :data:`UNCONVERTED`)
============================  =====================================================================

References
----------
.. [1] A. Ngan, F. Durand, W. Matusik, "Experimental analysis of BRDF models", EGSR 2005.
.. [2] J. Löw, J. Kronander, A. Ynnerman, J. Unger, "BRDF models for accurate and efficient
       rendering of glossy surfaces", ACM TOG 31(1), 2012.
.. [3] M. M. Bagher, C. Soler, N. Holzschuch, "Accurate fitting of measured reflectances using
       a Shifted Gamma micro-facet distribution", CGF 31(4), 2012.
.. [4] W. Matusik, H. Pfister, M. Brand, L. McMillan, "A data-driven reflectance model",
       SIGGRAPH 2003 (the MERL measurements).
.. [5] P. Peers et al., BRDF benchmark ``bbm`` (BSD-3), https://github.com/bsdfbenchmark/bbm
"""

from __future__ import annotations

import ast
import functools
import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path
from typing import Any

import numpy as np

from brdfkit._array import Array
from brdfkit.brdf.ashikhmin_shirley import AshikhminShirley
from brdfkit.brdf.bagher import BagherSGD
from brdfkit.brdf.base import BRDF, Sample, Scaled, Sum, register
from brdfkit.brdf.lafortune import Lafortune
from brdfkit.brdf.lambertian import Lambertian
from brdfkit.brdf.low import LowMicrofacet, LowSmooth
from brdfkit.brdf.phong import ModifiedPhong
from brdfkit.brdf.torrance_sparrow import CookTorrance
from brdfkit.brdf.ward import Ward
from brdfkit.errors import FormatError
from brdfkit.params import check_choice

UNCONVERTED = {
    "NganHe": (
        "He et al. (1991) needs the wavelength of each colour channel (bbm's Config::wavelength, "
        "not in the shipped headers: 0.645, 0.526, 0.444 µm for R, G, B in bbm's backbone.h) and "
        "its own Taylor-series evaluation; not converted yet"
    )
}
"""``bbm`` models of the tables that have no brdfkit preset, and why."""


@functools.lru_cache(maxsize=1)
def tables() -> dict[str, Any]:
    """The shipped fit tables: ``{"licence": ..., "sources": {fit: {"file", "model", "header",
    "materials": {name: {"diffuse": [...], "params": {...}}}}}}``."""
    path = files("brdfkit.data") / "materials" / "bbm_fits.json"
    return json.loads(path.read_text(encoding="utf-8"))


def fits() -> tuple[str, ...]:
    """The names of the fits with presets (``"ngan_ward"``, …, ``"bagher_sgd"``)."""
    return tuple(k for k, v in tables()["sources"].items() if v["model"] not in UNCONVERTED)


def materials(fit: str) -> tuple[str, ...]:
    """The material names of the fit ``fit``, in file order."""
    check_choice("fit", fit, fits())
    return tuple(tables()["sources"][fit]["materials"])


def citation(fit: str) -> str:
    """The paper the fit ``fit`` comes from (the fit file's header), and the table's source."""
    check_choice("fit", fit, tuple(tables()["sources"]))
    source = tables()["sources"][fit]
    paper = " ".join(line.removeprefix("BSDF fits for the ").strip() for line in source["header"])
    return f"{paper} — via the BRDF benchmark bbm ({source['file']}, BSD-3)"


def _unphysical(kd: Any, ks: Any) -> bool:
    kd, ks = np.asarray(kd, dtype=np.float64), np.asarray(ks, dtype=np.float64)
    return bool(np.any(ks > 1) or np.any(kd + ks > 1))


def _ward(normalization: str) -> Callable[[list[float], dict[str, Any]], BRDF]:
    def convert(diffuse: list[float], p: dict[str, Any]) -> BRDF:
        return Ward(
            diffuse,
            p["albedo"],
            p["roughness"],
            normalization=normalization,
            allow_unphysical=_unphysical(diffuse, p["albedo"]),
        )

    return convert


def _blinn_phong(diffuse: list[float], p: dict[str, Any]) -> BRDF:
    return ModifiedPhong(
        diffuse, p["albedo"], p["sharpness"], allow_unphysical=_unphysical(diffuse, p["albedo"])
    )


def _lafortune(diffuse: list[float], p: dict[str, Any]) -> BRDF:
    n, cxy, cz = p["sharpness"], p["Cxy"], p["Cz"]
    peak = max(abs(cxy), abs(cz))
    lobe = Lafortune(0.0, [cxy / peak], [cxy / peak], [cz / peak], [n])
    k = (np.asarray(p["albedo"]) * (n + 2) / (2 * math.pi)).tolist()
    return Lambertian(diffuse) + Scaled(k, lobe)


def _ngan_cook_torrance(diffuse: list[float], p: dict[str, Any]) -> BRDF:
    lobe = CookTorrance(m=p["roughness"], fresnel="schlick", f0=p["eta"])
    return Lambertian(diffuse) + Scaled((np.asarray(p["albedo"]) * 4 / math.pi).tolist(), lobe)


def _low_cook_torrance(diffuse: list[float], p: dict[str, Any]) -> BRDF:
    lobe = CookTorrance(m=p["roughness"], fresnel="dielectric", eta=p["eta"])
    return Lambertian(diffuse) + Scaled((np.asarray(p["albedo"]) * 4).tolist(), lobe)


def _ngan_ashikhmin_shirley(diffuse: list[float], p: dict[str, Any]) -> BRDF:
    lobe = AshikhminShirley(0.0, p["fresnelReflectance"], p["sharpness"])
    return Lambertian(diffuse) + Scaled(p["albedo"], lobe)


def _low_ashikhmin_shirley(diffuse: list[float], p: dict[str, Any]) -> BRDF:
    lobe = AshikhminShirley(0.0, 0.0, p["sharpness"], eta=p["fresnelReflectance"])
    return Lambertian(diffuse) + Scaled(p["albedo"], lobe)


def _low(cls: type[BRDF]) -> Callable[[list[float], dict[str, Any]], BRDF]:
    def convert(diffuse: list[float], p: dict[str, Any]) -> BRDF:
        return Lambertian(diffuse) + cls(p["A"], p["B"], p["C"], p["eta"])

    return convert


def _bagher(diffuse: list[float], p: dict[str, Any]) -> BRDF:
    lobe = BagherSGD(
        ks=(np.asarray(p["albedo"]) * np.asarray(p["K"])).tolist(),
        alpha=p["alpha"],
        p=p["p"],
        f0=p["eta"][0],
        f1=p["eta"][1],
        lam=p["Lambda"],
        c=p["c"],
        power=p["k"],
        theta0=p["theta0"],
    )
    return Lambertian(diffuse) + lobe


CONVERTERS: dict[str, Callable[[list[float], dict[str, Any]], BRDF]] = {
    "NganWard": _ward("ward"),
    "NganWardDuer": _ward("duer"),
    "NganBlinnPhong": _blinn_phong,
    "NganLafortune": _lafortune,
    "NganCookTorrance": _ngan_cook_torrance,
    "NganAshikhminShirley": _ngan_ashikhmin_shirley,
    "LowCookTorrance": _low_cook_torrance,
    "LowAshikhminShirley": _low_ashikhmin_shirley,
    "LowMicrofacetFit": _low(LowMicrofacet),
    "LowSmooth": _low(LowSmooth),
    "Bagher": _bagher,
}
"""``bbm`` model name → the conversion of a fit's (Lambertian albedo, parameters) to a BRDF."""


def preset(name: str, fit: str = "ngan_ward") -> BRDF:
    """The material ``name`` as fitted by ``fit``, as a brdfkit BRDF (see the module table).

    Raises
    ------
    brdfkit.errors.ParameterError
        Naming ``fit`` or ``name`` when it is unknown, with the known ones.
    """
    check_choice("fit", fit, fits())
    check_choice("name", name, materials(fit))
    return _preset(name, fit)


@functools.lru_cache(maxsize=4096)
def _preset(name: str, fit: str) -> BRDF:
    source = tables()["sources"][fit]
    entry = source["materials"][name]
    return CONVERTERS[source["model"]](entry["diffuse"], entry["params"])


@register("material")
@dataclass(frozen=True, eq=False)
class Material(BRDF):
    r"""A named real material: a published fit to a MERL measurement (:func:`preset`).

    Spec: ``material(name='alum-bronze', fit='ngan_ward')``. The value, sampling and claims
    are those of the converted model (:attr:`brdf`); :attr:`citation` names the fit's paper.
    **Reciprocal** when that model is (all are). **Energy-conserving** claimed when every lobe
    of it claims so (Ngan's Blinn–Phong, Cook–Torrance with 4·albedo/π ≤ 1 and
    Ashikhmin–Shirley presets, with the Lambertian); the albedo of every preset is measured
    in the tests and the presets above 1 are listed in ``brdfkit/data/materials/README.md``.

    Parameters
    ----------
    name : the MERL material (``brdfkit materials`` lists them).
    fit : the fit, one of :func:`fits` (default ``"ngan_ward"``).

    References
    ----------
    .. [1] A. Ngan, F. Durand, W. Matusik, "Experimental analysis of BRDF models", EGSR 2005.
    .. [2] W. Matusik et al., "A data-driven reflectance model", SIGGRAPH 2003.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import Material
    >>> f = Material('alum-bronze', 'ngan_ward')
    >>> wi, wo = np.array([0.48, 0.36, 0.8]), np.array([-0.6, 0.0, 0.8])
    >>> np.round(f.eval(wi, wo), 4)
    array([0.0271, 0.0187, 0.0094])
    >>> np.allclose(f.eval(wi, wo), f.eval(wo, wi))
    True
    """

    name: str = "alum-bronze"
    fit: str = "ngan_ward"

    def __post_init__(self) -> None:
        object.__setattr__(self, "brdf", preset(self.name, self.fit))

    @property
    def citation(self) -> str:
        """The paper of the fit and the table's source."""
        return citation(self.fit)

    @property
    def channels(self) -> int:  # type: ignore[override]
        return self.brdf.channels

    @property
    def reciprocal(self) -> bool:  # type: ignore[override]
        return self.brdf.reciprocal

    @property
    def energy_conserving(self) -> bool:  # type: ignore[override]
        lobes = self.brdf.lobes if isinstance(self.brdf, Sum) else (self.brdf,)
        return all(lobe.energy_conserving for lobe in lobes)

    @property
    def isotropic(self) -> bool:  # type: ignore[override]
        return self.brdf.isotropic

    @classmethod
    def examples(cls) -> list[BRDF]:
        return [
            cls("alum-bronze", "ngan_ward"),
            cls("gold-metallic-paint", "ngan_ashikhminshirley"),
            cls("blue-acrylic", "ngan_lafortune"),
            cls("red-fabric", "low_lowsmooth_E2"),
            cls("alum-bronze", "bagher_sgd"),
        ]

    def eval(self, wi: Array, wo: Array) -> Array:
        return self.brdf.eval(wi, wo)

    def pdf(self, wi: Array, wo: Array) -> Array:
        return self.brdf.pdf(wi, wo)

    def sample(self, wo: Array, u: Array) -> Sample:
        return self.brdf.sample(wo, u)

    def albedo(self, wo: Array, samples: int = 4096, seed: int = 0) -> Array:
        return self.brdf.albedo(wo, samples=samples, seed=seed)

    def albedo_estimate(
        self, wo: Array, samples: int = 4096, seed: int = 0, hemisphere: str = "upper"
    ) -> tuple[Array, Array]:
        return self.brdf.albedo_estimate(wo, samples=samples, seed=seed, hemisphere=hemisphere)

    def sampling_weight(self, wo: Array) -> Array:
        return self.brdf.sampling_weight(wo)


# --------------------------------------------------------------------------- catalogue
def catalogue(fit: str | None = None, model: str | None = None) -> list[dict[str, Any]]:
    """One record per preset: ``{"name", "fit", "model", "spec", "citation"}``.

    ``fit`` keeps one fit; ``model`` keeps the fits whose ``bbm`` model name or fit name
    contains it (case-insensitive: ``"ward"`` keeps ``ngan_ward`` and ``ngan_wardduer``).
    """
    chosen = fits() if fit is None else (fit,)
    records = []
    for key in chosen:
        bbm_model = tables()["sources"][key]["model"] if key in fits() else ""
        if model is not None and model.lower() not in f"{key} {bbm_model}".lower():
            continue
        for name in materials(key):
            records.append(
                {
                    "name": name,
                    "fit": key,
                    "model": bbm_model,
                    "spec": Material(name, key).to_spec(),
                    "citation": citation(key),
                }
            )
    return records


# --------------------------------------------------------------------------- the bbm fit files
@dataclass(frozen=True)
class FitEntry:
    """One material of a fit file: its Lambertian albedo, the specular model's name and
    parameters (numbers and lists, as in the file)."""

    diffuse: list[float]
    model: str
    params: dict[str, Any]


def _call(node: ast.expr, where: str) -> tuple[str, list[ast.expr], dict[str, Any]]:
    if not isinstance(node, ast.Call) or not isinstance(node.func, ast.Name):
        raise FormatError(f"{where}: expected Model(name = value, ...)")
    try:
        params = {kw.arg: ast.literal_eval(kw.value) for kw in node.keywords}
    except ValueError:
        raise FormatError(f"{where}: parameters must be numbers or lists of numbers") from None
    return node.func.id, node.args, params


def read_fit_file(path: str | Path) -> tuple[list[str], dict[str, FitEntry]]:
    """The header comments and the materials of the fit file ``path``, in file order.

    Raises
    ------
    brdfkit.errors.FormatError
        Naming the file and line of a line that is no ``name = Aggregate(Lambertian(albedo =
        [...]), Model(...))``.
    """
    path = Path(path)
    header: list[str] = []
    entries: dict[str, FitEntry] = {}
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        line = line.strip()
        if not line:
            continue
        if line.startswith("#"):
            header.append(line.lstrip("# ").rstrip())
            continue
        where = f"{path}:{number}"
        name, sep, expression = line.partition("=")
        try:
            tree = ast.parse(expression.strip(), mode="eval")
        except SyntaxError:
            raise FormatError(f"{where}: not a fit line") from None
        outer, args, _ = _call(tree.body, where)
        if not sep or outer != "Aggregate" or len(args) != 2:
            raise FormatError(f"{where}: expected name = Aggregate(Lambertian(...), Model(...))")
        diffuse_name, _, diffuse = _call(args[0], where)
        model, _, params = _call(args[1], where)
        if diffuse_name != "Lambertian" or set(diffuse) != {"albedo"}:
            raise FormatError(f"{where}: the first term must be Lambertian(albedo = [...])")
        entries[name.strip()] = FitEntry(list(map(float, diffuse["albedo"])), model, params)
    return header, entries


def tables_from_fit_files(directory: str | Path) -> dict[str, Any]:
    """The preset tables brdfkit ships (``brdfkit/data/materials/bbm_fits.json``), built from
    the ``*.fit`` files in ``directory``: per source (the file's stem) its file name, model,
    header (the citation) and, per material, the Lambertian albedo and the model's parameters.
    """
    sources: dict[str, Any] = {}
    for path in sorted(Path(directory).glob("*.fit")):
        header, entries = read_fit_file(path)
        models = sorted({entry.model for entry in entries.values()})
        if len(models) != 1:
            raise FormatError(f"{path}: expected one model per file; got {models}")
        sources[path.stem] = {
            "file": path.name,
            "model": models[0],
            "header": header,
            "materials": {
                name: {"diffuse": entry.diffuse, "params": entry.params}
                for name, entry in entries.items()
            },
        }
    return {"licence": "LICENSE.bbm", "sources": sources}


__all__ = ["Material"]
