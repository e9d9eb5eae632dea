"""Dask: batch-fitting scaling 1 → 2 workers, and out-of-core photometric stereo under a memory
limit.

1. **Batch scaling.** ``--fits`` fits in the pattern of Ngan et al.'s study, every file ×
   every model: ``--fits / --models-per-file`` distinct MERL files (written from Lambertian +
   GGX, each with its own albedo and roughness), each fitted with the first
   ``--models-per-file`` of :data:`MODELS` (one start), run by
   :func:`brdfkit.distributed.batch.run` on a LocalCluster of 1 worker process and of 2, each
   cluster started before its clock starts; the two are **interleaved** ``--repeats`` times
   (1, 2, 1, 2, …) and the minimum of each is kept. Speed-up = t(1 worker) / t(2 workers).
   Every repeat runs the same fits, so the two minima time the same work.
   A file is prepared (read, hashed, made into samples) once per batch by a task that its
   fits depend on, and Dask runs the fits where the samples are: "moved" counts the prepared
   files a worker received from the other (80 MB each); ``--models-per-file 1`` is the case
   where every fit has a file of its own.
   The workers are ``brdfkit fit``'s (:func:`brdfkit.distributed.cluster.local_cluster` with
   ``keep_memory``: freed memory kept for the next fit, see ``KEEP_MEMORY_CONFIG``).
   Each worker first fits a file outside the batch with each model, outside the clock (imports
   and JIT compilation or loading of the models' kernels, seconds per process: the steady state
   is measured, as compile time is kept apart elsewhere).
   "Cores busy" = the workers' CPU seconds per wall second: near 1 and 2 on a quiet machine;
   when the 2-worker run gets no more than the 1-worker one, the machine had no core to give.
   "CPU per fit" = the workers' CPU seconds over the fits: equal for 1 and 2 workers when the
   two processes do not slow each other down (through shared memory bandwidth and caches).
2. **Out of core.** A Lambertian sphere stack ``(N, H, W, 3)`` float32 is written straight to a
   Zarr store (one band at a time), several times larger than the memory limit given to the
   workers (LocalCluster ``memory_limit``; Dask pauses a worker at 80 % of it and restarts one
   at 95 %), then :func:`brdfkit.distributed.tiled.solve` runs least squares tile by tile.
   Reported: stack bytes, the limit per worker and in all, each worker's peak resident memory
   (``VmHWM`` of ``/proc/self/status``: the kernel's high-water mark, imports included), the solve's
   seconds and pixels per second, and the mean angular error against the sphere.

Prints a summary and one JSON object, and writes it to ``benchmarks/results/dask.json``
(``--json-out FILE``: elsewhere). The machine may be shared: timings are noisy, the
interleaving is there to spread bursts of load over both sides.

    python benchmarks/bench_dask.py  # --fits 8 --models-per-file 4 --repeats 2 --size 2304
    # --limit 256MiB
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def _peak_rss() -> int:
    """This process's peak resident memory since its ``exec`` (``VmHWM``; ``ru_maxrss`` would
    carry the parent's peak across the fork and exec that start a worker)."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) * 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


MODELS = ("lambertian + ggx", "lambertian + beckmann", "lambertian + ward",
          "lambertian + cook_torrance", "lambertian + blinn_phong")  # fmt: skip
"""The models of a file's fits, in this order (Ngan et al. fit seven to each material)."""


def _transfers(dask_worker) -> int:
    """Data a worker received from another (a file's samples prepared elsewhere)."""
    return dask_worker.state.transfer_incoming_count_total


def batch_scaling(fits: int, models_per_file: int, repeats: int, folder: Path) -> dict:
    from brdfkit.brdf import parse
    from brdfkit.distributed import batch
    from brdfkit.distributed.cluster import local_cluster
    from brdfkit.measured import write_merl
    from distributed import Client

    count = -(-fits // models_per_file)
    files = []
    for k in range(count + 1):  # the last one only warms the workers up
        files.append(folder / f"m{k}.binary")
        rho, alpha = 0.2 + 0.5 * k / count, 0.08 + 0.3 * ((k * 5) % count) / count
        write_merl(files[-1], parse(f"lambertian(rho={rho:.3f}) + ggx(alpha={alpha:.3f})"))
    options = {"objective": "cube_root", "loss": "soft_l1", "loss_scale": 0.5, "mode": "shared",
               "starts": 1, "fixed": [], "seed": 0}  # fmt: skip
    tasks = batch.tasks(files[:-1], MODELS[:models_per_file], **options)[:fits]
    warm = batch.tasks(files[-1:], MODELS[:models_per_file], **options)
    times: dict[int, list[float]] = {1: [], 2: []}
    cores: dict[int, list[float]] = {1: [], 2: []}  # worker CPU seconds per wall second
    cpu_per_fit: dict[int, list[float]] = {1: [], 2: []}
    moved: dict[int, list[int]] = {1: [], 2: []}  # prepared files sent between workers
    for repeat in range(repeats):
        for workers in (1, 2):
            with local_cluster(workers, keep_memory=True) as cluster, Client(cluster) as client:
                # imports and each worker's first fit of each model (the JIT compilation or
                # disk-cache loading of its kernels, seconds) outside the clock, as compile
                # time is kept apart in the other benchmarks
                for task in warm:
                    client.run(batch.fit_one, task)
                cpu = sum(client.run(time.process_time).values())
                began = time.perf_counter()
                done: list[str] = []
                batch.run(
                    client, tasks, lambda task, record, done=done: done.append(record["status"])
                )
                times[workers].append(time.perf_counter() - began)
                cpu = sum(client.run(time.process_time).values()) - cpu
                cores[workers].append(cpu / times[workers][-1])
                moved[workers].append(sum(client.run(_transfers).values()))
                cpu_per_fit[workers].append(cpu / len(tasks))
            assert done.count("ok") == len(tasks), done
            print(f"  batch repeat {repeat + 1}: {workers} worker(s) {times[workers][-1]:.1f} s, "
                  f"{cores[workers][-1]:.2f} cores busy, "
                  f"{cpu_per_fit[workers][-1]:.3f} CPU s per fit, {moved[workers][-1]} "
                  f"prepared files moved", file=sys.stderr)  # fmt: skip
    best = {w: min(t) for w, t in times.items()}
    return {"fits": len(tasks), "distinct_files": count, "models": list(MODELS[:models_per_file]),
            "repeats": repeats, "seconds": times, "best_seconds": best, "cores_busy": cores,
            "cpu_seconds_per_fit": cpu_per_fit, "prepared_files_moved": moved,
            "speedup_1_to_2": best[1] / best[2]}  # fmt: skip


def out_of_core(size: int, lights: int, limit: str, tile: int, folder: Path) -> dict:
    import dask
    import zarr
    from dask.utils import parse_bytes

    from brdfkit.distributed import tiled
    from brdfkit.distributed.cluster import local_cluster
    from brdfkit.vision.datasets import diligent_like_lights
    from brdfkit.vision.photometric_stereo import sphere_normals
    from distributed import Client

    directions = diligent_like_lights(lights // 4, 4, np.radians(30))
    store = folder / "stack.zarr"
    stack = zarr.open_array(store, mode="w", shape=(len(directions), size, size, 3),
                            chunks=(1, tile, tile, 3), dtype="float32")  # fmt: skip
    centre, radius = (size - 1) / 2, size / 2 - 1
    mask = np.zeros((size, size), bool)
    albedo = np.array([0.7, 0.5, 0.3])
    began = time.perf_counter()
    for r in range(0, size, tile):  # one band of rows at a time
        rows = slice(r, min(r + tile, size))
        normals, inside = sphere_normals((size, size), (centre, centre - r), radius)
        normals, inside = normals[: rows.stop - r], inside[: rows.stop - r]
        mask[rows] = inside
        shading = np.clip(np.einsum("hwj,nj->nhw", normals, directions), 0, None) * inside
        stack[:, rows] = (shading[..., None] * albedo).astype(np.float32)
    write_seconds = time.perf_counter() - began
    stack_bytes = 4 * len(directions) * size * size * 3
    info = tiled.Stack(str(store), directions, mask, tile, "sphere", None,
                       (len(directions), size, size, 3))  # fmt: skip
    with (
        dask.config.set({"distributed.worker.memory.spill": False}),
        local_cluster(2, limit) as cluster,
        Client(cluster) as client,
    ):
        client.run(lambda: __import__("brdfkit.vision.photometric_stereo"))
        began = time.perf_counter()
        tiled.solve(info, "least_squares", folder / "n.zarr", folder / "a.zarr")
        seconds = time.perf_counter() - began
        peaks = sorted(client.run(_peak_rss).values())
        restarts = len(cluster.workers)  # still the two it started with (no restart)
    normals = zarr.open_array(folder / "n.zarr")[:]
    truth, _ = sphere_normals((size, size), (centre, centre), radius)
    lit = mask & np.all(truth @ directions.T > 0, axis=-1)  # attached shadows bias LS elsewhere
    cosine = np.clip(np.sum(normals[lit] * truth[lit], axis=1), -1, 1)
    per_worker = parse_bytes(limit)
    return {
        "stack_shape": [len(directions), size, size, 3], "stack_bytes": stack_bytes,
        "limit_per_worker_bytes": per_worker, "workers": 2, "limit_total_bytes": 2 * per_worker,
        "stack_over_total_limit": stack_bytes / (2 * per_worker),
        "worker_peak_rss_bytes": peaks, "peak_under_limit": max(peaks) < per_worker,
        "workers_at_end": restarts, "tile": tile, "solve_seconds": seconds,
        "pixels_per_second": size * size / seconds, "write_seconds": write_seconds,
        "mean_angular_error_deg_all_lit": float(np.degrees(np.arccos(cosine)).mean()),
    }  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fits", type=int, default=8)
    parser.add_argument("--models-per-file", type=int, default=4, choices=range(1, 6),
                        help="fits per file (each with another model)")  # fmt: skip
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--size", type=int, default=2304, help="stack image side (pixels)")
    parser.add_argument("--lights", type=int, default=32)
    parser.add_argument("--limit", default="256MiB", help="memory limit per worker")
    parser.add_argument("--tile", type=int, default=128)
    parser.add_argument("--skip-batch", action="store_true")
    parser.add_argument("--skip-ooc", action="store_true")
    parser.add_argument("--json-out", type=Path, help="default: benchmarks/results/dask.json")
    args = parser.parse_args()
    report = {"cpus": os.cpu_count(), "load_average": os.getloadavg()}
    with tempfile.TemporaryDirectory(prefix="bench-dask-") as scratch:
        if not args.skip_batch:
            report["batch"] = batch_scaling(
                args.fits, args.models_per_file, args.repeats, Path(scratch)
            )
        if not args.skip_ooc:
            report["out_of_core"] = out_of_core(args.size, args.lights, args.limit, args.tile,
                                                Path(scratch))  # fmt: skip
    report["load_average_after"] = os.getloadavg()
    if "batch" in report:
        b = report["batch"]
        print(f"batch fitting: {b['fits']} fits ({b['distinct_files']} distinct files x "
              f"{len(b['models'])} models), best of {b['repeats']}: 1 worker "
              f"{b['best_seconds'][1]:.1f} s, 2 workers {b['best_seconds'][2]:.1f} s -> speed-up "
              f"{b['speedup_1_to_2']:.2f}x (target >= 1.8x); cores busy "
              f"{[round(c, 2) for c in b['cores_busy'][1]]} and "
              f"{[round(c, 2) for c in b['cores_busy'][2]]}; CPU s per fit "
              f"{[round(c, 3) for c in b['cpu_seconds_per_fit'][1]]} and "
              f"{[round(c, 3) for c in b['cpu_seconds_per_fit'][2]]}")  # fmt: skip
    if "out_of_core" in report:
        o = report["out_of_core"]
        mib = 2**20
        peaks = [round(p / mib) for p in o["worker_peak_rss_bytes"]]
        print(f"out-of-core PS: stack {o['stack_bytes'] / 2**30:.2f} GiB "
              f"{tuple(o['stack_shape'])}, limit {o['limit_per_worker_bytes'] / mib:.0f} MiB x 2 "
              f"workers = {o['limit_total_bytes'] / mib:.0f} MiB "
              f"(stack {o['stack_over_total_limit']:.1f}x that), worker peaks {peaks} MiB, "
              f"under limit: {o['peak_under_limit']}; {o['pixels_per_second'] / 1e6:.3f} "
              f"Mpixel/s ({o['solve_seconds']:.1f} s), "
              f"error {o['mean_angular_error_deg_all_lit']:.2g}°")  # fmt: skip
    from _machine import header, results_path

    text = json.dumps({**header(__file__, packages=("dask", "distributed", "zarr")), **report},
                      indent=1)  # fmt: skip
    print(text)
    (args.json_out or results_path(__file__)).write_text(text + "\n")


if __name__ == "__main__":
    main()
