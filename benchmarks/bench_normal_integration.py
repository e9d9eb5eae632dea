"""Normal integration on the real DiLiGenT ground-truth normals, against bilateral normal
integration (BiNI, Cao et al. ECCV 2022) run from its public code in the same run.

For each object of ``../shared/data/normal_integration/diligent`` (perspective, its ``K``):
brdfkit's default ``brdfkit integrate`` method (bilateral integration with each piece's scale
from least squares, ``bilateral_pieces``), brdfkit's masked least squares and
the peer's ``bilateral_normal_integration`` with the settings of its own DiLiGenT evaluation
(``k = 2``, ``max_iter = 100``, ``tol = 1e-4``; its file is imported from ``--peer``, the
folder of a checkout of github.com/xucao-42/bilateral_normal_integration, never copied here).
Each method reads the files with its own reader, outside the timing (brdfkit's the one of
``brdfkit integrate``, ``read_normal_map_input``). Scored as the peer's
``evaluation_diligent.py`` scores: MADE, the mean ``|s z - z_gt|`` in mm with ``s`` the median
of ``z_gt / z``. Wall seconds of the integration alone, brdfkit then the peer on each object
(the same load on both), after each has compiled its kernels (the peer at import, brdfkit on a
4 × 4 map). The peer needs pyvista, tqdm and OpenCV.

Beside the real objects, not counted in the summary, both integrate scenes rendered in their
camera (:data:`RENDERED`): a ball, whose silhouette's grazing normals the seven objects' masks
barely have, and three overlapping spheres, whose occluding contours part the surface.

A second score separates the shape of each piece from what the normals cannot tell: in
perspective, scaling part of a surface about the camera centre leaves its normals unchanged, so
the relative scale of pieces joined only across occluding contours (goblet's stem and foot
behind its cup) is not in the data. *Piecewise MADE* scales each ground-truth piece by its own
median ratio; the pieces are the connected parts of the mask once neighbours whose true depths
differ by more than ``JUMP_MM`` are parted.

``--variants`` adds rows for bilateral integration with other settings, all through its public
options: the authors' method alone, then with the sigmoid's sharpness ``k = 1`` and ``k = 4``
either side of their 2, with the conjugate-gradient tolerance 10 % either side of their 1e-3
(how much their result hangs on where the inexact solves stop), the piece cut at 0.5 % and 2 %
either side of the default 1 %, the continuity prior (the previous default) at 0.1 %, 1 %
and 10 %, and ``prior``: the default given the true depth at one pixel in 256 with 2 mm of
noise (a depth sensor's) as ``--prior``.

    python benchmarks/bench_normal_integration.py --peer PATH [--data ../shared/data]
        [--objects bear cat ...] [--variants]
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import io
import json
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from brdfkit.vision import datasets
from brdfkit.vision.bilateral_integration import bilateral_integration
from brdfkit.vision.depth_from_normals import DEFAULT_METHOD, METHODS, read_normal_map_input

PEER_FILE = "bilateral_normal_integration_cpu.py"
"""The peer's fast CPU implementation (the one its evaluation imports)."""

JUMP_MM = 5.0
"""Neighbours whose true depths differ by more than this are in different pieces (at DiLiGenT's
0.4 mm pixels at 1.5 m, a surface steeper than 85° from the view)."""

VARIANTS = {
    "bilateral": {},
    "bilateral_k1": {"k": 1.0},
    "bilateral_k4": {"k": 4.0},
    "bilateral_solver_tolerance_0.0009": {"solver_tolerance": 9e-4},
    "bilateral_solver_tolerance_0.0011": {"solver_tolerance": 1.1e-3},
    "pieces_0.005": {"pieces": 5e-3},
    "pieces_0.02": {"pieces": 2e-2},
    "continuity_0.001": {"continuity": 1e-3},
    "continuity_0.01": {"continuity": 1e-2},
    "continuity_0.1": {"continuity": 0.1},
}
"""The options of ``bilateral_integration`` in each ``--variants`` row."""

TIE_MM = 1e-6
"""MADEs closer than this are equal (and count as at most the peer's): a nanometre is the
last bits of two implementations of one method, not a difference in the depth."""

RENDERED = {
    "ball": ((0.0, 0.0, -1500.0, 47.7),),
    "three spheres": (
        (0.0, 0.0, -1500.0, 40.0), (35.0, -20.0, -1470.0, 18.0), (-40.0, 25.0, -1550.0, 30.0),
    ),
}  # fmt: skip
"""Scenes rendered beside the real objects in their camera, exact normals and depth, each
sphere ``(x, y, z, radius)`` in mm in the camera frame: a ball of DiLiGenT's ball's size
(about 120 pixels in radius, as ``bench_ps_materials.py``'s), whose silhouette grazes, and
three overlapping spheres, whose occluding contours part pieces and slivers."""

PRIOR_EVERY, PRIOR_NOISE_MM = 16, 2.0
"""The ``prior`` variant: the true depth at one pixel in ``PRIOR_EVERY²`` with Gaussian noise
of ``PRIOR_NOISE_MM``, as a depth sensor might give it, through ``--prior``."""


def made(depth: np.ndarray, truth: np.ndarray) -> float:
    """The peer's evaluation: mean ``|s z - z_gt|`` with ``s`` the median of ``z_gt / z``."""
    scale = np.nanmedian(truth / depth)
    return float(np.nanmean(np.abs(scale * depth - truth)))


def pieces(truth: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Label of each mask pixel's ground-truth piece (see :data:`JUMP_MM`), -1 outside."""
    import scipy.sparse
    from scipy.sparse.csgraph import connected_components

    index = np.full(mask.shape, -1)
    index[mask] = np.arange(int(mask.sum()))
    pairs = []
    for a, b in ((np.s_[:, :-1], np.s_[:, 1:]), (np.s_[:-1, :], np.s_[1:, :])):
        joined = mask[a] & mask[b] & (np.abs(truth[a] - truth[b]) <= JUMP_MM)
        pairs.append((index[a][joined], index[b][joined]))
    p, q = (np.concatenate(side) for side in zip(*pairs, strict=True))
    graph = scipy.sparse.coo_matrix((np.ones(len(p)), (p, q)), shape=(index.max() + 1,) * 2)
    labels = np.full(mask.shape, -1)
    labels[mask] = connected_components(graph, directed=False)[1]
    return labels


def piecewise_made(depth: np.ndarray, truth: np.ndarray, labels: np.ndarray) -> float:
    """MADE with each piece of ``labels`` scaled by its own median of ``z_gt / z``."""
    error = np.zeros(0)
    for label in range(labels.max() + 1):
        inside = labels == label
        scale = np.median(truth[inside] / depth[inside])
        error = np.concatenate([error, np.abs(scale * depth[inside] - truth[inside])])
    return float(error.mean())


def load_peer(folder: Path):
    """The peer's ``bilateral_normal_integration`` and the SHA-256 of its file."""
    os.environ.setdefault("TQDM_DISABLE", "1")
    sys.path.insert(0, str(folder))
    with contextlib.redirect_stdout(io.StringIO()):
        from bilateral_normal_integration_cpu import bilateral_normal_integration
    digest = hashlib.sha256((folder / PEER_FILE).read_bytes()).hexdigest()
    return bilateral_normal_integration, digest


def read_as_peer(folder: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The normal map, mask and ``K`` as the peer's evaluation reads them."""
    import cv2

    image = cv2.imread(str(folder / "normal_map.png"), cv2.IMREAD_UNCHANGED)
    normals = cv2.cvtColor(image, cv2.COLOR_RGB2BGR)
    normals = normals / (65535 if normals.dtype == np.uint16 else 255) * 2 - 1
    mask = cv2.imread(str(folder / "mask.png"), cv2.IMREAD_GRAYSCALE).astype(bool)
    return normals, mask, np.loadtxt(folder / "K.txt")


def timed(call) -> tuple[np.ndarray, float]:
    start = time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()):
        depth = call()
    return depth, time.perf_counter() - start


def sensor_prior(data) -> np.ndarray:
    """The ``prior`` variant's depths (:data:`PRIOR_EVERY`, :data:`PRIOR_NOISE_MM`), NaN
    elsewhere; the same noise for every object (seed 0)."""
    rng = np.random.default_rng(0)
    prior = np.full(data.depth.shape, np.nan)
    known = data.depth[::PRIOR_EVERY, ::PRIOR_EVERY]
    prior[::PRIOR_EVERY, ::PRIOR_EVERY] = known + rng.normal(0.0, PRIOR_NOISE_MM, known.shape)
    return np.where(data.mask, prior, np.nan)


def variants(data) -> dict[str, tuple[np.ndarray, float]]:
    """Depth and seconds of bilateral integration with each of :data:`VARIANTS`, and of
    ``brdfkit integrate``'s default with a sparse, noisy depth prior."""
    runs = {
        name: timed(lambda o=options: bilateral_integration(
            data.normals, data.mask, data.camera, **o).depth)
        for name, options in VARIANTS.items()
    }  # fmt: skip
    prior = sensor_prior(data)
    runs["prior"] = timed(
        lambda: METHODS[DEFAULT_METHOD](data.normals, data.mask, data.camera, depth_prior=prior)
    )
    return runs


def rendered(spheres: tuple, camera: np.ndarray) -> datasets.NormalIntegrationData:
    """The nearest surface of ``spheres`` (see :data:`RENDERED`) seen through ``camera`` in a
    612 × 512 image (:func:`brdfkit.vision.datasets.perspective_sphere` for each)."""
    scene = None
    for *centre, radius in spheres:
        ball = datasets.perspective_sphere((512, 612), camera, centre, radius)
        if scene is None:
            scene = ball
            continue
        nearer = ball.mask & ~(scene.depth <= ball.depth)  # NaN (no surface yet) compares False
        scene = replace(
            scene,
            normals=np.where(nearer[..., None], ball.normals, scene.normals),
            mask=scene.mask | ball.mask,
            depth=np.where(nearer, ball.depth, scene.depth),
        )
    return scene


def run_object(
    data: datasets.NormalIntegrationData, as_peer: tuple, peer, with_variants: bool = False
) -> dict[str, float]:
    """MADE, piecewise MADE and seconds of brdfkit's default, its least squares, the peer (and
    the variants) on one object; ``as_peer`` the normals, mask and ``K`` as the peer reads
    them."""
    normals, mask, camera = as_peer
    ours = timed(lambda: METHODS[DEFAULT_METHOD](data.normals, data.mask, data.camera))
    theirs = timed(lambda: peer(normals, mask, k=2, K=camera, max_iter=100, tol=1e-4)[0])
    squares = timed(lambda: METHODS["least_squares"](data.normals, data.mask, data.camera))
    runs = {"brdfkit": ours, "bini": theirs, "least_squares": squares}
    if with_variants:
        runs.update(variants(data))
    labels = pieces(data.depth, data.mask)
    record: dict[str, float] = {
        "pixels": int(data.mask.sum()),
        "pieces_over_100_pixels": int(np.sum(np.bincount(labels[data.mask]) > 100)),
    }
    for name, (depth, seconds) in runs.items():
        record[f"{name}_made_mm"] = made(depth, data.depth)
        record[f"{name}_piecewise_made_mm"] = piecewise_made(depth, data.depth, labels)
        record[f"{name}_seconds"] = seconds
    return record


def main() -> None:
    default = os.environ.get(
        "BRDFKIT_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"
    )
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--peer", type=Path, required=True, help=f"folder holding {PEER_FILE}")
    parser.add_argument("--data", type=Path, default=Path(default))
    parser.add_argument("--objects", nargs="+", default=None)
    parser.add_argument("--variants", action="store_true", help="add the variants' rows")
    args = parser.parse_args()
    root = args.data / "normal_integration" / "diligent"
    names = args.objects or sorted(p.name for p in root.iterdir() if p.is_dir())
    peer, digest = load_peer(args.peer)
    flat = np.zeros((4, 4, 3))
    flat[..., 2] = 1.0
    METHODS[DEFAULT_METHOD](flat, None)  # compiles brdfkit's kernel or loads its cache
    objects = {}
    for name in names:
        data = replace(  # the normals as brdfkit integrate reads them
            datasets.load_normal_integration(root / name),
            normals=read_normal_map_input(root / name).normals,
        )
        objects[name] = run_object(data, read_as_peer(root / name), peer, args.variants)
        print(json.dumps({"object": name, **objects[name]}), flush=True)
    scenes = {}
    for name, spheres in RENDERED.items():
        scene = rendered(spheres, data.camera)
        as_peer = (scene.normals, scene.mask, scene.camera)
        scenes[name] = {"spheres": spheres, **run_object(scene, as_peer, peer, args.variants)}
        print(json.dumps({"rendered": name, **scenes[name]}), flush=True)
    methods = [key.removesuffix("_seconds") for key in objects[names[0]] if "_seconds" in key]
    wins = sum(o["brdfkit_made_mm"] <= o["bini_made_mm"] + TIE_MM for o in objects.values())
    ties = sum(abs(o["brdfkit_made_mm"] - o["bini_made_mm"]) < TIE_MM for o in objects.values())
    summary = {
        "objects": len(objects),
        "brdfkit_made_at_most_bini": wins,
        "made_equal_to_bini": ties,
        "tie_mm": TIE_MM,
        "brdfkit_mean_made_mm": float(np.mean([o["brdfkit_made_mm"] for o in objects.values()])),
        "bini_mean_made_mm": float(np.mean([o["bini_made_mm"] for o in objects.values()])),
        "brdfkit_total_seconds": float(sum(o["brdfkit_seconds"] for o in objects.values())),
        "bini_total_seconds": float(sum(o["bini_seconds"] for o in objects.values())),
        **{
            f"{kind}_by_method": {
                method: float(np.mean([o[f"{method}_{kind}"] for o in objects.values()]))
                for method in methods
            }
            for kind in ("made_mm", "piecewise_made_mm")
        },
    }
    print(json.dumps(summary))
    from _machine import write_results

    record = {
        "method": DEFAULT_METHOD,
        "peer": {"file": PEER_FILE, "sha256": digest, "k": 2, "max_iter": 100, "tol": 1e-4},
        "objects": objects,
        "summary": summary,
        "rendered": scenes,
    }
    write_results(__file__, record, packages=("pyvista", "opencv-python-headless"))


if __name__ == "__main__":
    main()
