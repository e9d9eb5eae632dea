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
3. Mitsuba 3's ``volpath`` (``llvm_ad_rgb``) on a slab 40 × 40 × 20 mean free paths (ω = 0.9,
   η = 1.33): its total reflectance at normal incidence (under a constant unit environment, by
   reciprocity, the specular F(1) included) and its radial profile by reciprocity (a sensor
   over a small square looking down, unit diffuse light from one ring of texels just above the
   surface at a time: the share of pencil-beam power leaving over that ring; the walk
   estimates the same number, see :func:`mitsuba_profile`);
4. a translucent unit sphere (ω = 0.9, η = 1.33, mean free paths of 0.1 and 0.02 radii) under a
   soft lobe of sky, 64², rendered by Mitsuba's ``volpath``, by brdfkit's reference walk
   (:func:`brdfkit.bssrdf.sphere_walk.random_walk_sphere`) and by each diffusion model's
   separable BSSRDF (:func:`brdfkit.bssrdf.sphere.diffusion_sphere`).

``python benchmarks/bench_bssrdf.py`` (``--spheres-only``: part 4 alone, the rest of the
results file kept); results go to ``benchmarks/results/bssrdf.json``.
"""

from __future__ import annotations

import math
import sys
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
from brdfkit.bssrdf.sphere import diffusion_sphere
from brdfkit.bssrdf.sphere_walk import random_walk_sphere
from brdfkit.fresnel import fresnel_dielectric
from brdfkit.light import EnvironmentMap
from brdfkit.light.spherical_harmonics import latlong_directions

WALKS = 1_000_000
ALBEDOS = (0.1, 0.3, 0.5, 0.7, 0.9, 0.99)
ETAS = (1.0, 1.33, 1.5)
EDGES = np.concatenate([[0.0], np.geomspace(0.01, 50.0, 30), [np.inf]])
NEAR = 0.1
MODELS = (ClassicalDipole, BetterDipole, PhotonBeamDiffusion, NormalizedDiffusion)
MITSUBA_RUNS, MITSUBA_SPP = 8, 64
SLAB_SIDE, SLAB_DEPTH = 40.0, 20.0
RINGS = np.array([0.0, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0])
REACH, TEXELS, GAP, SENSOR = 6.0, 512, 1e-3, 0.05
PROFILE_RUNS, PROFILE_SPP = 4, 1024
SPHERE_MEDIA = {  # ω, σt, η; mean free paths of 0.1 and 0.02 sphere radii
    "soft": (0.9, 10.0, 1.33),
    "dense": (0.9, 50.0, 1.33),
}
SPHERE_RESOLUTION, SPHERE_RUNS, SPHERE_SPP, SPHERE_WALKS, BLOCK = 64, 8, 64, 128, 4
SKY_TOWARDS = (0.3, 1.0, 0.5)
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


def slab_medium(mi) -> dict:
    """Mitsuba's slab: the walk's medium (ω = 0.9, σt = 1, isotropic) below a smooth dielectric
    boundary of η = 1.33, its top face at z = 0, SLAB_SIDE wide and SLAB_DEPTH deep (mean free
    paths; small enough for Mitsuba's float32 intersections to stay exact to ~1e-6)."""
    transform = mi.ScalarTransform4f()
    half_depth = SLAB_DEPTH / 2
    return {
        "type": "cube",
        "to_world": transform.translate([0, 0, -half_depth])
        @ transform.scale([SLAB_SIDE / 2, SLAB_SIDE / 2, half_depth]),
        "bsdf": {"type": "dielectric", "int_ior": MITSUBA_ETA, "ext_ior": 1.0},
        "interior": {
            "type": "homogeneous",
            "albedo": {"type": "rgb", "value": MITSUBA_ALBEDO},
            "sigma_t": 1.0,
            "phase": {"type": "isotropic"},
        },
    }


def looking_down(mi, half_width: float, pixels: int) -> dict:
    """An orthographic sensor looking straight down at the slab over [−w, w]² (box filter)."""
    transform = mi.ScalarTransform4f()
    return {
        "type": "orthographic",
        "to_world": transform.look_at(origin=[0, 0, 5], target=[0, 0, 0], up=[0, 1, 0])
        @ transform.scale([half_width, half_width, 1]),
        "film": {
            "type": "hdrfilm",
            "width": pixels,
            "height": pixels,
            "pixel_format": "rgb",
            "rfilter": {"type": "box"},
        },
        "sampler": {"type": "independent"},
    }


def mitsuba_slab(mi, ms, variant: str) -> dict:
    """Total reflectance: under a constant unit environment, seen at normal incidence, the
    slab's radiance is (by reciprocity) its total reflectance at normal incidence, the specular
    F(1) included."""
    scene = mi.load_dict(
        {
            "type": "scene",
            "integrator": {"type": "volpath", "max_depth": -1},
            "sensor": looking_down(mi, 0.01, 64),
            "light": {"type": "constant", "radiance": {"type": "rgb", "value": 1.0}},
            "slab": slab_medium(mi),
        }
    )
    start = time.perf_counter()
    pixels = np.concatenate(
        [ms.render(mi, scene, MITSUBA_SPP, seed=seed).ravel() for seed in range(MITSUBA_RUNS)]
    )  # every pixel (and channel: a grey scene renders alike in each) an independent mean
    seconds = time.perf_counter() - start
    tally = tally_walks(MITSUBA_ALBEDO, MITSUBA_ETA, 1.0, WALKS, seed=3, thickness=SLAB_DEPTH)
    walk, walk_stderr = tally.reflectance()
    specular = float(fresnel_dielectric(1.0, MITSUBA_ETA))
    return {
        "variant": variant,
        "albedo": MITSUBA_ALBEDO,
        "eta": MITSUBA_ETA,
        "spp": MITSUBA_RUNS * MITSUBA_SPP * 64 * 64,
        "mitsuba": float(np.mean(pixels)),
        "mitsuba_stderr": float(np.std(pixels, ddof=1) / math.sqrt(pixels.size / 3)),
        "walk_plus_specular": walk + specular,
        "walk_stderr": walk_stderr,
        "mitsuba_seconds": seconds,
    }


def ring_texels() -> np.ndarray:
    """The ring of each texel of the emitting rectangle (by its centre's radius; the corners
    beyond the last edge are ring ``len(RINGS) - 1``)."""
    centres = ((np.arange(TEXELS) + 0.5) / TEXELS * 2 - 1) * REACH
    return np.digitize(np.hypot(centres[:, None], centres[None, :]), RINGS) - 1


def ring_emitter(mi, rings: np.ndarray, group: int) -> dict:
    """A rectangle just above the slab, invisible (``null``) but emitting downwards, unit
    radiance over rings 3·group, 3·group + 1 and 3·group + 2 in its red, green and blue."""
    transform = mi.ScalarTransform4f()
    texture = np.stack([rings == 3 * group + c for c in range(3)], -1).astype(np.float32)
    return {
        "type": "rectangle",
        "to_world": transform.translate([0, 0, GAP]) @ transform.scale([REACH, REACH, 1]),
        "flip_normals": True,
        "bsdf": {"type": "null"},
        "emitter": {
            "type": "area",
            "radiance": {
                "type": "bitmap",
                "bitmap": mi.Bitmap(texture),
                "raw": True,
                "filter_type": "nearest",
                "wrap_mode": "clamp",
            },
        },
    }


def mitsuba_profile(mi, ms, variant: str) -> dict:
    """The radial profile by reciprocity. A pencil beam at normal incidence entering at x_c
    gives exitance R(|x − x_c|) at x, so a sensor seeing the slab's radiance along the normal
    over a small square S (x_c uniform in S), lit by unit diffuse radiance from a ring A just
    above the surface, sees ``E_S[∫_A R(|x − x_c|) dx]`` — the fraction of pencil-beam power
    leaving within A − x_c — plus the specular F(1) where x_c ∈ A. Both Mitsuba and the walk
    estimate exactly that number for every ring of texels (the walk's exit radius given a
    uniform azimuth and x_c drawn in S)."""
    rings = ring_texels()
    groups = math.ceil((len(RINGS)) / 3)
    start = time.perf_counter()
    values = np.zeros((PROFILE_RUNS, 16 * 16, groups * 3))  # every pixel an independent mean
    for group in range(groups):
        scene = mi.load_dict(
            {
                "type": "scene",
                "integrator": {"type": "volpath", "max_depth": -1},
                "sensor": looking_down(mi, SENSOR, 16),
                "rings": ring_emitter(mi, rings, group),
                "slab": slab_medium(mi),
            }
        )
        for seed in range(PROFILE_RUNS):
            image = ms.render(mi, scene, PROFILE_SPP, seed=seed)
            values[seed, :, 3 * group : 3 * group + 3] = image.reshape(-1, 3)
    seconds = time.perf_counter() - start
    values = values.reshape(-1, groups * 3)[:, : len(RINGS)]
    mitsuba = values.mean(0)
    mitsuba_stderr = values.std(0, ddof=1) / math.sqrt(values.shape[0])
    walk, walk_stderr = walk_rings(rings)
    z = (mitsuba - walk) / np.hypot(mitsuba_stderr, walk_stderr)
    return {
        "variant": variant,
        "ring_edges": [float(e) for e in RINGS],
        "sensor_half_width": SENSOR,
        "spp_per_ring": PROFILE_RUNS * PROFILE_SPP * 16 * 16,
        "mitsuba": mitsuba.tolist(),
        "mitsuba_stderr": mitsuba_stderr.tolist(),
        "walk": walk.tolist(),
        "walk_stderr": walk_stderr.tolist(),
        "z": z.tolist(),
        "max_abs_z": float(np.max(np.abs(z))),
        "chi2": float(np.sum(z * z)),
        "rings": len(RINGS),
        "mitsuba_seconds": seconds,
    }


def walk_rings(rings: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The walk's share of pencil-beam power leaving over each ring of texels (see
    :func:`mitsuba_profile`), with the specular F(1) in the ring holding the sensor."""
    fine = np.arange(0.0, REACH * 1.5, 0.001)
    tally = tally_walks(
        MITSUBA_ALBEDO, MITSUBA_ETA, 1.0, WALKS, seed=4, thickness=SLAB_DEPTH, edges=fine
    )
    rng = np.random.default_rng(5)
    radius = np.repeat(fine[:-1], tally.counts) + 0.001 * rng.random(tally.counts.sum())
    phi = 2 * np.pi * rng.random(radius.size)
    sensor = rng.uniform(-SENSOR, SENSOR, (radius.size, 2))
    exit_x = sensor[:, 0] + radius * np.cos(phi)
    exit_y = sensor[:, 1] + radius * np.sin(phi)
    column = np.floor((exit_x / REACH + 1) / 2 * TEXELS).astype(int)
    row = np.floor((exit_y / REACH + 1) / 2 * TEXELS).astype(int)
    on = (column >= 0) & (column < TEXELS) & (row >= 0) & (row < TEXELS)
    counts = np.bincount(rings[row[on], column[on]], minlength=len(RINGS))[: len(RINGS)]
    p = counts / tally.samples
    value = tally.transmitted_in * p
    stderr = tally.transmitted_in * np.sqrt(p * (1 - p) / (tally.samples - 1))
    value[0] += float(fresnel_dielectric(1.0, MITSUBA_ETA))
    return value, stderr


def lobe_sky() -> EnvironmentMap:
    """The sphere's light: a soft lobe around SKY_TOWARDS on a faint floor,
    L(ω) = 0.05 + 4 max(ω·l, 0)⁴, as a 32 × 64 lat-long map."""
    towards = np.asarray(SKY_TOWARDS) / np.linalg.norm(SKY_TOWARDS)
    radiance = 0.05 + 4 * np.maximum(latlong_directions(32, 64) @ towards, 0) ** 4
    return EnvironmentMap(np.repeat(radiance[..., None], 3, -1))


def blocks(image: np.ndarray, stderr: np.ndarray, mask: np.ndarray) -> tuple:
    """Means and standard errors of BLOCK × BLOCK pixel blocks wholly on the sphere."""
    side = image.shape[0] // BLOCK
    inner = mask.reshape(side, BLOCK, side, BLOCK).all(axis=(1, 3))
    mean = image.reshape(side, BLOCK, side, BLOCK, -1).mean(axis=(1, 3))
    spread = np.sqrt((stderr**2).reshape(side, BLOCK, side, BLOCK, -1).sum(axis=(1, 3)))
    return mean[inner], spread[inner] / BLOCK**2


def mitsuba_sphere(mi, ms, medium_values: tuple, table_errors: dict) -> dict:
    """A translucent sphere (``medium_values``: ω, σt, η; radius 1) under :func:`lobe_sky`:
    Mitsuba's ``volpath`` against brdfkit's reference walk (within noise: z-scores of 4 × 4
    pixel blocks against the combined standard error) and the diffusion models' separable BSSRDF
    renders
    (relative error of the mean and relative RMSE of the blocks) beside each model's error in
    the table (``table_errors``: the half-space at normal incidence)."""
    sky = lobe_sky()
    albedo, sigma_t, eta = medium_values
    transform = mi.ScalarTransform4f()
    sensor = looking_down(mi, 1.0, SPHERE_RESOLUTION)
    sensor["to_world"] = transform.look_at(origin=[10, 0, 0], target=[0, 0, 0], up=[0, 0, 1])
    scene = mi.load_dict(
        {
            "type": "scene",
            "integrator": {"type": "volpath", "max_depth": -1, "hide_emitters": True},
            "sensor": sensor,
            "sphere": {
                "type": "sphere",
                "bsdf": {"type": "dielectric", "int_ior": eta, "ext_ior": 1.0},
                "interior": {
                    "type": "homogeneous",
                    "albedo": {"type": "rgb", "value": albedo},
                    "sigma_t": sigma_t,
                    "phase": {"type": "isotropic"},
                },
            },
            "light": ms.envmap_emitter(mi, sky),
        }
    )
    start = time.perf_counter()
    runs = np.stack([ms.render(mi, scene, SPHERE_SPP, seed=seed) for seed in range(SPHERE_RUNS)])[
        ..., :1
    ]  # a grey scene: the channels are one path's
    mitsuba_seconds = time.perf_counter() - start
    mitsuba = runs.mean(0)
    mitsuba_stderr = runs.std(0, ddof=1) / math.sqrt(SPHERE_RUNS)
    medium = Medium(albedo, sigma_t, eta=eta)
    start = time.perf_counter()
    walk, walk_stderr = random_walk_sphere(medium, sky, SPHERE_RESOLUTION, SPHERE_WALKS, seed=7)
    walk_seconds = time.perf_counter() - start
    walk, walk_stderr = walk[..., :1], walk_stderr[..., :1]
    centres = (np.arange(SPHERE_RESOLUTION) + 0.5) / SPHERE_RESOLUTION * 2 - 1
    corner = (np.abs(centres) + 1 / SPHERE_RESOLUTION) ** 2
    on_sphere = corner[:, None] + corner[None, :] < 1  # pixels wholly on the sphere
    reference, reference_stderr = blocks(mitsuba, mitsuba_stderr, on_sphere)
    walk_blocks, walk_block_stderr = blocks(walk, walk_stderr, on_sphere)
    z = (walk_blocks - reference) / np.hypot(reference_stderr, walk_block_stderr)
    models = {}
    for model_type in MODELS:
        image = diffusion_sphere(model_type(medium), sky, SPHERE_RESOLUTION, 256)[..., :1]
        mean, _ = blocks(image, np.zeros_like(image), on_sphere)
        models[model_type.name] = {
            "documented": table_errors[model_type.name]["total"],
            "mean": float(mean.mean() / reference.mean() - 1),
            "block_rmse": float(np.sqrt(np.mean((mean - reference) ** 2) / np.mean(reference**2))),
        }
    return {
        "medium": {"albedo": albedo, "sigma_t": sigma_t, "eta": eta, "radius": 1.0},
        "resolution": SPHERE_RESOLUTION,
        "mitsuba_spp": SPHERE_RUNS * SPHERE_SPP,
        "walk_spp": SPHERE_WALKS,
        "blocks": int(z.size),
        "walk_z_mean": float(z.mean()),
        "walk_z_std": float(z.std()),
        "walk_max_abs_z": float(np.abs(z).max()),
        "walk_mean_ratio": float(walk_blocks.mean() / reference.mean()),
        "models": models,
        "mitsuba_blocks": reference.ravel().tolist(),
        "mitsuba_seconds": mitsuba_seconds,
        "walk_seconds": walk_seconds,
    }


def mitsuba_comparisons(cases: list[dict]) -> dict:
    """The slab's total reflectance and radial profile and the spheres against Mitsuba
    (``None`` each without Mitsuba)."""
    try:
        from brdfkit.interop import mitsuba as ms

        mi, variant = ms.load_mitsuba(("llvm_ad_rgb", "scalar_rgb"))
    except ImportError:
        return {"mitsuba": None, "mitsuba_profile": None, "mitsuba_spheres": None}
    return {
        "mitsuba": mitsuba_slab(mi, ms, variant),
        "mitsuba_profile": mitsuba_profile(mi, ms, variant),
        "mitsuba_spheres": {
            name: mitsuba_sphere(mi, ms, values, documented(cases, values))
            for name, values in SPHERE_MEDIA.items()
        },
    }


def documented(cases: list[dict], medium_values: tuple) -> dict:
    """The table's errors of the case with the sphere medium's ω and η."""
    albedo, _, eta = medium_values
    return next(c for c in cases if c["albedo"] == albedo and c["eta"] == eta)["errors"]


def spheres_only() -> None:
    """Rerun part 4 alone (``--spheres-only``), keeping parts 1–3 of the results file (their
    machine record kept as ``machine_of_parts_1_to_3``)."""
    import json

    from _machine import results_path, write_results

    record = json.loads(results_path(__file__).read_text(encoding="utf-8"))
    earlier = record.pop("machine_of_parts_1_to_3", record["machine"])
    for key in ("benchmark", "command", "machine"):
        record.pop(key)
    from brdfkit.interop import mitsuba as ms

    mi, _ = ms.load_mitsuba(("llvm_ad_rgb", "scalar_rgb"))
    record["mitsuba_spheres"] = {
        name: mitsuba_sphere(mi, ms, values, documented(record["cases"], values))
        for name, values in SPHERE_MEDIA.items()
    }
    record["machine_of_parts_1_to_3"] = earlier
    print(f"wrote {write_results(__file__, record, packages=('mitsuba',))}")
    print(record["mitsuba_spheres"])


def main() -> None:
    from _machine import write_results

    if "--spheres-only" in sys.argv[1:]:
        spheres_only()
        return
    start = time.perf_counter()
    chandrasekhar = chandrasekhar_rows()
    cases = [
        model_errors(albedo, eta, seed=10 + i)
        for i, (eta, albedo) in enumerate((e, a) for e in ETAS for a in ALBEDOS)
    ]
    walk_seconds = time.perf_counter() - start
    record = {
        "walks": WALKS,
        "edges": [float(e) for e in EDGES],
        "near_radius": NEAR,
        "chandrasekhar": chandrasekhar,
        "cases": cases,
        "walk_seconds": walk_seconds,
        **mitsuba_comparisons(cases),
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
    for key in ("mitsuba", "mitsuba_profile", "mitsuba_spheres"):
        print(key, record[key])


if __name__ == "__main__":
    main()
