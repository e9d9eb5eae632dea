"""Explorer latency in a real browser: slider → updated sphere and plots, and the env-lit sphere.

Starts ``brdfkit explore``'s server in-process and drives the real page in headless Chromium
(Debian's ``/usr/bin/chromium``): for each workload the θi slider is dragged
``--moves`` steps, one step after the previous frame is shown, and the time from the slider's
``input`` event to the frame being drawn (the directional-light sphere and every plot of every
visible BRDF) is measured in the page with ``performance.now()``. The slider is held
(``pointerdown``) through the steps and released after them: while it is dragged the page asks
for previews, the sphere at half resolution (128² of 256²); ``preview share`` says how many of
the measured frames were previews. The steps come in drags of five (a first, unmeasured step
then five measured ones, each as soon as the previous frame is shown), with five renders of
the peer between the drags. ``click`` is the full 256² image: a single step after the
page has rested (an ``input`` and a ``change`` event, as a click on the slider's track or a
key), from the event to the full frame drawn. The peer is the full sphere rendered in Python
by :func:`brdfkit.render.render_sphere` (the compute alone), so the ratio latency / render
says what the server, the WebSocket and the drawing add.
Workloads: Lambertian + GGX, and a MERL-layout table (written by
:func:`brdfkit.measured.write_merl`, read back as a tabulated BRDF).

Under the environment map (the bundled one), the time from switching the view on to the first
image (the exact diffuse term, :func:`brdfkit.explore.views.diffuse_term`), to the first pass
(1 spp of each of the estimator's two Sobol' replicates) and to 1 % relative noise (the RMS
error / mean over the sphere, estimated without bias from the two replicates:
:func:`brdfkit.explore.views.relative_noise`) is reported,
after the server's warm-up (which builds the compiled kernels of the shown BRDF).

The lit object (the bundled shader ball under the map, with shadows, 128², refined to 64 spp
on the server's compiled path, shadow rays through Embree): the sphere's slider latency is
measured again with the lit view on and restarted before every other move (so that its
passes run while the slider moves), interleaved with moves where it is off; and the orbit
latency, from a drag on the lit image (``pointermove``) to the first pass of the new camera
drawn in the page, with the server's seconds for that pass and for 64 spp.

The sphere's latency is from the slider's ``input`` event until the page has drawn the reply
holding every view (sphere, polar, θv/θh/θd curves, lobe, slice); ``server views ms`` is the
Python time of those views, ``page draw ms`` the page's drawing of them.

The browser composites the page as a user's does: ``--compositor software`` (the main
record) is Chromium's own default here, a browser without a GPU, which rasterises and
composites on the CPU (a browser with a GPU does both on the GPU); the page itself draws with
2D canvases only. ``swiftshader`` adds the flags the browser tests use elsewhere for WebGL
(``--use-angle=swiftshader``): a GPU emulated on the CPU. On this benchmark's 2-core machine
that emulation costs about 0.25 s of CPU per click (``gpu CPU ms per click``: the CPU time
of Chromium's GPU process over the clicks, read from ``/proc``; under 10 ms with the
default), which competes for the two cores with the server; no user's browser runs it, but
it is measured as well (the second table) to show that cost.

Run ``python benchmarks/bench_explore.py`` (needs the ``explore`` and ``explore-test``
extras); results go to ``benchmarks/results/explore.json`` and a Markdown table on stdout.

``--session`` measures the environment-map figures without a browser: the server's own
:meth:`~brdfkit.explore.session.Session.environment` replies, each encoded as the WebSocket
frame it would send (:func:`~brdfkit.explore.protocol.encode_frame`), after the same
warm-up; per repeat the wall and CPU seconds (``time.process_time``, both cores) to the first
image, the first pass and 1 % noise, and the samples per pixel then. It leaves out the page's
decoding and drawing (a few ms per pass) and needs no browser; its results go to the same
file, ``benchmarks/results/explore.json``, in place of the browser's.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

from brdfkit.brdf import parse
from brdfkit.explore.protocol import Entry, Message, encode_frame
from brdfkit.explore.server import ExplorerServer
from brdfkit.explore.session import Session
from brdfkit.explore.views import ViewState
from brdfkit.measured import read, write_merl
from brdfkit.render import render_sphere

COMPOSITORS = {
    "software": ["--no-sandbox"],
    "swiftshader": ["--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--no-sandbox"],
}
"""Chromium's flags per compositor (``--no-sandbox``: the benchmark runs as root)."""
ANALYTIC = "lambertian(albedo=[0.8, 0.4, 0.2]) + ggx(alpha=0.2)"

MOVE = """(value) => new Promise((resolve) => {
  const x = window.explorer, range = document.querySelector('.bx-theta_i');
  const start = performance.now(), before = x.shown.seq;
  const done = () => x.shown && x.sent && x.shown.seq > before && x.shown.seq === x.sent.seq;
  const wait = () => done()
      ? resolve([x.shown.time - start, 1e3 * x.frame().header.seconds, x.drawMs,
                 !!x.shown.preview])
      : requestAnimationFrame(wait);
  range.value = value; range.dispatchEvent(new Event('input'));
  requestAnimationFrame(wait);
})"""

CLICK = """(value) => new Promise((resolve) => {
  const x = window.explorer, range = document.querySelector('.bx-theta_i');
  const start = performance.now(), before = x.shown.seq;
  const done = () => x.shown.seq > before && x.shown.seq === x.sent.seq && !x.moving
      && !x.shown.preview;
  const wait = () => done() ? resolve(x.shown.time - start) : requestAnimationFrame(wait);
  range.value = value;
  range.dispatchEvent(new Event('input')); range.dispatchEvent(new Event('change'));
  requestAnimationFrame(wait);
})"""

HOLD = """(name) => document.querySelector('.bx-theta_i').dispatchEvent(new PointerEvent(name))"""

REST_MS = 400
"""Milliseconds the page is left alone before a click (beyond its rest time: a single step)."""

ENV = """([limit]) => new Promise((resolve) => {
  const x = window.explorer, box = document.querySelector('.bx-envmap');
  const start = performance.now();
  let first = null, firstPass = null;
  box.checked = true; box.dispatchEvent(new Event('change'));
  const seq = x.sent.seq;
  const poll = () => {
    const e = x.env.b1;
    if (e && e.seq >= seq) {
      if (first === null) first = e.time - start;
      if (firstPass === null && e.samples >= 1) firstPass = e.time - start;
      if (e.noise > 0 && e.noise <= 0.01) {
        return resolve({first, firstPass, noise1: e.time - start, ...e});
      }
    }
    if (performance.now() - start > limit) {
      return resolve({first, firstPass, noise1: null, ...(e || {})});
    }
    setTimeout(poll, 10);
  };
  poll();
})"""


def gpu_process_cpu_ms() -> float:
    """CPU milliseconds used so far by the GPU processes of the browsers this process started
    (Linux ``/proc``; 0 elsewhere)."""
    parents, gpu, ticks = {}, [], os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100
    for entry in Path("/proc").glob("[0-9]*"):
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            command = (entry / "cmdline").read_bytes()
        except OSError:
            continue
        parents[int(entry.name)] = int(fields[1])
        if b"--type=gpu-process" in command:
            gpu.append((int(entry.name), int(fields[11]) + int(fields[12])))

    def ours(pid: int) -> bool:
        while pid > 1:
            if pid == os.getpid():
                return True
            pid = parents.get(pid, 1)
        return False

    return 1e3 * sum(t for pid, t in gpu if ours(pid)) / ticks


def percentile(values: list[float], q: float) -> float:
    return float(np.percentile(values, q))


DRAG_STEPS = 5
"""Steps of each drag; between drags, as many renders of the peer."""


def latency(page: Any, brdf: Any, moves: int) -> dict[str, Any]:
    """Slider-to-frame times in the page while the slider is dragged (drags of
    :data:`DRAG_STEPS` steps, each after its first, which is a full image, with as many
    render_sphere timings between the drags); then single steps at rest (clicks) to the full
    image."""
    browser_ms, render_ms, server_ms, draw_ms, previews = [], [], [], [], 0
    for i in range(moves):
        theta = 20 + (i * 37) % 60
        if i % DRAG_STEPS == 0:
            page.evaluate(HOLD, "pointerdown")  # the slider held: a drag
            page.evaluate(MOVE, theta + 1)  # its first step: a full image
        total, server, draw, preview = page.evaluate(MOVE, theta)
        browser_ms.append(total)
        server_ms.append(server)
        draw_ms.append(draw)
        previews += preview
        if i % DRAG_STEPS == DRAG_STEPS - 1 or i == moves - 1:
            page.evaluate(HOLD, "pointerup")
            for k in range(i - i % DRAG_STEPS, i + 1):
                light = ViewState(theta_i=20 + (k * 37) % 60).light()
                start = time.perf_counter()
                render_sphere(brdf, light, resolution=256)
                render_ms.append(1e3 * (time.perf_counter() - start))
    click_ms = []
    gpu_before = gpu_process_cpu_ms()
    for i in range(max(moves // 2, 1)):
        page.wait_for_timeout(REST_MS)
        click_ms.append(page.evaluate(CLICK, 25 + (i * 41) % 60))
    gpu_ms = gpu_process_cpu_ms() - gpu_before
    median = statistics.median(browser_ms)
    return {
        "median_ms": median,
        "p95_ms": percentile(browser_ms, 95),
        "preview_share": previews / moves,
        "click_median_ms": statistics.median(click_ms),
        "click_p95_ms": percentile(click_ms, 95),
        "gpu_process_cpu_ms_per_click": gpu_ms / len(click_ms),
        "render_sphere_median_ms": statistics.median(render_ms),
        "ratio_to_render_sphere": median / statistics.median(render_ms),
        "server_views_median_ms": statistics.median(server_ms),
        "page_draw_median_ms": statistics.median(draw_ms),
        "moves": moves,
        "clicks": len(click_ms),
    }


LIT_TOGGLE = """(on) => { const box = document.querySelector('.bx-lit');
  if (box.checked !== on) { box.checked = on; box.dispatchEvent(new Event('change')); } }"""


def lit_latency(page: Any, moves: int) -> dict[str, Any]:
    """The sphere's slider latency with the lit object refining (restarted before each such
    move) and without it, interleaved."""
    times: dict[bool, list[float]] = {True: [], False: []}
    for i in range(moves):
        on = i % 2 == 0
        page.evaluate(LIT_TOGGLE, on)
        if on:  # a fresh start: wait for its first pass, so that the rest runs during the move
            page.wait_for_function(
                "(seq) => (window.explorer.lit.b1 || {seq: 0}).seq >= seq",
                arg=page.evaluate("window.explorer.sent.seq"),
                timeout=120_000,
            )
        else:
            page.wait_for_function("() => window.explorer.shown.seq === window.explorer.sent.seq")
        times[on].append(page.evaluate(MOVE, 20 + (i * 37) % 60)[0])
    return {
        "slider_median_ms_lit_on": statistics.median(times[True]),
        "slider_p95_ms_lit_on": percentile(times[True], 95),
        "slider_median_ms_lit_off": statistics.median(times[False]),
        "slider_p95_ms_lit_off": percentile(times[False], 95),
        "moves": moves,
    }


def orbit_latency(page: Any, orbits: int) -> dict[str, Any]:
    """Drag → first pass of the new camera in the page (ms), and the server's seconds for it
    and for the last pass (64 spp), over ``orbits`` drags of 20 px."""
    page.evaluate(LIT_TOGGLE, True)
    first_ms, first_server_s, full_s = [], [], []
    for i in range(orbits):
        box = page.locator('.bx-lit-image[data-id="b1"]').bounding_box()
        x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
        page.mouse.move(x, y)
        page.mouse.down()
        page.mouse.move(x + (20 if i % 2 else -20), y)
        page.mouse.up()
        view = page.evaluate(
            "[window.explorer.state.view.azimuth, window.explorer.state.view.elevation]"
        )
        wait = (
            "([a, e, n]) => { const l = window.explorer.lit.b1 || {};"
            " return l.azimuth === a && l.elevation === e && l.samples >= n; }"
        )
        page.wait_for_function(wait, arg=[*view, 1], timeout=120_000, polling="raf")
        lit = page.evaluate("window.explorer.lit.b1")
        first_ms.append(lit["time"] - page.evaluate("window.explorer.orbited"))
        first_server_s.append(lit["seconds"])
        page.wait_for_function(wait, arg=[*view, 64], timeout=300_000, polling=50)
        full_s.append(page.evaluate("window.explorer.lit.b1.seconds"))
    return {
        "orbit_to_first_pass_median_ms": statistics.median(first_ms),
        "orbit_to_first_pass_p95_ms": percentile(first_ms, 95),
        "first_pass_server_median_s": statistics.median(first_server_s),
        "to_64_spp_server_median_s": statistics.median(full_s),
        "orbits": orbits,
    }


def environment_session(session: Session, spec: str, limit: float) -> dict[str, Any]:
    """The environment-lit sphere's replies in-process (``--session``): seconds (wall and
    CPU) to the first image, the first pass and 1 % noise, as the page's ENV script times
    them, each reply encoded as its WebSocket frame."""
    message = Message("render", 1, (Entry("b1", True, "spec", spec),), ViewState(envmap=True))
    cancel = threading.Event()
    record: dict[str, Any] = {"first": None, "first_pass": None, "noise1": None}
    start, cpu = time.perf_counter(), time.process_time()
    for header, arrays in session.environment(message, cancel):
        encode_frame(header, [a.tobytes() for a in arrays])
        wall, used = time.perf_counter() - start, time.process_time() - cpu
        if record["first"] is None:
            record["first"] = wall
        if record["first_pass"] is None and header["samples"] >= 1:
            record["first_pass"] = wall
        record.update(samples=header["samples"], noise=header["noise"], seconds=wall, cpu=used)
        noise = header["noise"]
        if noise is not None and 0 < noise <= 0.01:
            record["noise1"], record["noise1_cpu"] = wall, used
            break
        if wall > limit:
            break
    cancel.set()
    return record


def session_main(args: argparse.Namespace) -> None:
    """``--session``: the environment-map figures without a browser, ``--repeats`` times."""
    session = Session()
    start = time.perf_counter()
    session.warm_up([ANALYTIC])
    warm_up = time.perf_counter() - start
    runs = [environment_session(session, ANALYTIC, args.env_limit) for _ in range(args.repeats)]
    from _machine import header

    results = {**header(__file__, packages=("starlette", "uvicorn", "websockets")),
               "platform": platform.platform(), "warm_up_s": warm_up,
               "runs": runs}  # fmt: skip
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(results, indent=2) + "\n")
    print("| run | first image ms | first pass ms | 1 % noise s | CPU s | spp | noise % |")
    print("|---|---|---|---|---|---|---|")
    for i, r in enumerate(runs):
        noise1 = "not reached" if r["noise1"] is None else f"{r['noise1']:.2f}"
        cpu = r.get("noise1_cpu", r["cpu"])
        print(
            f"| {i} | {1e3 * r['first']:.0f} | {1e3 * r['first_pass']:.0f} | {noise1} | "
            f"{cpu:.2f} | {r['samples']} | {100 * r['noise']:.2f} |"
        )


def browser_workloads(browser: Any, merl: Path, args: argparse.Namespace) -> dict[str, Any]:
    """Every workload's record in one browser: Lambertian + GGX (with the environment map and
    the lit object) and the MERL-layout table, each on a new server and page."""
    workloads = {}
    for name, item in (("lambertian+ggx", ANALYTIC), ("MERL table", str(merl))):
        session = Session()
        initial = [session.add_file(item)] if item.endswith(".binary") else [item]
        brdf = read(merl) if item.endswith(".binary") else parse(item)
        server = ExplorerServer(session, initial).start()
        session.warmed.wait(timeout=300)
        context = browser.new_context(viewport={"width": 1500, "height": 1100}, bypass_csp=True)
        page = context.new_page()
        page.goto(server.url)
        # until the module runs, window.explorer is the page's <div id="explorer">
        page.wait_for_function("(window.explorer?.shown?.seq ?? 0) > 0")
        record = latency(page, brdf, args.moves)
        if name == "lambertian+ggx":
            record["envmap"] = page.evaluate(ENV, [1e3 * args.env_limit])
            record["lit"] = {
                **lit_latency(page, args.lit_moves or args.moves),
                **orbit_latency(page, args.orbits),
            }
        workloads[name] = record
        context.close()
        server.stop()
    return workloads


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--moves", type=int, default=40)
    parser.add_argument("--chromium", default="/usr/bin/chromium")
    parser.add_argument("--env-limit", type=float, default=20.0, help="seconds")
    parser.add_argument("--orbits", type=int, default=6, help="drags of the lit object")
    parser.add_argument("--lit-moves", type=int, default=None, help="default: --moves")
    parser.add_argument("--session", action="store_true", help="env map figures, no browser")
    parser.add_argument("--repeats", type=int, default=3, help="--session runs")
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument(
        "--compositor",
        nargs="+",
        choices=sorted(COMPOSITORS),
        default=["software", "swiftshader"],
        help="Chromium's compositor(s), the first one the main record",
    )
    args = parser.parse_args()
    args.out = args.out or Path(__file__).parent / "results/explore.json"
    if args.session:
        return session_main(args)
    from playwright.sync_api import sync_playwright

    from _machine import header

    results: dict[str, Any] = {
        **header(__file__, packages=("playwright", "starlette", "uvicorn", "websockets")),
        "platform": platform.platform(),
        "load_average_before": os.getloadavg(),
        "workloads": {},
    }
    with tempfile.TemporaryDirectory() as folder, sync_playwright() as p:
        merl = Path(folder) / "table.binary"
        write_merl(merl, parse("lambertian(albedo=[0.3, 0.5, 0.7]) + ggx(alpha=0.15)"))
        for k, compositor in enumerate(args.compositor):
            browser = p.chromium.launch(executable_path=args.chromium, args=COMPOSITORS[compositor])
            workloads = browser_workloads(browser, merl, args)
            browser.close()
            if k == 0:
                results["compositor"], results["workloads"] = compositor, workloads
            else:
                results.setdefault("other_compositors", {})[compositor] = workloads
    results["load_average_after"] = os.getloadavg()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(results, indent=2) + "\n")
    every = {results["compositor"]: results["workloads"], **results.get("other_compositors", {})}
    print("| compositor | workload | median ms | p95 ms | preview share | click median ms | click "
          "p95 ms | server views ms | page draw ms | render_sphere ms | ratio |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for compositor, workloads in every.items():
        for name, r in workloads.items():
            print(
                f"| {compositor} | {name} | {r['median_ms']:.1f} | {r['p95_ms']:.1f} | "
                f"{r['preview_share']:.2f} | {r['click_median_ms']:.1f} | "
                f"{r['click_p95_ms']:.1f} | {r['server_views_median_ms']:.1f} | "
                f"{r['page_draw_median_ms']:.1f} | {r['render_sphere_median_ms']:.1f} | "
                f"{r['ratio_to_render_sphere']:.2f} |"
            )
    for compositor, workloads in every.items():
        lit = workloads["lambertian+ggx"]["lit"]
        print(
            f"\n{compositor}: gpu CPU ms per click "
            f"{workloads['lambertian+ggx']['gpu_process_cpu_ms_per_click']:.0f}; "
            f"lit object: sphere slider median {lit['slider_median_ms_lit_on']:.1f} ms with it "
            f"refining, {lit['slider_median_ms_lit_off']:.1f} ms without (p95 "
            f"{lit['slider_p95_ms_lit_on']:.1f} / {lit['slider_p95_ms_lit_off']:.1f}); orbit to "
            f"first pass {lit['orbit_to_first_pass_median_ms']:.0f} ms (server "
            f"{lit['first_pass_server_median_s']:.2f} s), 64 spp after "
            f"{lit['to_64_spp_server_median_s']:.1f} s"
        )
    env = results["workloads"]["lambertian+ggx"]["envmap"]
    noise1 = "not reached" if env["noise1"] is None else f"{env['noise1']:.0f} ms"
    first_pass = "none" if env["firstPass"] is None else f"{env['firstPass']:.0f} ms"
    first = "none" if env["first"] is None else f"{env['first']:.0f} ms"
    print(
        f"\nenvironment map: first image {first} (first pass {first_pass}); "
        f"1 % noise {noise1} "
        f"(last pass: {env.get('samples')} spp, noise {100 * (env.get('noise') or 0):.1f} %)"
    )


if __name__ == "__main__":
    main()
