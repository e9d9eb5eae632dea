"""How close each diffusion model comes to the exact random walk, and the walk to its oracles.

Three parts, all under collimated light at normal incidence on a half-space with isotropic
scattering (lengths in mean free paths):

1. the random walk (:func:`brdfkit.bssrdf.tally_walks`) against Chandrasekhar's exact
   reflectance at an index-matched boundary, ω ∈ {0.5, 0.9, 0.99}, μ₀ ∈ {1, 0.5};
2. each diffusion model against the walk for ω ∈ {0.1, 0.3, 0.5, 0.7, 0.9, 0.99} and
   η ∈ {1.0, 1.33, 1.5}: the relative error of the total diffuse reflectance, the profile's
   shape error (half the L1 distance between the radial power distributions, binned, each
   normalised to 1: the fraction of the power put at the wrong radius) and the relative error
   of the power leaving within 0.1 mean free path of the point of entry (r → 0). Models give
   the exitance per unit power that entered; they are compared after the walk's boundary
   transmittance :math:`1 - F(\\mu_i)`;
3. Mitsuba 3's ``volpath`` (``scalar_rgb``) on a thick slab (ω = 0.9, η = 1.33) under a
   constant unit environment, seen at normal incidence: by reciprocity its radiance is the
   slab's total reflectance at normal incidence, the specular F(1) included.

``python benchmarks/bench_bssrdf.py``; results go to ``benchmarks/results/bssrdf.json``.
"""

from __future__ import annotations

import math
import time

import numpy as np
from scipy.special import roots_legendre

from brdfkit.bssrdf import (
    BetterDipole,
    ClassicalDipole,
    Medium,
    NormalizedDiffusion,
    PhotonBeamDiffusion,
    chandrasekhar_reflectance,
    tally_walks,
)
from brdfkit.bssrdf.random_walk import entry
from brdfkit.fresnel import fresnel_dielectric

WALKS = 1_000_000
ALBEDOS = (0.1, 0.3, 0.5, 0.7, 0.9, 0.99)
ETAS = (1.0, 1.33, 1.5)
EDGES = np.concatenate([[0.0], np.geomspace(0.01, 50.0, 30), [np.inf]])
NEAR = 0.1
MODELS = (ClassicalDipole, BetterDipole, PhotonBeamDiffusion, NormalizedDiffusion)
MITSUBA_RUNS, MITSUBA_SPP = 8, 8192
MITSUBA_ALBEDO, MITSUBA_ETA = 0.9, 1.33


def bin_powers(model, edges: np.ndarray) -> np.ndarray:
    """The power per unit power entering that ``model`` sends out in each radial bin
    (Gauss–Legendre on each finite bin; the last, unbounded, bin gets the rest)."""
    x, w = roots_legendre(24)
    lo, hi = edges[:-2, None], edges[1:-1, None]
    r = lo + (hi - lo) * (x + 1) / 2
    density = 2 * np.pi * r * model.profile(r.ravel())[:, 0].reshape(r.shape)
    finite = np.sum(density * w * (hi - lo) / 2, axis=1)
    total = float(model.total_reflectance()[0])
    return np.concatenate([finite, [max(total - finite.sum(), 0.0)]])


def chandrasekhar_rows() -> list[dict]:
    rows = []
    for albedo in (0.5, 0.9, 0.99):
        for mu in (1.0, 0.5):
            value, stderr = tally_walks(albedo, 1.0, mu, WALKS, seed=1).reflectance()
            exact = float(chandrasekhar_reflectance(mu, albedo))
            rows.append(
                {"albedo": albedo, "mu": mu, "walk": value, "stderr": stderr, "exact": exact}
            )
    return rows


def model_errors(albedo: float, eta: float, seed: int) -> dict:
    tally = tally_walks(albedo, eta, 1.0, WALKS, seed=seed, edges=EDGES)
    walk_total, walk_stderr = tally.reflectance()
    t_i, _ = entry(1.0, eta)
    walk_bins = t_i * tally.counts / tally.samples  # the last bin reaches to infinity
    near = EDGES[1:] <= NEAR
    errors = {}
    medium = Medium(albedo, eta=eta)
    for model_type in MODELS:
        model = model_type(medium)
        bins = t_i * bin_powers(model, EDGES)
        total = t_i * float(model.total_reflectance()[0])
        shape = 0.5 * np.sum(np.abs(bins / bins.sum() - walk_bins / walk_bins.sum()))
        errors[model_type.name] = {
            "total": (total - walk_total) / walk_total,
            "profile": float(shape),
            "near": float(bins[near].sum() / walk_bins[near].sum() - 1),
        }
    return {
        "albedo": albedo,
        "eta": eta,
        "walk": walk_total,
        "stderr": walk_stderr,
        "near_walk": float(walk_bins[near].sum()),
        "errors": errors,
    }


def mitsuba_slab() -> dict | None:
    """Mitsuba's volpath reflectance of a thick slab (see the module docstring), or ``None``
    without Mitsuba."""
    try:
        from brdfkit.interop import mitsuba as ms

        mi, variant = ms.load_mitsuba(("scalar_rgb",))
    except ImportError:
        return None
    transform = mi.ScalarTransform4f()
    scene = mi.load_dict(
        {
            "type": "scene",
            "integrator": {"type": "volpath", "max_depth": -1, "rr_depth": 1 << 30},
            "sensor": {
                "type": "orthographic",
                "to_world": transform.look_at(origin=[0, 0, 5], target=[0, 0, 0], up=[0, 1, 0])
                @ transform.scale([0.01, 0.01, 1]),
                "film": {"type": "hdrfilm", "width": 1, "height": 1, "rfilter": {"type": "box"}},
                "sampler": {"type": "independent"},
            },
            "light": {"type": "constant", "radiance": {"type": "rgb", "value": 1.0}},
            "slab": {  # 4000 × 4000 × 1000 mean free paths, its top face at z = 0
                "type": "cube",
                "to_world": transform.translate([0, 0, -500]) @ transform.scale([2000, 2000, 500]),
                "bsdf": {"type": "dielectric", "int_ior": MITSUBA_ETA, "ext_ior": 1.0},
                "interior": {
                    "type": "homogeneous",
                    "albedo": {"type": "rgb", "value": MITSUBA_ALBEDO},
                    "sigma_t": {"type": "rgb", "value": 1.0},
                    "phase": {"type": "isotropic"},
                },
            },
        }
    )
    start = time.perf_counter()
    runs = [
        float(np.mean(ms.render(mi, scene, MITSUBA_SPP, seed=seed))) for seed in range(MITSUBA_RUNS)
    ]
    seconds = time.perf_counter() - start
    walk, walk_stderr = tally_walks(MITSUBA_ALBEDO, MITSUBA_ETA, 1.0, WALKS, seed=3).reflectance()
    specular = float(fresnel_dielectric(1.0, MITSUBA_ETA))
    return {
        "variant": variant,
        "albedo": MITSUBA_ALBEDO,
        "eta": MITSUBA_ETA,
        "spp": MITSUBA_RUNS * MITSUBA_SPP,
        "mitsuba": float(np.mean(runs)),
        "mitsuba_stderr": float(np.std(runs, ddof=1) / math.sqrt(MITSUBA_RUNS)),
        "walk_plus_specular": walk + specular,
        "walk_stderr": walk_stderr,
        "mitsuba_seconds": seconds,
    }


def main() -> None:
    from _machine import write_results

    start = time.perf_counter()
    chandrasekhar = chandrasekhar_rows()
    cases = [
        model_errors(albedo, eta, seed=10 + i)
        for i, (eta, albedo) in enumerate((e, a) for e in ETAS for a in ALBEDOS)
    ]
    walk_seconds = time.perf_counter() - start
    mitsuba = mitsuba_slab()
    record = {
        "walks": WALKS,
        "edges": [float(e) for e in EDGES],
        "near_radius": NEAR,
        "chandrasekhar": chandrasekhar,
        "cases": cases,
        "mitsuba": mitsuba,
        "walk_seconds": walk_seconds,
    }
    path = write_results(__file__, record, packages=("mitsuba",))
    print(f"wrote {path}")
    for row in chandrasekhar:
        z = (row["walk"] - row["exact"]) / row["stderr"]
        print(f"ω={row['albedo']} μ={row['mu']}: walk {row['walk']:.5f} exact {row['exact']:.5f}"
              f" ({z:+.2f} σ)")  # fmt: skip
    for case in cases:
        totals = "  ".join(f"{n}: {e['total']:+.3f}" for n, e in case["errors"].items())
        print(f"η={case['eta']} ω={case['albedo']}: {totals}")
    if mitsuba:
        print(mitsuba)


if __name__ == "__main__":
    main()
