"""Write the benchmark tables of ``benchmarks/README.md`` (and the README's comparison with
peers) from the results files, so that the documents show what ``benchmarks/results`` holds.

Each ``bench_NAME.py`` writes ``benchmarks/results/NAME.json`` (see ``_machine.py``); here every
such file becomes the Markdown between ``<!-- results: NAME -->`` and ``<!-- end results: NAME
-->`` in ``benchmarks/README.md``: its tables, the machine it ran on and the command that made
it. The table between ``<!-- peers -->`` and ``<!-- end peers -->`` in the project's
``README.md`` is made from the same files.

    python benchmarks/tables.py           # rewrite the tables in both documents
    python benchmarks/tables.py --check   # exit 1 if a document is stale or results are amiss

``--check`` also fails when ``benchmarks/results`` holds a file that no ``bench_*.py`` writes,
or more files than there are benchmark scripts.
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import sys
from collections.abc import Callable
from pathlib import Path
from statistics import mean
from typing import Any

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"
BENCHMARKS_README = HERE / "README.md"
README = HERE.parent / "README.md"


def load(name: str, results: Path = RESULTS) -> dict[str, Any]:
    return json.loads((results / f"{name}.json").read_text(encoding="utf-8"))


def rows(header: list[str], body: list[list[Any]], align: str | None = None) -> str:
    """A Markdown table; ``align`` is one letter per column, ``l`` or ``r``."""
    align = align or "l" * len(header)
    rule = "|" + "|".join("---:" if a == "r" else "---" for a in align) + "|"
    lines = ["| " + " | ".join(header) + " |", rule]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in body]
    return "\n".join(lines)


def sci(x: float) -> str:
    """3 significant digits as a × 10ⁿ (evaluations per second)."""
    exponent = len(str(int(abs(x)))) - 1 if abs(x) >= 1 else 0
    superscript = str(exponent).translate(str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹"))
    return f"{x / 10**exponent:.2f}×10{superscript}"


def pct(x: float, digits: int = 2) -> str:
    return f"{100 * x:.{digits}f} %"


def machine_line(record: dict[str, Any]) -> str:
    """*Machine: …; date; command* under each table."""
    m = record["machine"]
    packages = ", ".join(
        f"{name} {version}"
        for name, version in m.get("packages", {}).items()
        if version not in ("unknown", "not installed")
    )
    parts = [f"{m['cpu']}, {m['cores']} cores" if m["cpu"] != "unknown" else "CPU unknown"]
    parts.append(f"{m['os']}" if m["os"] != "unknown" else "OS unknown")
    parts.append(f"Python {m['python']}" if m["python"] != "unknown" else "Python unknown")
    if packages:
        parts.append(packages)
    if m.get("commit", "unknown") != "unknown":
        parts.append(f"brdfkit at {m['commit']}")
    text = f"*Machine:* {'; '.join(parts)}; {m['date']}. *Command:* `{record['command']}`."
    if m.get("note"):
        text += f" *Note:* {m['note']}"
    return text


# --- one function per benchmark: its tables (without the machine line) ----------------------


def atlas(r: dict) -> str:
    warm = [k for k, c in enumerate(r.get("atlas_cache", [])) if c != "cold"]
    out = []
    if warm:
        best = min(warm, key=lambda k: r["atlas_seconds"][k])
        out.append(
            rows(
                ["builds", "wall s (best)", "CPU s (that build)", "wall s (each)", "import s"],
                [
                    [
                        len(warm),
                        f"{r['atlas_seconds'][best]:.1f}",
                        f"{r['atlas_cpu_seconds'][best]:.1f}",
                        ", ".join(f"{r['atlas_seconds'][k]:.1f}" for k in warm),
                        f"{r['import_seconds']:.2f}",
                    ]
                ],
                "rrrlr",
            )
        )
    if "noise" in r:
        spheres = r["noise"]["spheres"]
        quad = [s for s in spheres if s["spp"] == 0]
        mc = [s for s in spheres if s["spp"] > 0]
        body = []
        if quad:
            finer = max(quad, key=lambda s: s["rel_rmse_finer_quadrature"])
            vs_mc = max(quad, key=lambda s: s["rel_rmse_mc"])
            noise = max(s["mc_noise"] for s in quad)
            samples = quad[0]["mc_samples"]
            body.append(
                [len(quad), "quadrature", "the next finer quadrature level",
                 sum(s["rel_rmse_finer_quadrature"] <= 0.01 for s in quad),
                 f"{pct(finer['rel_rmse_finer_quadrature'])} "
                 f"({finer['card']}, example {finer['example'] + 1})"]
            )  # fmt: skip
            body.append(
                [len(quad), "quadrature",
                 f"Monte Carlo, {samples} spp (its own noise: up to {pct(noise, 1)})",
                 sum(s["rel_rmse_mc"] <= 0.01 for s in quad),
                 f"{pct(vs_mc['rel_rmse_mc'])} ({vs_mc['card']}, example {vs_mc['example'] + 1})"]
            )  # fmt: skip
        if mc:
            worst = max(mc, key=lambda s: s["rel_rmse"])
            spp = sorted({s["spp"] for s in mc})
            spp_text = f"{spp[0]}" if len(spp) == 1 else f"{spp[0]}–{spp[-1]}"
            body.append(
                [len(mc), f"Monte Carlo, {spp_text} spp", "Monte Carlo at 16× the spp",
                 sum(s["rel_rmse"] <= 0.01 for s in mc),
                 f"{pct(worst['rel_rmse'], 4)} ({worst['card']}, example {worst['example'] + 1})"]
            )  # fmt: skip
        out.append(
            rows(
                ["spheres", "rendered by", "relative RMSE against", "within 1 %", "worst"],
                body,
                "rllrl",
            )
        )
    return "\n\n".join(out)


def _walk_against_exact(c: dict) -> list[Any]:
    """A row of the random walk against Chandrasekhar's reflectance."""
    difference = c["walk"] - c["exact"]
    return [
        c["albedo"],
        c["mu"],
        f"{c['walk']:.5f} ± {c['stderr']:.5f}",
        f"{c['exact']:.5f}",
        f"{difference / c['stderr']:+.2f} σ, {pct(difference / c['exact'], 3)}",
    ]


def bssrdf(r: dict) -> str:
    exact = rows(
        ["ω", "μ₀", "random walk", "Chandrasekhar", "difference"],
        [_walk_against_exact(c) for c in r["chandrasekhar"]],
        "rrrrr",
    )
    models = list(r["cases"][0]["errors"])
    parts = [f"Random walk against the exact reflectance (η = 1, {r['walks']:,} walks):\n\n{exact}"]
    for key, title in (
        ("total", "Relative error of the total diffuse reflectance"),
        ("profile", "Profile shape error (fraction of the power at the wrong radius)"),
        ("near", f"Relative error of the power within {r['near_radius']} mean free path (r → 0)"),
    ):
        body = [
            [c["eta"], c["albedo"]] + [pct(c["errors"][m][key], 1) for m in models]
            for c in r["cases"]
        ]
        parts.append(f"{title}:\n\n" + rows(["η", "ω", *models], body, "rr" + "r" * len(models)))
    m = r.get("mitsuba")
    if m:
        difference = m["mitsuba"] - m["walk_plus_specular"]
        parts.append(
            f"Mitsuba 3 `volpath` ({m['variant']}, {m['spp']:,} paths) on a thick slab, ω = "
            f"{m['albedo']}, η = {m['eta']}: reflectance {m['mitsuba']:.4f} ± "
            f"{m['mitsuba_stderr']:.4f}; random walk + specular F(1): "
            f"{m['walk_plus_specular']:.4f} ± {m['walk_stderr']:.4f}; difference "
            f"{pct(difference / m['walk_plus_specular'])}."
        )
    if r.get("mitsuba_profile"):
        parts.append(_bssrdf_profile(r["mitsuba_profile"]))
    if r.get("mitsuba_spheres"):
        parts.append(_bssrdf_spheres(r["mitsuba_spheres"]))
    earlier = r.get("machine_of_parts_1_to_3")
    if earlier:
        parts.append(
            f"The tables above the spheres come from the full run (brdfkit at "
            f"{earlier['commit']}, {earlier['date']}, load average {earlier['load_average'][0]}); "
            "the spheres from the `--spheres-only` run of the machine line below."
        )
    return "\n\n".join(parts)


def _bssrdf_profile(p: dict) -> str:
    edges = p["ring_edges"] + ["∞"]
    body = [
        [f"{edges[i]}–{edges[i + 1]}", f"{m:.5f} ± {ms:.5f}", f"{w:.5f} ± {ws:.5f}", f"{z:+.2f}"]
        for i, (m, ms, w, ws, z) in enumerate(
            zip(p["mitsuba"], p["mitsuba_stderr"], p["walk"], p["walk_stderr"], p["z"], strict=True)
        )
    ]
    return (
        f"Radial profile by reciprocity, Mitsuba 3 `volpath` ({p['variant']}, "
        f"{p['spp_per_ring']:,} paths per ring) against the random walk (share of pencil-beam "
        f"power leaving over each ring of radii, mean free paths, the first with F(1)); "
        f"χ² = {p['chi2']:.1f} over {p['rings']} rings:\n\n"
        + rows(["ring", "Mitsuba", "random walk", "z"], body, "lrrr")
    )


def _bssrdf_spheres(spheres: dict) -> str:
    parts = []
    for name, s in spheres.items():
        m = s["medium"]
        models = s["models"]
        body = [
            [n, pct(e["documented"], 1), pct(e["mean"], 1), pct(e["block_rmse"], 1)]
            for n, e in models.items()
        ]
        parts.append(
            f"Translucent sphere ({name}: ω = {m['albedo']}, σt = {m['sigma_t']} per radius, "
            f"η = {m['eta']}; {s['resolution']}², {s['blocks']} blocks of 4×4 pixels): reference "
            f"walk ({s['walk_spp']} spp) against Mitsuba `volpath` ({s['mitsuba_spp']} spp): "
            f"block z mean {s['walk_z_mean']:+.2f}, sd {s['walk_z_std']:.2f}, max "
            f"|z| {s['walk_max_abs_z']:.2f}, mean ratio {s['walk_mean_ratio']:.4f}. Diffusion "
            "models' separable BSSRDF against Mitsuba:\n\n"
            + rows(["model", "table error", "mean error", "block RMSE"], body, "lrrr")
        )
    return "\n\n".join(parts)


def brdf(r: dict) -> str:
    data = r["rows"]
    peer = {(x["workload"], x["n"]): x for x in data if x["impl"].startswith("Mitsuba")}
    body = []
    for x in data:
        p = peer.get((x["workload"], x["n"]))
        ratio = f"{x['per_second'] / p['per_second']:.2f}" if p else "–"
        cpu = (
            f"{p['cpu_seconds'] / x['cpu_seconds']:.2f}"
            if p and "cpu_seconds" in p and "cpu_seconds" in x
            else ""
        )
        body.append([x["workload"], sci(x["n"]).replace("1.00×", ""), x["impl"],
                     sci(x["per_second"]), ratio, cpu])  # fmt: skip
    return rows(
        [
            "workload",
            "pairs",
            "implementation",
            "evaluations/s",
            "÷ Mitsuba",
            "÷ Mitsuba, CPU time",
        ],
        body,
        "lrlrrr",
    )


CORNELL_MODELS = {
    "lambertian": "Lambertian",
    "lambertian + cook_torrance": "+ Cook–Torrance",
    "lambertian + ggx": "+ GGX",
    "lambertian + ward": "+ Ward",
    "lambertian + ggx + ggx": "+ GGX + GGX",
}


def cornell_fits(r: dict) -> str:
    records = r["records"]
    fittings = list(dict.fromkeys((x["objective"], x["loss"]) for x in records))
    default = fittings[0]

    def cell(material: str, model: str, fitting: tuple, averaged: bool = False) -> float:
        (x,) = (
            x
            for x in records
            if (x["material"], x["model"], x["objective"], x["loss"]) == (material, model, *fitting)
        )
        return mean(x["delta_e_per_light"].values()) if averaged else x["delta_e"]["mean"]

    materials = list(dict.fromkeys(x["material"] for x in records))
    models = [m for m in CORNELL_MODELS if any(x["model"] == m for x in records)]
    main = rows(
        ["material", *(CORNELL_MODELS[m] for m in models)],
        [[material, *(f"{cell(material, m, default):.1f}" for m in models)]
         for material in materials],
        "l" + "r" * len(models),
    )  # fmt: skip
    specular = models[1:]
    summary = rows(
        ["objective", "loss", "default light", f"{len(records[0]['delta_e_per_light'])} lights"],
        [
            [f"`{o}`", f"`{loss}`",
             f"{mean(cell(m, d, (o, loss)) for m in materials for d in specular):.1f}",
             f"{mean(cell(m, d, (o, loss), True) for m in materials for d in specular):.1f}"]
            for o, loss in fittings
        ],
        "llrr",
    )  # fmt: skip
    return (
        f"Mean CIEDE2000, measured against fitted sphere, default light, default fit "
        f"(`{default[0]}` objective, `{default[1]}` loss):\n\n{main}\n\n"
        f"Mean over the {len(materials) * len(specular)} fits with a specular lobe, by objective "
        f"and loss:\n\n{summary}"
    )


def dask(r: dict) -> str:
    out = []
    if "batch" in r:
        b = r["batch"]
        body = [
            [w, f"{b['best_seconds'][w]:.1f}", ", ".join(f"{s:.1f}" for s in b["seconds"][w]),
             ", ".join(f"{c:.2f}" for c in b["cores_busy"][w]),
             ", ".join(f"{c:.2f}" for c in b["cpu_seconds_per_fit"][w])]
            for w in ("1", "2")
        ]  # fmt: skip
        out.append(
            f"{b['fits']} fits ({b['distinct_files']} files × {len(b['models'])} models), "
            f"best of {b['repeats']}: speed-up **{b['speedup_1_to_2']:.2f}×** from 1 to 2 "
            "workers.\n\n"
            + rows(["workers", "best s", "s (each)", "cores busy", "CPU s per fit"], body, "rrlll")
        )
    if "out_of_core" in r:
        o = r["out_of_core"]
        mib = 2**20
        text = rows(
            ["stack", "memory limit", "worker peaks", "solve s", "Mpixel/s", "mean error"],
            [[f"{o['stack_bytes'] / 2**30:.2f} GiB {tuple(o['stack_shape'])}",
              f"{o['limit_per_worker_bytes'] / mib:.0f} MiB × {o['workers']}",
              ", ".join(f"{p / mib:.0f} MiB" for p in o["worker_peak_rss_bytes"]),
              f"{o['solve_seconds']:.0f}", f"{o['pixels_per_second'] / 1e6:.3f}",
              f"{o['mean_angular_error_deg_all_lit']:.4f}°"]],
            "llrrrr",
        )  # fmt: skip
        run = o.get("run")
        if run:
            text += f"\n\nOut of core: {run['date']}, {run['note']}."
        out.append(text)
    return "\n\n".join(out)


def env_sampling(r: dict) -> str:
    return rows(
        ["map", "lock-step bisection ns", "guide tables ns", "ratio"],
        [[m["map"], f"{m['ns_per_sample']['lockstep']:.1f}", f"{m['ns_per_sample']['guide']:.1f}",
          f"{m['ratio']:.2f}"] for m in r["maps"]],
        "lrrr",
    )  # fmt: skip


def _ms(x: float | None) -> str:
    return "not reached" if x is None else f"{x:.0f}"


def _explore_latency(workloads: dict) -> str:
    return rows(
        ["workload", "median ms", "p95 ms", "preview share", "click median ms", "click p95 ms",
         "server views ms", "page draw ms", "render_sphere ms"],
        [[name, f"{w['median_ms']:.1f}", f"{w['p95_ms']:.1f}", f"{w.get('preview_share', 0):.2f}",
          _ms(w.get("click_median_ms")), _ms(w.get("click_p95_ms")),
          f"{w['server_views_median_ms']:.1f}", f"{w['page_draw_median_ms']:.1f}",
          f"{w['render_sphere_median_ms']:.1f}"] for name, w in workloads.items()],
        "lrrrrrrrr",
    )  # fmt: skip


def _explore_other(compositor: str, workloads: dict) -> str:
    lit = workloads["lambertian+ggx"]["lit"]
    clicks = ", ".join(
        f"{name} {_ms(w.get('click_median_ms'))} / {_ms(w.get('click_p95_ms'))}"
        for name, w in workloads.items()
    )
    gpu = workloads["lambertian+ggx"].get("gpu_process_cpu_ms_per_click")
    return (
        f"The same run with Chromium's `{compositor}` compositor: clicks (median / p95 ms) "
        f"{clicks}; the sphere's slider with the lit view refining "
        f"{lit['slider_median_ms_lit_on']:.1f} / {lit['slider_p95_ms_lit_on']:.1f} ms (off "
        f"{lit['slider_median_ms_lit_off']:.1f} / {lit['slider_p95_ms_lit_off']:.1f})"
        + (f"; its GPU process {gpu:.0f} ms of CPU per click." if gpu is not None else ".")
    )


def explore(r: dict) -> str:
    out = []
    if "workloads" in r:
        compositor = r.get("compositor", "swiftshader")
        gpu = next(iter(r["workloads"].values())).get("gpu_process_cpu_ms_per_click")
        out.append(
            f"Chromium's `{compositor}` compositor"
            + (f" (its GPU process: {gpu:.0f} ms of CPU per click)" if gpu is not None else "")
            + ":\n\n"
            + _explore_latency(r["workloads"])
        )
        env = next((w["envmap"] for w in r["workloads"].values() if "envmap" in w), None)
        if env:
            noise1 = "not reached" if env["noise1"] is None else f"{env['noise1'] / 1e3:.2f}"
            out.append(
                "Environment map (Lambertian + GGX):\n\n"
                + rows(
                    ["first image ms", "first pass ms", "1 % noise s", "spp then", "noise then"],
                    [[_ms(env["first"]), _ms(env["firstPass"]), noise1, env["samples"],
                      pct(env["noise"])]],
                    "rrrrr",
                )
            )  # fmt: skip
        lit = next((w["lit"] for w in r["workloads"].values() if "lit" in w), None)
        if lit:
            load = r.get("load_average_before")
            out.append(
                "Lit object (shader ball, 128², shadow rays through Embree; the sphere's slider "
                "with the lit view refining vs off, interleaved"
                + (f"; load average {load[0]:.1f} on the machine" if load else "")
                + "):\n\n"
                + rows(
                    ["slider median ms, lit on / off", "slider p95 ms, lit on / off",
                     "orbit → first pass ms", "first pass server s", "64 spp server s"],
                    [[f"{lit['slider_median_ms_lit_on']:.1f} / "
                      f"{lit['slider_median_ms_lit_off']:.1f}",
                      f"{lit['slider_p95_ms_lit_on']:.1f} / {lit['slider_p95_ms_lit_off']:.1f}",
                      _ms(lit["orbit_to_first_pass_median_ms"]),
                      f"{lit['first_pass_server_median_s']:.2f}",
                      f"{lit['to_64_spp_server_median_s']:.1f}"]],
                    "rrrrr",
                )
            )  # fmt: skip
        for compositor, workloads in r.get("other_compositors", {}).items():
            out.append(_explore_other(compositor, workloads))
    if "runs" in r:
        out.append(
            "Environment map, in-process (`--session`):\n\n"
            + rows(
                ["run", "first image ms", "first pass ms", "1 % noise s", "CPU s", "spp", "noise"],
                [[k, f"{1e3 * x['first']:.0f}", f"{1e3 * x['first_pass']:.0f}",
                  "not reached" if x["noise1"] is None else f"{x['noise1']:.2f}",
                  f"{x.get('noise1_cpu', x['cpu']):.2f}", x["samples"], pct(x["noise"])]
                 for k, x in enumerate(r["runs"])],
                "rrrrrrr",
            )
        )  # fmt: skip
    return "\n\n".join(out)


def fit(r: dict) -> str:
    if "runs" not in r:  # --contention
        return rows(
            ["model", "starts", "median CPU s per fit, 1 process", "2 processes", "ratio"],
            [[r["model"], r["starts"], f"{r['median_cpu_per_fit']['1']:.3f}",
              f"{r['median_cpu_per_fit']['2']:.3f}", f"{r['ratio_2_over_1']:.2f}"]],
            "lrrrr",
        )  # fmt: skip
    names = {"default": "brdfkit (one lobe per Jacobian column)",
             "peer_2point": "SciPy's 2-point finite differences"}  # fmt: skip
    body = [
        [names.get(name, name), ", ".join(f"{x['seconds']:.2f}" for x in runs),
         ", ".join(f"{x['cpu_seconds']:.2f}" for x in runs), runs[0]["nfev"],
         f"{max(max(x['alpha_relative_errors']) for x in runs):.1e}"]
        for name, runs in r["runs"].items()
    ]  # fmt: skip
    text = (
        f"`{r['truth']}` fitted back on {r['samples']:,} measured nodes "
        f"({r['fit_samples']:,} in the refinement), runs interleaved:\n\n"
        + rows(["Jacobian", "wall s", "CPU s", "evaluations", "worst α error"], body, "lllrr")
    )
    if "numpy_eval_s" in r:
        text += (
            f"\n\nOne NumPy evaluation of the model on every node: {r['numpy_eval_s']:.2f} s; "
            f"one torch forward and backward pass: {r['torch_forward_backward_s']:.2f} s."
        )
    return text


def kulla_conty(r: dict) -> str:
    table = rows(
        ["path", "kulla_conty s", "rough_conductor s", "ratio"],
        [[path, f"{r[path]['kulla_conty_s']:.3f}", f"{r[path]['rough_conductor_s']:.3f}",
          f"{r[path]['ratio']:.2f}"] for path in ("numpy", "compiled") if path in r],
        "lrrr",
    )  # fmt: skip
    return f"{table}\n\nE(μ) table for a new α: {r['table_seconds']:.2f} s."


def tracer(r: dict) -> str:
    def jax(row: dict) -> str:
        return "" if row["jax_make_jaxpr_s"] is None else f"{row['jax_make_jaxpr_s']:.3f}"

    table = rows(
        ["model", "method", "trace s", "jax.make_jaxpr s", "source lines", "numba compile s"],
        [[x["model"], x["method"], f"{x['trace_s']:.3f}", jax(x), str(x["source_lines"]),
          f"{x['numba_compile_s']:.2f}"] for x in r["rows"]],
        "llrrrr",
    )  # fmt: skip
    return (
        f"{table}\n\nfloat32 kernels of each model's structure; trace: brdfkit's tracer "
        f"(best of {r['repeats']}, interleaved with JAX's `make_jaxpr` of the same function, "
        "which the compiled path needed before); numba compile: once, no disk cache."
    )


def kulla_conty_dielectric(r: dict) -> str:
    cpu = r["cpu_seconds"]
    table = rows(
        ["model", f"CPU ms per {r['pairs']:,} pairs"],
        [[name, f"{1e3 * s:.1f}"] for name, s in cpu.items()],
        "lr",
    )
    return (
        f"{table}\n\nRatio {r['ratio']:.2f}; a new (α, η) costs "
        f"{r['construction_cpu_seconds']:.2f} CPU s once."
    )


def loo_fits(r: dict) -> str:
    return rows(
        ["held-out file", "configuration chosen on the other four", "CIEDE2000 on it"],
        [[x["held_out"], f"`{x['model']}`, `{x['objective']}`", f"{x['delta_e']:.2f}"]
         for x in r["leave_one_out"]],
        "llr",
    )  # fmt: skip


MIS_NAMES = {"brdf": "BRDF", "light": "light", "mis balance": "MIS balance",
             "mis power": "MIS power", "mis optimal": "MIS optimal"}  # fmt: skip


def mis(r: dict) -> str:
    keys = list(r["rows"][0]["relative"])
    body = [
        [x["map"].split("/")[-1].removesuffix(".hdr"), f"`{x['brdf']}`",
         *(f"{x['mse'][k] / min(x['mse'].values()):.2f} "
           f"({x['reported_variance'][k] / min(x['mse'].values()):.2f})" for k in keys)]
        for x in r["rows"]
    ]  # fmt: skip
    first = r["rows"][0]
    return (
        f"Mean squared error relative to the best estimator of the row "
        f"({first['samples_per_strategy']} samples per strategy, {first['seeds']} seeds; in "
        "brackets the mean reported variance, on the same scale):\n\n"
        + rows(["map", "BRDF", *(MIS_NAMES.get(k, k) for k in keys)], body, "ll" + "r" * len(keys))
    )


def photometric_stereo(r: dict) -> str:
    records = r["records"]
    stack = records[0]["stack"]
    body = [
        [x["method"], f"{x['pixels']:,}", f"{x['seconds']:.2f}", f"{x['cpu_seconds']:.2f}",
         f"{x['first_call_cpu_seconds']:.2f}", x["iterations"],
         f"{x['mean_deg']:.2f} / {x['median_deg']:.2f}"]
        for x in records
    ]  # fmt: skip
    return f"Stack {' × '.join(map(str, stack))} (images × rows × columns × channels):\n\n" + rows(
        ["method", "pixels", "wall s", "CPU s", "first call CPU s", "iterations",
         "error ° (mean / median)"],
        body,
        "lrrrrrr",
    )  # fmt: skip


PS_NAMES = {
    "least_squares": "least squares",
    "trimmed": "trimmed",
    "sparse_regression": "sparse regression",
    "robust_pca": "robust PCA",
    "bipolynomial": "ST14",
    "bipolynomial (3, 1)": "ST14 (3, 1)",
    "constrained_bivariate": "IA14",
    "shared_bivariate": "AZ08",
    "consensus": "HM10",
}


def ps_materials_averages(r: dict) -> tuple[list[str], dict[str, dict[str, float]]]:
    """Methods, and the mean error per material and method over the objects."""
    records = r["records"]
    methods = list(dict.fromkeys(x["method"] for x in records))
    materials = list(dict.fromkeys(x["material"] for x in records))
    table = {
        material: {
            m: mean(x["mean_deg"] for x in records if (x["material"], x["method"]) == (material, m))
            for m in methods
        }
        for material in materials
    }
    table["average"] = {m: mean(table[material][m] for material in materials) for m in methods}
    return methods, table


def ps_materials(r: dict) -> str:
    methods, table = ps_materials_averages(r)
    body = []
    for material, means in table.items():
        best = min(means, key=means.get)
        body.append(
            [material, *(f"**{v:.2f}**" if m == best else f"{v:.2f}" for m, v in means.items()),
             PS_NAMES.get(best, best)]
        )  # fmt: skip
    return (
        f"Mean angular error (°) over {', '.join(r['objects'])} (every {r['step']}th pixel), "
        "best of each row in bold:\n\n"
        + rows(["material", *(PS_NAMES.get(m, m) for m in methods), "best"], body,
               "l" + "r" * len(methods) + "l")
    )  # fmt: skip


def _uncalibrated_cell(records: list[dict], key: Any) -> str:
    """Mean of ``key(record)`` over the records that did not fail; ``—`` when all failed, and
    how many failed otherwise."""
    values = [key(x) for x in records if "failed" not in x]
    failed = len(records) - len(values)
    if not values:
        return "failed"
    return f"{mean(values):.2f}" + (f" ({failed} failed)" if failed else "")


def uncalibrated(r: dict) -> str:
    cues, records = r["cues"], r["records"]
    materials = list(dict.fromkeys(x["material"] for x in records))

    def where(material: str, cue: str) -> list[dict]:
        return [x for x in records if (x["material"], x["cue"]) == (material, cue)]

    lights = [
        [m, *(_uncalibrated_cell(where(m, c), lambda x: x["lights_median_deg"]) for c in cues)]
        for m in materials
    ]
    columns = [("calibrated", "sparse_regression"), ("auto", "sparse_regression")]
    columns += [("calibrated", "shared_bivariate")] + [(c, "shared_bivariate") for c in cues]
    normals = [
        [m, *(_uncalibrated_cell(where(m, c), lambda x, s=s: x["normals_mean_deg"][s])
              for c, s in columns)]
        for m in materials
    ]  # fmt: skip
    names = {"sparse_regression": "SR", "shared_bivariate": "SB"}
    psm_objects = list(dict.fromkeys(x["psm"] for x in r["psm"]))
    psm = [
        [o, *(_uncalibrated_cell([x for x in r["psm"] if (x["psm"], x["cue"]) == (o, c)],
                                 lambda x: x["lights_median_deg"]) for c in cues)]
        for o in psm_objects
    ]  # fmt: skip
    gray = {x["cue"]: x for x in r["psm"] if x["psm"] == "gray" and "failed" not in x}
    gray_normals = ", ".join(
        f"{c} {x['normals_mean_deg']['least_squares']:.2f}" for c, x in gray.items()
    )
    used = sorted({(x["material"], x["cue_used"]) for x in records if x["cue"] == "auto"
                   and "cue_used" in x})  # fmt: skip
    auto = "; ".join(f"{m}: {c}" for m, c in used)
    objects = f"{', '.join(r['objects'])} (every {r['step']}th pixel)"
    return (
        f"(a) Renders over {objects}: the lights' median angular error (°), mean over the "
        "objects:\n\n"
        + rows(["material", *cues], lights, "l" + "r" * len(cues))
        + "\n\nThe normals' mean angular error (°) of sparse regression (SR, the default of "
        "`brdfkit ps` out of core) and shared bivariate (SB, its default) with the true "
        "(calibrated) or the estimated lights:\n\n"
        + rows(["material", *(f"{c} {names[s]}" for c, s in columns)], normals,
               "l" + "r" * len(columns))
        + f"\n\n`auto` chose: {auto}.\n\n"
        "(b) psm photographs (12 lights, 8-bit): the lights' median angular error (°) against "
        "the chrome sphere's:\n\n"
        + rows(["object", *cues], psm, "l" + "r" * len(cues))
        + f"\n\nThe gray sphere's normals (least squares, mean °): {gray_normals}."
    )  # fmt: skip


def relighting(r: dict) -> str:
    means = r["means"]
    order = ("lambertian", "svbrdf_1", "svbrdf_2", "svbrdf_cv")
    models = [m for m in order if any(m in obj for obj in means.values())]
    models += [m for obj in means.values() for m in obj if m not in models]
    shadows = r["shadows"]

    def cell(obj: str, model: str) -> str:
        values = means[obj].get(model, {})
        if not values:
            return "–"
        return " / ".join(f"{values[s]['rms']:.4f}" if s in values else "–" for s in shadows)

    return (
        f"RMS error of the held-out photographs (all pixels), mean over the folds; cast shadows "
        f"{' / '.join(shadows)}:\n\n"
        + rows(["object", *models], [[obj, *(cell(obj, m) for m in models)] for obj in means])
    )


def hdr(r: dict) -> str:
    s = r["summary"]
    counts = [str(n) for n in r["settings"]["sample_counts"]]
    curves = r["settings"]["curves"]
    accuracy = rows(
        ["method", "median error % of range", *curves],
        [[m, f"{e:.3f}", *(f"{s['per_curve'][m][c]:.3f}" for c in curves)]
         for m, e in s["median_error_percent"].items()],
        "lr" + "r" * len(curves),
    )  # fmt: skip
    stability = rows(
        ["method", *(f"{n} samples" for n in counts), "largest difference"],
        [[m, *(f"{by[n]:.3f}" for n in counts), f"{s['spread'][m]:.3f}"]
         for m, by in s["by_samples"].items()],
        "l" + "r" * (len(counts) + 1),
    )  # fmt: skip
    return (
        "Median RMS error of the inverse response (codes 1–254, after the free scale), % of its "
        "range, over channels and seeds (brdfkit at 1,000 sampled pixels; OpenCV with its "
        f"defaults):\n\n{accuracy}\n\nThe same median by the number of sampled pixels:\n\n"
        f"{stability}"
    )


def render(r: dict) -> str:
    body = []
    for x in r["rows"]:
        ours = "compiled" if "compiled" in x else "numpy"
        body.append(
            [x["scene"], x["spp"], f"{x[ours]['seconds']:.3f}", f"{x[ours]['rel_rmse']:.4f}",
             f"{x['mitsuba']['seconds']:.3f}", f"{x['mitsuba']['rel_rmse']:.4f}",
             f"**{x[f'{ours}_efficiency_ratio']:.2f}**"]
        )  # fmt: skip
    compile_s = {x["scene"]: x["compile_seconds"] for x in r["rows"] if x["compile_seconds"]}
    text = (
        f"{r['resolution']}² sphere, relative RMSE against each renderer's own "
        f"{r['reference_spp']}-spp reference, best of {r['repeats']}:\n\n"
        + rows(
            ["scene", "spp", "brdfkit s", "brdfkit error", "Mitsuba s", "Mitsuba error",
             "efficiency ÷ Mitsuba"],
            body,
            "lrrrrrr",
        )
    )  # fmt: skip
    if compile_s:
        text += "\n\nKernel build, once per model (not in the times): " + ", ".join(
            f"{scene} {s:.1f} s" for scene, s in compile_s.items()
        )
        text += "."
    return text


def envmap(r: dict) -> str:
    body = []
    for x in r["rows"]:
        for mode, peer in (("kept", "kept"), ("new", "new"), ("again", "new")):
            b, m = x[f"brdfkit {mode}"], x[f"mitsuba {peer}"]
            body.append(
                [x["map"], f"{x['peak']:.3g}", mode, f"{b['seconds']:.3f}",
                 f"{b['rel_rmse']:.4f}", f"{m['seconds']:.3f}", f"{m['rel_rmse']:.4f}",
                 f"**{x[f'ratio {mode}']:.2f}**"]
            )  # fmt: skip
    return (
        f"`{r['model']}` sphere, {r['resolution']}², {r['spp']} spp, best of {r['repeats']}; "
        f"error against each renderer's own {r['reference_spp']}-spp image; Mitsuba "
        f"{r['mitsuba']}. *kept*: the scene kept between images; *new*: the map read and a new "
        "scene per image (brdfkit's tables forgotten first, in the process and on disk; Mitsuba "
        "loads its scene); *again*: "
        "brdfkit's new scene of a map read before (tables found by content), against Mitsuba's "
        "new scene:\n\n"
        + rows(
            ["map", "peak", "scene", "brdfkit s", "brdfkit error", "Mitsuba s", "Mitsuba error",
             "efficiency ÷ Mitsuba"],
            body,
            "lrlrrrrr",
        )
    )  # fmt: skip


def mesh(r: dict) -> str:
    body = [
        [x["model"], x["spp"], f"{x['brdfkit']['seconds']:.2f}", f"{x['brdfkit']['rel_rmse']:.4f}",
         f"{x['mitsuba']['seconds']:.2f}", f"{x['mitsuba']['rel_rmse']:.4f}",
         f"**{x['efficiency_ratio']:.2f}**", f"{x['reference_mean_ratio']:.4f}",
         f"{x['reference_blurred_rel_rmse']:.4f}"]
        for x in r["rows"]
    ]  # fmt: skip
    height, width = r["size"]
    text = (
        f"Torus over a plane, {width}×{height}, `{r['envmap']}` + sun; fresh processes (read, "
        f"render, write), best of {r['repeats']}; error against each renderer's own "
        f"{r['reference_spp']}-spp reference; Mitsuba {r['mitsuba']}:\n\n"
        + rows(
            ["model", "spp", "brdfkit s", "brdfkit error", "Mitsuba s", "Mitsuba error",
             "efficiency ÷ Mitsuba", "converged mean ratio", "converged blurred error"],
            body,
            "lrrrrrrrr",
        )
    )  # fmt: skip
    if "large" in r:
        x = r["large"]
        b, m = x["brdfkit"], x["mitsuba"]
        text += (
            f"\n\nA torus of {x['triangles']} triangles over the plane at {x['size'][1]}², "
            f"{x['model']}, the scene kept in process, {x['spp']} spp against each renderer's own "
            f"{x['reference_spp']}-spp image: brdfkit {b['seconds']:.2f} s (error "
            f"{b['rel_rmse']:.4f}), Mitsuba {m['seconds']:.2f} s (error {m['rel_rmse']:.4f}); "
            f"efficiency ÷ Mitsuba **{x['efficiency_ratio']:.2f}**."
        )
        if "brdfkit_numpy" in x:
            n = x["brdfkit_numpy"]
            text += (
                f" brdfkit on its NumPy path: {n['seconds']:.2f} s (error {n['rel_rmse']:.4f}), "
                f"efficiency ÷ Mitsuba {x['efficiency_ratio_numpy']:.2f}."
            )
    return text


def render_cli(r: dict) -> str:
    w, first = r["warm"], r["first"]
    body = [
        ["brdfkit render (warm kernel cache)", f"{w['brdfkit_median']:.2f}",
         f"{min(w['brdfkit_seconds']):.2f}–{max(w['brdfkit_seconds']):.2f}",
         f"{w['brdfkit_cpu_median']:.2f}"],
        [f"Mitsuba {r['mitsuba']} (`mitsuba scene.xml`)", f"{w['mitsuba_median']:.2f}",
         f"{min(w['mitsuba_seconds']):.2f}–{max(w['mitsuba_seconds']):.2f}",
         f"{w['mitsuba_cpu_median']:.2f}"],
        ["brdfkit render, first run (empty kernel cache)",
         f"{statistics.median(first['seconds']):.2f}",
         f"{min(first['seconds']):.2f}–{max(first['seconds']):.2f}", ""],
    ]  # fmt: skip
    if "baseline_seconds" in first:
        base = first["baseline_seconds"]
        label = f"brdfkit at {first['baseline']}, first run (paired)"
        spread = f"{min(base):.2f}–{max(base):.2f}"
        body.append([label, f"{statistics.median(base):.2f}", spread])
    if "baseline_seconds" in w:
        base = w["baseline_seconds"]
        label = f"brdfkit at {first['baseline']}, warm (paired)"
        spread = f"{min(base):.2f}–{max(base):.2f}"
        cpu = f"{statistics.median(w['baseline_cpu_seconds']):.2f}"
        body.append([label, f"{w['baseline_median']:.2f}", spread, cpu])
    load = r["machine"].get("load_average", ["?"])[0]
    loads = first.get("load_before_runs")
    if loads:
        load = f"{load}; before the first runs {min(loads):.1f}–{max(loads):.1f}"
    return (
        f'`brdfkit render -b "{r["spec"]}"` with its defaults ({r["resolution"]}², '
        f"{r['spp']} spp, the bundled map; an EXR written) and Mitsuba's twin scene, each a "
        f"fresh process, {len(w['brdfkit_seconds'])} interleaved runs; wall seconds, and the "
        "median CPU seconds of each process (all threads):\n\n"
        + rows(["process", "median s", "range s", "CPU s"], body, "lrrr")
        + f"\n\nMedian ratio brdfkit ÷ Mitsuba, pair by pair: **{w['ratio_median']:.2f}** "
        f"(goal ≤ 1.5). The twin's images: mean ratio {r['twin_mean_ratio']:.4f}. "
        f"Load average when written: {load} (the machine's other work is in every figure)."
    )


def sfs(r: dict) -> str:
    return rows(
        ["size", "solver", "pixels", "wall s", "CPU s", "evaluations", "error ° (mean / median)"],
        [[f"{x['size']}²", x["solver"], f"{x['pixels']:,}", f"{x['seconds']:.2f}",
          f"{x['cpu_seconds']:.2f}", x["evaluations"],
          f"{x['mean_deg']:.2f} / {x['median_deg']:.2f}"] for x in r["records"]],
        "llrrrrr",
    )  # fmt: skip


def sh(r: dict) -> str:
    if r["maps"]:
        table = rows(
            ["map", "pixels", "mean / E_max", "max / E_max", "mean relative", "max relative"],
            [[x["map"], x["pixels"], pct(x["mean_by_max"]), pct(x["max_by_max"]),
              pct(x["mean_relative"]), pct(x["max_relative"], 1)] for x in r["maps"]],
            "lrrrrr",
        )  # fmt: skip
        return (
            f"{table}\n\nOver the maps: mean error {pct(r['mean_by_max'])} of the largest "
            f"irradiance, largest {pct(r['max_by_max'])}."
        )
    low, high = r["mean_by_max_range"]
    return rows(
        ["maps", "mean error / E_max (average over the maps)", "per map", "highest"],
        [[r["map_count"], pct(r["mean_by_max"]), f"{pct(low)} – {pct(high)}",
          r["mean_by_max_highest"]]],
        "rrll",
    )  # fmt: skip


INTEGRATORS = {
    "ls_perspective": "LS perspective",
    "least_squares": "LS orthographic",
    "poisson_dct": "DCT Poisson",
    "frankot_chellappa": "Frankot–Chellappa",
}


def vision_accuracy(r: dict) -> str:
    ps = rows(
        ["method", "mean °", "median °"],
        [[m, f"{e['mean']:.2f}", f"{e['median']:.2f}"] for m, e in r["psm_gray_sphere"].items()],
        "lrr",
    )
    integration = rows(
        ["object", *INTEGRATORS.values()],
        [[obj, *(f"{row[k]:.2f}" for k in INTEGRATORS)]
         for obj, row in r["diligent_integration_rmse_percent"].items()],
        "lrrrr",
    )  # fmt: skip
    return (
        "Photometric stereo on the real psm gray sphere, lights from the chrome sphere:\n\n"
        f"{ps}\n\nNormal integration of the real DiLiGenT ground-truth normals, depth RMSE "
        f"after fitting scale and offset, % of the depth range:\n\n{integration}"
    )


def normal_integration(r: dict) -> str:
    body = [
        [name, f"{o['pixels']:,}", f"{o['brdfkit_made_mm']:.4f}", f"{o['bini_made_mm']:.4f}",
         f"{o['least_squares_made_mm']:.3f}", f"{o['brdfkit_seconds']:.2f}",
         f"{o['bini_seconds']:.2f}"]
        for name, o in r["objects"].items()
    ]  # fmt: skip
    s = r["summary"]
    body.append(
        ["**all**", "", f"{s['brdfkit_mean_made_mm']:.4f} (mean)", f"{s['bini_mean_made_mm']:.4f}",
         "", f"{s['brdfkit_total_seconds']:.2f} (total)", f"{s['bini_total_seconds']:.2f}"]
    )  # fmt: skip
    header = ["object", "pixels", f"brdfkit {r['method']} MADE mm", "BiNI MADE mm",
              "least squares MADE mm", "brdfkit s", "BiNI s"]  # fmt: skip
    text = (
        f"{rows(header, body, 'lrrrrrr')}\n\nbrdfkit's MADE at most BiNI's on "
        f"{s['brdfkit_made_at_most_bini']} of {s['objects']} objects"
    )
    if "made_equal_to_bini" in s:
        text += f" (equal to within {s['tie_mm']:g} mm on {s['made_equal_to_bini']})"
    text += "."
    scenes = []
    for name, b in r.get("rendered", {}).items():
        equal = abs(b["brdfkit_made_mm"] - b["bini_made_mm"]) < s.get("tie_mm", 0.0)
        scenes.append(
            f"{name} ({b['pixels']:,} pixels): brdfkit {b['brdfkit_made_mm']:.4f} mm in "
            f"{b['brdfkit_seconds']:.2f} s, BiNI {b['bini_made_mm']:.4f} mm in "
            f"{b['bini_seconds']:.2f} s" + (" (equal)" if equal else "")
            + f", least squares {b['least_squares_made_mm']:.3f} mm"
        )  # fmt: skip
    if scenes:
        text += " Rendered in DiLiGenT's camera (not counted): " + "; ".join(scenes) + "."
    if "piecewise_made_mm_by_method" not in s:
        return text
    methods = list(s["made_mm_by_method"])
    pieces = rows(
        ["object", "pieces", *methods],
        [[name, o["pieces_over_100_pixels"],
          *(f"{o[f'{m}_made_mm']:.3f} / {o[f'{m}_piecewise_made_mm']:.3f}" for m in methods)]
         for name, o in r["objects"].items()]
        + [["**mean**", "", *(f"{s['made_mm_by_method'][m]:.3f} / "
                              f"{s['piecewise_made_mm_by_method'][m]:.3f}" for m in methods)]],
        "lr" + "r" * len(methods),
    )  # fmt: skip
    return (
        f"{text}\n\nMADE / piecewise MADE (each ground-truth piece scaled on its own; pieces "
        f"of over 100 pixels counted) in mm:\n\n{pieces}"
    )


def ps_depth(r: dict) -> str:
    integrations, s = r["integrations"], r["summary"]
    solvers = list(s[f"{integrations[0]}_mean_made_mm"])
    runs = {(o["object"], o["material"], o["solver"]): o for o in r["records"]}
    body = []
    for obj, material in dict.fromkeys((o["object"], o["material"]) for o in r["records"]):
        cells = []
        for solver in solvers:
            o = runs[obj, material, solver]
            cells += [f"{o['angular_error_deg']:.2f}",
                      *(f"{o[f'{name}_made_mm']:.3f}" for name in integrations)]  # fmt: skip
        truth = o["ground_truth_normals_made_mm"]
        body.append([obj, material, *cells, *(f"{truth[name]:.3f}" for name in integrations)])
    header = ["object", "material"]
    for solver in [*solvers, "true normals"]:
        if solver != "true normals":
            header.append(f"{solver} °")
        header += [f"{solver}, {name}" for name in integrations]
    means = "; ".join(
        f"{solver}: " + ", ".join(f"{name} {s[f'{name}_mean_made_mm'][solver]:.3f}"
                                  for name in integrations)
        for solver in solvers
    )  # fmt: skip
    return (
        f"One pixel in {r['step']} along each axis, noise {r['noise']}: the normals' mean angular "
        "error (°) and the depth's MADE (mm) by each integrator:\n\n"
        f"{rows(header, body, 'll' + 'r' * (len(header) - 2))}\n\n"
        f"bilateral_pieces below least squares in {s['bilateral_pieces_below_least_squares']} "
        f"of {s['runs']} runs; mean MADE (mm) {means}."
    )


def ps_cli(r: dict) -> str:
    body = [
        [o["object"], o["run"], " ".join(o["options"]) or "(none)",
         f"{o['method']}, {o['integration']}", f"{o['angular_error_deg']:.2f}",
         f"{100 * o['depth_relative_rmse']:.2f}",
         "" if o["light_error_deg"] is None else f"{o['light_error_deg']:.2f}",
         f"{o['wall_seconds']:.1f}", f"{o['cpu_seconds']:.1f}"]
        for o in r["records"]
    ]  # fmt: skip
    header = ["object", "run", "options", "method, integration", "normals' error °",
              "depth RMSE %", "lights' error °", "wall s", "CPU s"]  # fmt: skip
    return (
        f"`brdfkit ps FOLDER --json` on 96-image, 612 × 512 DiLiGenT folders ({r['material']}), "
        f"each a fresh process, caches warm but in the run so named (a first run after "
        f"installing):\n\n{rows(header, body, 'llllrrrrr')}"
    )


def brdf_explorer(r: dict) -> str:
    def opengl(x: dict) -> list[str]:
        if "opengl_error" not in x:
            return ["–", "–"]
        return [f"{x['opengl_error']:.1e}", pct(x["opengl_nonfinite"], 1)]

    files = rows(
        ["file", "parameters", "eval ms", "finite", "reciprocity", "max albedo",
         "OpenGL difference", "OpenGL NaN"],
        [[x["file"], x["parameters"], f"{x['eval_ms']:.1f}", pct(x["finite"]),
          f"{x['reciprocity']:.1e}", f"{x['max_albedo']:.3f}", *opengl(x)] for x in r["files"]],
        "lrrrrrrr",
    )  # fmt: skip
    peers = rows(
        ["file", "brdfkit model", "max relative difference", "shader ms", "brdfkit ms"],
        [[x["file"], f"`{x['peer']}`", f"{x['max_relative_difference']:.1e}",
          f"{x['shader_ms']:.1f}", f"{x['native_ms']:.1f}"] for x in r["peers"]],
        "llrrr",
    )  # fmt: skip
    return (
        f"One `eval` of {r['pairs']:,} direction pairs, default parameters:\n\n{files}\n\n"
        f"The translated shader against brdfkit's own code for its formula:\n\n{peers}"
    )


def export(r: dict) -> str:
    mitsuba = rows(
        ["model (Mitsuba 3 XML)", "pairs", "p99 relative error", "largest"],
        [
            [x["model"], f"{x['pairs']:,}", f"{x['p99']:.1e}", f"{x['max']:.1e}"]
            for x in r["mitsuba"]
        ],
        "lrrr",
    )
    rgl = rows(
        ["model (RGL table)", "sample square", "write s", "MB", "median", "p90", "p99",
         "reader vs Mitsuba"],
        [[x["model"], f"{x['resolution']}²", f"{x['seconds']:.1f}", f"{x['bytes'] / 1e6:.1f}",
          pct(x["median"]), pct(x["p90"], 1), pct(x["p99"], 1),
          f"{x['reader_vs_mitsuba_max']:.1e}" if "reader_vs_mitsuba_max" in x else "–"]
         for x in r["rgl"]],
        "lrrrrrrr",
    )  # fmt: skip
    return "\n\n".join(t for t in (mitsuba if r["mitsuba"] else "", rgl) if t)


def faults(r: dict) -> str:
    def line(run: dict) -> str:
        return " / ".join(run.get("stderr", [])) or "–"

    ctrl_c = [
        [x.get("command", "atlas"), f"{x['seconds']:.2f}" if x["seconds"] is not None else "hung",
         x["status"],
         x["processes_left"], x["temporaries_left"], line(x)]
        for x in r["interrupts"]
    ]  # fmt: skip
    inputs = [
        [label, r[key]["status"], f"{r[key]['peak_mib']:.0f}", line(r[key])]
        for label, key in (
            (f"PNG bomb, 20000 × 20000 ({r['png_bomb_bytes'] / 1e6:.1f} MB)", "png_bomb"),
            ("hdr -t 1,1,1, three different exposures", "equal_times"),
            ("fit of a MERL file with one 1e308 entry", "merl_1e308"),
        )
    ]
    start = r.get("start")
    if start:
        kinds = sorted({k for counts in start["outcomes_by_ms"].values() for k in counts})
        starts = rows(["SIGINT after (ms)", *kinds], [
            [ms, *(counts.get(k, 0) for k in kinds)]
            for ms, counts in start["outcomes_by_ms"].items()
        ], "r" + "r" * len(kinds))  # fmt: skip
        starts = (
            f"A Ctrl-C while `brdfkit atlas --help` starts ({start['starts']} starts per delay; "
            f"the interpreter alone takes {start['interpreter_ms']:.0f} ms to start, and "
            f"{start['to_guard_ms']:.0f} ms to reach brdfkit's guard, so a traceback is the "
            f"interpreter's own, before brdfkit's first line runs):\n\n{starts}"
        )
    e = r["explorer"]
    steps = [
        [x["message"], x["answer"], x["entry_errors"], f"{x['seconds']:.2f}"] for x in e["steps"]
    ]
    f = r["protocol_fuzz"]
    replies = ", ".join(f"{k} {v}" for k, v in sorted(f["replies"].items(), key=lambda i: -i[1]))
    return "\n\n".join([
        "Two Ctrl-C on a command whose workers are busy:",
        rows(["command", "s to exit", "status", "processes left", "temporaries left", "stderr"],
             ctrl_c, "lrrrrl"),
        *([starts] if start else []),
        "Hostile inputs on the command line:",
        rows(["input", "status", "peak MiB", "stderr"], inputs, "lrrl"),
        f"The explorer's server, one connection (its peak memory {e['peak_mib_before']:.0f} MiB "
        f"before, {e['peak_mib_after']:.0f} MiB after):",
        rows(["message", "answer", "entries refused", "s"], steps, "llrr"),
        f"The protocol fuzzed: {f['messages']:,} messages in {f['seconds']:.0f} s; replies: "
        f"{replies}; {'no message unanswered, no worker dead' if f['passed'] else 'FAILED'}.",
    ])  # fmt: skip


def install(r: dict) -> str:
    default, without = r["default"], r["without_jax"]
    sizes = rows(
        ["install", "site-packages MiB", "distributions"],
        [["default dependencies", f"{default['site_packages_mib']:,.0f}", default["distributions"]],
         ["without JAX (jax, jaxlib, ml_dtypes, opt_einsum)",
          f"{without['site_packages_mib']:,.0f}", without["distributions"]]],
        "lrr",
    )  # fmt: skip
    largest = rows(
        ["distribution (default install)", "MiB"],
        [[name, f"{mib:.1f}"] for name, mib in default["largest_mib"].items()],
        "lr",
    )
    start = rows(
        ["fresh process", "wall s (median)", "wall s (min)", "CPU s (median)"],
        [[f"`{name}`", f"{t['wall_median_s']:.3f}", f"{t['wall_min_s']:.3f}",
          f"{t['cpu_median_s']:.3f}"] for name, t in r["start_up"].items()],
        "lrrr",
    )  # fmt: skip
    return f"{sizes}\n\n{largest}\n\n{start}"


TABLES: dict[str, Callable[[dict], str]] = {
    "brdf": brdf,
    "render": render,
    "mesh": mesh,
    "render_cli": render_cli,
    "env_sampling": env_sampling,
    "envmap": envmap,
    "mis": mis,
    "sh": sh,
    "atlas": atlas,
    "explore": explore,
    "kulla_conty": kulla_conty,
    "kulla_conty_dielectric": kulla_conty_dielectric,
    "tracer": tracer,
    "fit": fit,
    "cornell_fits": cornell_fits,
    "loo_fits": loo_fits,
    "dask": dask,
    "photometric_stereo": photometric_stereo,
    "ps_materials": ps_materials,
    "bipolynomial": ps_materials,
    "uncalibrated": uncalibrated,
    "vision_accuracy": vision_accuracy,
    "normal_integration": normal_integration,
    "ps_depth": ps_depth,
    "ps_cli": ps_cli,
    "sfs": sfs,
    "relighting": relighting,
    "brdf_explorer": brdf_explorer,
    "bssrdf": bssrdf,
    "hdr": hdr,
    "export": export,
    "faults": faults,
    "install": install,
}
"""Every benchmark, in the order of ``benchmarks/README.md``."""


def section(name: str, results: Path = RESULTS) -> str:
    """The generated Markdown of one benchmark: its tables, then its machine line."""
    if not (results / f"{name}.json").exists():
        return f"(No results yet: run `python benchmarks/bench_{name}.py`.)"
    record = load(name, results)
    tables = TABLES[name](record) or "(This run recorded nothing that has a table.)"
    return f"{tables}\n\n{machine_line(record)}"


# --- the README's comparison with peers ------------------------------------------------------


def peers(results: Path = RESULTS) -> str:
    """One row per comparison with a peer, each from a results file; a row whose numbers a
    file lacks (a run without its peer) is left out."""
    body: list[list[str]] = []
    for row in (_render_peer, _brdf_peers, _fit_peer, _ps_peer, _integration_peer):
        try:
            body += row(results)
        except (OSError, KeyError, StopIteration, ValueError):
            continue
    return rows(["task", "peer", "brdfkit", "command"], body)


def _render_peer(results: Path) -> list[list[str]]:
    record = load("render", results)
    render_rows, variant = record["rows"], record["mitsuba"].split()[-1]
    ratios = [
        x.get("compiled_efficiency_ratio") or x["numpy_efficiency_ratio"] for x in render_rows
    ]
    scenes = ", ".join(dict.fromkeys(x["scene"] for x in render_rows))
    spps = " and ".join(str(spp) for spp in dict.fromkeys(x["spp"] for x in render_rows))
    return [
        ["Rendering a sphere under an environment map (efficiency: 1 / (time × error²))",
         f"Mitsuba 3 `direct`, `{variant}` ({scenes}; {spps} spp)",
         f"{min(ratios):.1f}–{max(ratios):.0f}× Mitsuba's", "`python benchmarks/bench_render.py`"]
    ]  # fmt: skip


def _brdf_peers(results: Path) -> list[list[str]]:
    brdf_rows = load("brdf", results)["rows"]

    def rate(workload: str, n: int, impl: str) -> float:
        return next(
            x["per_second"]
            for x in brdf_rows
            if (x["workload"], x["n"]) == (workload, n) and x["impl"] == impl
        )

    mitsuba = "Mitsuba 3 llvm_ad_rgb"
    ggx = [
        rate("eval", n, "brdfkit accel f32") / rate("eval", n, mitsuba)
        for n in (10**6, 10**7)
        if any(x["n"] == n for x in brdf_rows)
    ]
    sample = rate("sample+eval", 10**6, "brdfkit accel f32") / rate("sample+eval", 10**6, mitsuba)
    return [
        ["GGX conductor `eval`, float32, 10⁶ and 10⁷ pairs (compiled)", "Mitsuba 3 `llvm_ad_rgb`",
         " and ".join(f"{g:.2f}×" for g in ggx) + " Mitsuba's rate",
         "`python benchmarks/bench_brdf.py`"],
        ["Lambertian + GGX, sample then eval, 10⁶ (compiled)", "Mitsuba 3 `llvm_ad_rgb`",
         f"{sample:.2f}× Mitsuba's rate", "`python benchmarks/bench_brdf.py`"],
    ]  # fmt: skip


def _fit_peer(results: Path) -> list[list[str]]:
    f = load("fit", results)
    ours = min(x["seconds"] for x in f["runs"]["default"])
    theirs = min(x["seconds"] for x in f["runs"]["peer_2point"])
    return [
        ["Fitting Lambertian + 2 GGX lobes to a MERL-sized table",
         "SciPy `least_squares`, 2-point Jacobian",
         f"{ours:.1f} s against {theirs:.1f} s (best of {len(f['runs']['default'])})",
         "`python benchmarks/bench_fit.py`"]
    ]  # fmt: skip


def _ps_peer(results: Path) -> list[list[str]]:
    _, table = ps_materials_averages(load("ps_materials", results))
    average = table["average"]
    best = min(average, key=average.get)
    return [
        ["Calibrated photometric stereo, DiLiGenT-layout renders of the real DiLiGenT normals, "
         f"{len(table) - 1} material{'s' if len(table) > 2 else ''} (mean angular error)",
         "least squares (Woodham 1980, DiLiGenT's baseline)",
         f"{average[best]:.1f}° ({PS_NAMES.get(best, best)}) against "
         f"{average['least_squares']:.1f}°", "`python benchmarks/bench_ps_materials.py`"]
    ]  # fmt: skip


def _integration_peer(results: Path) -> list[list[str]]:
    s = load("normal_integration", results)["summary"]
    return [
        [f"Normal integration, the real DiLiGenT ground-truth normals of {s['objects']} objects "
         "(mean absolute depth error)", "BiNI (Cao et al. 2022), its public code",
         f"{s['brdfkit_mean_made_mm']:.2f} mm against {s['bini_mean_made_mm']:.2f} mm "
         f"(at most BiNI's on {s['brdfkit_made_at_most_bini']} of {s['objects']}), in "
         f"{s['brdfkit_total_seconds']:.1f} s against {s['bini_total_seconds']:.1f} s",
         "`python benchmarks/bench_normal_integration.py --peer PATH`"]
    ]  # fmt: skip


# --- documents -------------------------------------------------------------------------------


def replace(text: str, marker: str, body: str) -> str:
    """``text`` with what lies between ``<!-- marker -->`` and ``<!-- end marker -->`` set to
    ``body``; KeyError if the markers are missing."""
    start, end = f"<!-- {marker} -->", f"<!-- end {marker} -->"
    pattern = re.compile(rf"{re.escape(start)}\n.*?{re.escape(end)}", re.DOTALL)
    if not pattern.search(text):
        raise KeyError(f"markers {start} … {end} not found")
    return pattern.sub(lambda _: f"{start}\n{body}\n{end}", text, count=1)


def documents(results: Path = RESULTS) -> dict[Path, str]:
    """The two documents as they should read, given the results."""
    text = BENCHMARKS_README.read_text(encoding="utf-8")
    for name in TABLES:
        text = replace(text, f"results: {name}", section(name, results))
    readme = replace(README.read_text(encoding="utf-8"), "peers", peers(results))
    return {BENCHMARKS_README: text, README: readme}


def problems(results: Path = RESULTS) -> list[str]:
    """What is amiss in ``results`` itself: files no benchmark writes, missing files, too many."""
    scripts = {p.stem.removeprefix("bench_") for p in HERE.glob("bench_*.py")}
    files = sorted(p.name for p in results.iterdir() if not p.name.startswith("."))
    found = []
    if len(files) > len(scripts):
        found.append(f"{len(files)} files in {results} for {len(scripts)} benchmark scripts")
    for name in files:
        if not name.endswith(".json") or name.removesuffix(".json") not in scripts:
            found.append(f"{name}: no bench_*.py writes it")
    for name in sorted(scripts - {f.removesuffix(".json") for f in files}):
        found.append(f"bench_{name}.py has no results file")
    for name in sorted(scripts - set(TABLES)):
        found.append(f"bench_{name}.py has no table in tables.py")
    return found


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="exit 1 if anything is stale")
    args = parser.parse_args()
    found = problems()
    for path, text in documents().items():
        if path.read_text(encoding="utf-8") != text:
            if args.check:
                found.append(f"{path.relative_to(HERE.parent)} is stale: run benchmarks/tables.py")
            else:
                path.write_text(text, encoding="utf-8")
                print(f"rewrote the tables of {path.relative_to(HERE.parent)}")
    for problem in found:
        print(problem, file=sys.stderr)
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
