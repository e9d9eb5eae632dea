"""The README's screenshot of ``brdfkit explore``: the real page in headless Chromium.

Three BRDFs (Lambertian + GGX, gold GGX, and a MERL-layout table written from an analytic model)
with the environment-lit spheres on, after 64 samples per pixel. Run
``python examples/explore_screenshot.py [OUT.png]`` (default ``docs/images/explore.png``); it needs
the ``explore`` and ``explore-test`` extras and ``/usr/bin/chromium``. (Not a gallery example: it
serves a page.)
"""

from __future__ import annotations

import io
import sys
import tempfile
from pathlib import Path

from PIL import Image
from playwright.sync_api import sync_playwright

from brdfkit.brdf import parse
from brdfkit.explore.server import ExplorerServer
from brdfkit.explore.session import Session
from brdfkit.io import atomic_write_bytes
from brdfkit.measured import write_merl

OUT = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("docs/images/explore.png")

with tempfile.TemporaryDirectory() as folder, sync_playwright() as p:
    merl = Path(folder) / "blue-plastic.binary"
    write_merl(merl, parse("lambertian(albedo=[0.05, 0.15, 0.5]) + 0.3 * ggx(alpha=0.08)"))
    session = Session()
    name = session.add_file(merl)
    specs = ["lambertian(albedo=[0.8, 0.4, 0.2]) + ggx(alpha=0.2)", "ggx(alpha=0.3, material='Au')"]
    server = ExplorerServer(session, [*specs, name]).start()
    session.warmed.wait(timeout=300)
    browser = p.chromium.launch(
        executable_path="/usr/bin/chromium",
        args=["--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--no-sandbox"],
    )
    page = browser.new_context(viewport={"width": 1700, "height": 1150}, bypass_csp=True).new_page()
    page.goto(server.url)
    page.wait_for_function("window.explorer && window.explorer.shown.seq > 0", timeout=60_000)
    page.locator(".bx-envmap").check()
    page.wait_for_function(
        "() => ['b1', 'b2', 'b3'].every((id) => (window.explorer.env[id] || {}).samples >= 64)",
        timeout=600_000,
        polling=500,
    )
    png = page.screenshot(full_page=True)
    browser.close()
    server.stop()

image = Image.open(io.BytesIO(png)).convert("RGB").quantize(colors=256, dither=Image.Dither.NONE)
buffer = io.BytesIO()
image.save(buffer, format="PNG", optimize=True)
atomic_write_bytes(OUT, buffer.getvalue())
print(f"wrote {OUT} ({len(buffer.getvalue()) // 1024} KB)")
