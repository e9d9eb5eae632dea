"""Accuracy of the exports that another renderer evaluates: Mitsuba 3 XML and RGL tables.

- ``mitsuba``: the models of ``tests/interop/test_mitsuba_export.py``, each exported to a ``<bsdf>``
  document, loaded by ``mi.load_string`` (``scalar_rgb``) and evaluated at ``--pairs`` uniform
  direction pairs (half through the interface for a dielectric); p99 and largest relative
  error of f against brdfkit's ``eval``.
- ``rgl``: analytic models tabulated by :func:`brdfkit.measured.write_rgl` at a few sample-square
  resolutions; time to write, file size, and the median, 90th and 99th percentile relative error
  of the table (brdfkit's reader, which equals Mitsuba's ``measured`` plugin: the largest
  difference of the two on ``--mitsuba-pairs`` pairs is recorded) against the model at
  ``--pairs`` uniform pairs. The relative error's floor is 10⁻³ of the model's largest value.

    python benchmarks/bench_export.py [--pairs 20000] [--mitsuba-pairs 300]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from brdfkit.brdf import (
    GGXConductor,
    Lambertian,
    Principled,
    RoughConductor,
    RoughDielectric,
    RoughPlastic,
    SmoothPlastic,
)
from brdfkit.interop import to_mitsuba_xml
from brdfkit.measured import read_rgl, write_rgl

RGL_CASES = [
    ("GGX α=0.3 gold", RoughConductor(alpha=0.3, material="Au"), (32, 64)),
    ("GGX α=0.1 gold", RoughConductor(alpha=0.1, material="Au"), (32, 64)),
    ("Lambertian + GGX α=0.05", Lambertian([0.5, 0.1, 0.1]) + 0.3 * GGXConductor(alpha=0.05),
     (32, 64)),
    ("GGX α=(0.1, 0.3) copper (anisotropic)", RoughConductor(alpha_u=0.1, alpha_v=0.3,
                                                             material="Cu"), (32,)),
]  # fmt: skip


PERCENTILES = {"median": 50, "p90": 90, "p99": 99}
MITSUBA_CASES = {
    "Lambertian": Lambertian([0.2, 0.5, 0.8]),
    "GGX anisotropic gold": RoughConductor(
        alpha_u=0.1, alpha_v=0.4, material="Au", masking="smith_separable"
    ),
    "Beckmann copper": RoughConductor(
        alpha=0.25, distribution="beckmann", material="Cu", masking="smith_separable",
        approximate_g1=True,
    ),
    "rough dielectric": RoughDielectric(alpha=0.3, eta=1.5),
    "plastic": SmoothPlastic(diffuse_reflectance=[0.8, 0.3, 0.1], eta=1.5, internal="mitsuba"),
    "rough plastic, nonlinear": RoughPlastic(
        alpha=0.3, distribution="ggx", diffuse_reflectance=0.9, nonlinear=True, internal="mitsuba"
    ),
    "principled": Principled(
        base_color=[0.5, 0.8, 0.3], metallic=0.4, roughness=0.4, anisotropic=0.8, specular=0.8,
        specular_tint=0.6, clearcoat=0.5,
    ),
    "Lambertian + 2 GGX + Lambertian": Lambertian([0.5, 0.1, 0.1])
    + 2.0 * RoughConductor(alpha=0.1, eta=1.5, k=0.0, masking="smith_separable")
    + Lambertian(0.2),
}  # fmt: skip
"""The models of the Mitsuba test (``tests/interop/test_mitsuba_export.py``)."""


def directions(n: int, seed: int) -> np.ndarray:
    v = np.random.default_rng(seed).normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    v[:, 2] = np.abs(v[:, 2])
    return v


def relative(values: np.ndarray, reference: np.ndarray) -> np.ndarray:
    return np.abs(values - reference) / np.maximum(
        np.abs(reference), 1e-3 * np.abs(reference).max()
    )


def mitsuba_f(mi, bsdf, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
    ctx, out = mi.BSDFContext(), []
    for light, view in zip(wi, wo, strict=True):
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(*map(float, view))
        si.sh_frame = mi.Frame3f(mi.Normal3f(0, 0, 1))
        out.append(np.array(bsdf.eval(ctx, si, mi.Vector3f(*map(float, light)))) / abs(light[2]))
    return np.array(out)


def mitsuba_rows(mi, pairs: int) -> list[dict]:
    rows = []
    for name, brdf in MITSUBA_CASES.items():
        wi, wo = directions(pairs, 1), directions(pairs, 2)
        if brdf.transmits:
            wi[::2, 2] *= -1
        theirs = mitsuba_f(mi, mi.load_string(to_mitsuba_xml(brdf)), wi, wo)
        ours = np.broadcast_to(brdf.eval(wi, wo), theirs.shape)
        err = np.abs(ours - theirs) / np.maximum(np.abs(theirs), 1e-6 * np.abs(theirs).max())
        rows.append({"model": name, "pairs": pairs, "p99": float(np.percentile(err, 99)),
                     "max": float(err.max())})  # fmt: skip
        print(f"| {name} | {pairs} | {rows[-1]['p99']:.1e} | {rows[-1]['max']:.1e} |", flush=True)
    return rows


def rgl_rows(mi, pairs: int, mitsuba_pairs: int) -> list[dict]:
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for name, brdf, resolutions in RGL_CASES:
            for resolution in resolutions:
                path = Path(folder) / "table.bsdf"
                start = time.perf_counter()
                write_rgl(brdf, path, resolution=resolution)
                seconds = time.perf_counter() - start
                table = read_rgl(path)
                wi, wo = directions(pairs, 3), directions(pairs, 4)
                err = relative(table.eval(wi, wo), brdf.eval(wi, wo)).max(axis=-1)
                row = {
                    "model": name,
                    "resolution": resolution,
                    "seconds": seconds,
                    "bytes": path.stat().st_size,
                    **{k: float(np.percentile(err, q)) for k, q in PERCENTILES.items()},
                }
                if mi is not None:
                    a, b = wi[:mitsuba_pairs], wo[:mitsuba_pairs]
                    theirs = mitsuba_f(
                        mi, mi.load_dict({"type": "measured", "filename": str(path)}), a, b
                    )
                    row["reader_vs_mitsuba_max"] = float(relative(table.eval(a, b), theirs).max())
                rows.append(row)
                print(f"| {name} | {resolution} | {seconds:.1f} | {row['median']:.2%} | "
                      f"{row['p90']:.1%} | {row['p99']:.1%} |", flush=True)  # fmt: skip
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=20000, help="direction pairs per model")
    parser.add_argument("--mitsuba-pairs", type=int, default=300, help="pairs for Mitsuba loops")
    args = parser.parse_args()
    try:
        import mitsuba as mi

        mi.set_variant("scalar_rgb")
    except ImportError:
        mi = None
    print("| model | pairs | p99 relative error | largest |\n|---|---:|---:|---:|")
    mitsuba = mitsuba_rows(mi, args.mitsuba_pairs * 10) if mi is not None else []
    print("\n| model | resolution | s | median | p90 | p99 |\n|---|---:|---:|---:|---:|---:|")
    rgl = rgl_rows(mi, args.pairs, args.mitsuba_pairs)
    record = {"mitsuba": mitsuba, "rgl": rgl}
    print(json.dumps(record))
    from _machine import write_results

    write_results(__file__, record, packages=("mitsuba",))


if __name__ == "__main__":
    main()
