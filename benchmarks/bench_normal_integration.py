"""Normal integration on the real DiLiGenT ground-truth normals, against bilateral normal
integration (BiNI, Cao et al. ECCV 2022) run from its public code in the same run.

For each object of ``../shared/data/normal_integration/diligent`` (perspective, its ``K``):
brdfkit's default ``brdfkit integrate`` method (bilateral), brdfkit's masked least squares and
the peer's ``bilateral_normal_integration`` with the settings of its own DiLiGenT evaluation
(``k = 2``, ``max_iter = 100``, ``tol = 1e-4``; its file is imported from ``--peer``, the
folder of a checkout of github.com/xucao-42/bilateral_normal_integration, never copied here).
Each method reads the files with its own reader, outside the timing. Scored as the peer's
``evaluation_diligent.py`` scores: MADE, the mean ``|s z - z_gt|`` in mm with ``s`` the median
of ``z_gt / z``. Wall seconds of the integration alone, brdfkit then the peer on each object
(the same load on both), after each has compiled its kernels (the peer at import, brdfkit on a
4 × 4 map). The peer needs pyvista, tqdm and OpenCV.

    python benchmarks/bench_normal_integration.py --peer PATH [--data ../shared/data]
        [--objects bear cat ...]
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
from pathlib import Path

import numpy as np

from brdfkit.vision import datasets
from brdfkit.vision.depth_from_normals import DEFAULT_METHOD, METHODS

PEER_FILE = "bilateral_normal_integration_cpu.py"
"""The peer's fast CPU implementation (the one its evaluation imports)."""


def made(depth: np.ndarray, truth: np.ndarray) -> float:
    """The peer's evaluation: mean ``|s z - z_gt|`` with ``s`` the median of ``z_gt / z``."""
    scale = np.nanmedian(truth / depth)
    return float(np.nanmean(np.abs(scale * depth - truth)))


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


def run_object(folder: Path, peer) -> dict[str, float]:
    """MADE and seconds of brdfkit's default, its least squares and the peer on one object."""
    data = datasets.load_normal_integration(folder)
    normals, mask, camera = read_as_peer(folder)
    ours, ours_s = timed(lambda: METHODS[DEFAULT_METHOD](data.normals, data.mask, data.camera))
    theirs, theirs_s = timed(
        lambda: peer(normals, mask, k=2, K=camera, max_iter=100, tol=1e-4)[0]
    )  # fmt: skip
    squares, squares_s = timed(
        lambda: METHODS["least_squares"](data.normals, data.mask, data.camera)
    )  # fmt: skip
    return {
        "pixels": int(data.mask.sum()),
        "brdfkit_made_mm": made(ours, data.depth),
        "brdfkit_seconds": ours_s,
        "bini_made_mm": made(theirs, data.depth),
        "bini_seconds": theirs_s,
        "least_squares_made_mm": made(squares, data.depth),
        "least_squares_seconds": squares_s,
    }


def main() -> None:
    default = os.environ.get(
        "BRDFKIT_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"
    )
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--peer", type=Path, required=True, help=f"folder holding {PEER_FILE}")
    parser.add_argument("--data", type=Path, default=Path(default))
    parser.add_argument("--objects", nargs="+", default=None)
    args = parser.parse_args()
    root = args.data / "normal_integration" / "diligent"
    names = args.objects or sorted(p.name for p in root.iterdir() if p.is_dir())
    peer, digest = load_peer(args.peer)
    flat = np.zeros((4, 4, 3))
    flat[..., 2] = 1.0
    METHODS[DEFAULT_METHOD](flat, None)  # compiles brdfkit's kernel or loads its cache
    objects = {}
    for name in names:
        objects[name] = run_object(root / name, peer)
        print(json.dumps({"object": name, **objects[name]}), flush=True)
    wins = sum(o["brdfkit_made_mm"] <= o["bini_made_mm"] for o in objects.values())
    summary = {
        "objects": len(objects),
        "brdfkit_made_at_most_bini": wins,
        "brdfkit_mean_made_mm": float(np.mean([o["brdfkit_made_mm"] for o in objects.values()])),
        "bini_mean_made_mm": float(np.mean([o["bini_made_mm"] for o in objects.values()])),
        "brdfkit_total_seconds": float(sum(o["brdfkit_seconds"] for o in objects.values())),
        "bini_total_seconds": float(sum(o["bini_seconds"] for o in objects.values())),
    }
    print(json.dumps(summary))
    from _machine import write_results

    record = {
        "method": DEFAULT_METHOD,
        "peer": {"file": PEER_FILE, "sha256": digest, "k": 2, "max_iter": 100, "tol": 1e-4},
        "objects": objects,
        "summary": summary,
    }
    write_results(__file__, record, packages=("pyvista", "opencv-python-headless"))


if __name__ == "__main__":
    main()
