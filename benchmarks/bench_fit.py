"""Fitting a 3-lobe model to a MERL-sized table (90 × 90 × 180 × 3, ~1.46 M samples).

A MERL file is written from Lambertian + two GGX lobes (a sharp and a broad one), read back, and
``lambertian + ggx + ggx`` is fitted to it with :func:`brdfkit.fit.fit` (defaults: 4 starts on
4 000 samples, refinement on 30 000, errors on all measured nodes), with a rich progress bar on
stderr: by the default path (the Jacobian one lobe per column, one BLAS thread inside the least
squares) and, interleaved in the same run (``--repeats`` pairs), by the peer: scipy's
``"2-point"`` finite-difference Jacobian (P + 1 full evaluations, the process's BLAS threads).
The same run measures, on all the table's samples, one NumPy evaluation of the 3-lobe model
against one torch forward + backward pass (the cost of an autograd gradient), the comparison
behind the choice of finite-difference least squares on NumPy.

Prints one JSON object and writes it to ``benchmarks/results/fit.json``: wall time (and this
process's CPU seconds, the fairer figure on a machine busy with other work), samples, recovered
parameters, errors, and the timings. Run with two threads to reproduce the 2-core figure:
``OMP_NUM_THREADS=2 python benchmarks/bench_fit.py``.

``--contention``: instead, the CPU seconds per fit (``time.process_time``) of one process
fitting alone against two processes fitting at once, ``--fits`` fits each, the two set-ups
interleaved ``--repeats`` times (``--model``, ``--starts``: which fit; ``--model "lambertian +
ggx" --starts 1`` are the model and starts of ``benchmarks/bench_dask.py``'s batch, here on
this benchmark's table). On two free cores a fit that is not held back by a shared resource
takes the same CPU time either way; the ratio of the two (two processes over one) is what a
shared memory bus costs each fit, and bounds the scaling of batch fitting on two workers by
2 / ratio. On a machine busy with other work (load above the core count) the ratio is noise;
the CPU per fit still compares two versions of the code run one after the other. Its record
goes to the same file, in place of the fit's.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import brdfkit.fit.analytic as fitting
from brdfkit.brdf import MODELS, parse
from brdfkit.fit.analytic import fit, fit_data
from brdfkit.measured import read_merl, write_merl

TRUTH = (
    "lambertian(rho=[0.15, 0.1, 0.05]) + [0.3, 0.3, 0.35] * ggx(alpha=0.05) "
    "+ [0.4, 0.35, 0.3] * ggx(alpha=0.3)"
)
MODEL = "lambertian + ggx + ggx"


def torch_timing(data) -> dict[str, float]:
    """Seconds for one NumPy evaluation and one torch forward + backward of the model."""
    import torch

    torch.set_num_threads(int(os.environ.get("OMP_NUM_THREADS", "2")))
    model = parse(TRUTH)
    began = time.perf_counter()
    model.eval(data.wi, data.wo)
    numpy_forward = time.perf_counter() - began
    wi, wo = torch.tensor(data.wi), torch.tensor(data.wo)
    alpha = torch.tensor(0.05, dtype=torch.float64, requires_grad=True)
    ks = torch.tensor([0.3, 0.3, 0.35], dtype=torch.float64, requires_grad=True)
    began = time.perf_counter()
    lobe = MODELS["ggx"](alpha=alpha)
    f = parse("lambertian(rho=[0.15, 0.1, 0.05])").eval(wi, wo) + ks * lobe.eval(wi, wo)
    f = f + parse("[0.4, 0.35, 0.3] * ggx(alpha=0.3)").eval(wi, wo)
    loss = ((f - torch.tensor(data.values)) * wi[:, 2:3]).square().sum()
    loss.backward()
    return {"numpy_eval_s": numpy_forward, "torch_forward_backward_s": time.perf_counter() - began}


def _fits_cpu(path: str, model: str, starts: int, fits: int, barrier: Any) -> list[float]:
    """CPU seconds of each of ``fits`` fits of ``model`` to the MERL file ``path``, after one
    fit outside the clock (imports, first-use caches) and ``barrier`` (the processes start
    together)."""
    table = read_merl(path)
    fit(table, model, starts=starts)
    barrier.wait()
    seconds = []
    for _ in range(fits):
        began = time.process_time()
        fit(table, model, starts=starts)
        seconds.append(time.process_time() - began)
    return seconds


def contention(model: str, starts: int, fits: int, repeats: int) -> dict[str, Any]:
    """CPU seconds per fit, one process alone against two at once (interleaved)."""
    context = multiprocessing.get_context("spawn")
    cpu: dict[int, list[float]] = {1: [], 2: []}
    with tempfile.TemporaryDirectory() as folder:
        path = str(write_merl(Path(folder) / "three_lobes.binary", parse(TRUTH)))
        for _ in range(repeats):
            for processes in (1, 2):
                manager_barrier = context.Manager().Barrier(processes)
                with context.Pool(processes) as pool:
                    runs = pool.starmap(
                        _fits_cpu, [(path, model, starts, fits, manager_barrier)] * processes
                    )
                cpu[processes] += [s for run in runs for s in run]
                print(f"  {processes} process(es): CPU per fit "
                      f"{statistics.median(cpu[processes][-fits * processes:]):.3f} s",
                      file=sys.stderr)  # fmt: skip
    median = {p: statistics.median(s) for p, s in cpu.items()}
    return {
        "model": model,
        "starts": starts,
        "fits_per_process": fits,
        "repeats": repeats,
        "load_average": os.getloadavg(),
        "cpu_per_fit": cpu,
        "median_cpu_per_fit": median,
        "min_cpu_per_fit": {p: min(s) for p, s in cpu.items()},
        "ratio_2_over_1": median[2] / median[1],
    }


def main() -> None:
    from rich.console import Console
    from rich.progress import Progress

    parser = argparse.ArgumentParser()
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--contention", action="store_true")
    parser.add_argument("--model", default=MODEL)
    parser.add_argument("--starts", type=int, default=4)
    parser.add_argument("--fits", type=int, default=3)
    args = parser.parse_args()
    repeats = args.repeats
    from _machine import header, results_path

    if args.contention:
        record = {**header(__file__), **contention(args.model, args.starts, args.fits, repeats)}
        json.dump(record, sys.stdout, indent=2)
        print()
        results_path(__file__).write_text(json.dumps(record, indent=2) + "\n")
        return
    with tempfile.TemporaryDirectory() as folder:
        path = write_merl(Path(folder) / "three_lobes.binary", parse(TRUTH))
        table = read_merl(path)
    data = fit_data(table)
    paths = {"default": ("lobes", 1), "peer_2point": ("2-point", None)}
    runs: dict[str, list[dict]] = {name: [] for name in paths}
    for _ in range(repeats):
        for name, (jacobian, threads) in paths.items():
            fitting._JACOBIAN, fitting._BLAS_THREADS = jacobian, threads
            cpu = time.process_time()
            with Progress(console=Console(stderr=True), transient=True) as bar:
                task = bar.add_task(name, total=1)
                result = fit(
                    table,
                    MODEL,
                    progress=lambda done, total, text, task=task: bar.update(
                        task, completed=done, total=total, description=text
                    ),
                )
            alphas = sorted([result.params["1.ggx.alpha"], result.params["2.ggx.alpha"]])
            runs[name].append(
                {
                    "seconds": round(result.seconds, 2),
                    "cpu_seconds": round(time.process_time() - cpu, 2),  # the progress bar's too
                    "nfev": result.nfev,
                    "alpha_relative_errors": [abs(alphas[0] / 0.05 - 1), abs(alphas[1] / 0.3 - 1)],
                    "cube_root_rmse": result.errors["cube_root_rmse"],
                    "success": result.success,
                }
            )
    fitting._JACOBIAN, fitting._BLAS_THREADS = paths["default"]
    record = {
        **header(__file__, packages=("torch",)),
        "samples": result.samples,
        "fit_samples": result.fit_samples,
        "threads": os.environ.get("OMP_NUM_THREADS", "all"),
        "cpus": os.cpu_count(),
        "load_average": os.getloadavg(),
        "truth": TRUTH,
        "runs": runs,
        "speedup": [
            round(p["seconds"] / d["seconds"], 2)
            for d, p in zip(runs["default"], runs["peer_2point"], strict=True)
        ],
        **torch_timing(data),
    }
    json.dump(record, sys.stdout, indent=2)
    print()
    results_path(__file__).write_text(json.dumps(record, indent=2) + "\n")


if __name__ == "__main__":
    main()
