"""Fixtures of the explorer tests: a MERL-layout file, the server, headless Chromium."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

CHROMIUM = os.environ.get("BRDFKIT_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = ["--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--no-sandbox"]
INITIAL = "lambertian(albedo=[0.8, 0.4, 0.2]) + ggx(alpha=0.2)"
MERL_SOURCE = "lambertian(albedo=[0.3, 0.5, 0.7]) + ggx(alpha=0.15)"


def chromium_or_skip() -> str:
    """The Chromium binary, or skip: these tests drive a real browser (no download)."""
    pytest.importorskip("playwright.sync_api", reason="needs playwright (pip install playwright)")
    if not (Path(CHROMIUM).exists() or shutil.which(CHROMIUM)):
        pytest.skip(f"needs Chromium at {CHROMIUM} (set BRDFKIT_CHROMIUM)")
    return CHROMIUM


@pytest.fixture(scope="session")
def merl_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A MERL ``.binary`` table of an analytic BRDF, in the exact MERL layout."""
    from brdfkit.brdf import parse
    from brdfkit.measured import write_merl

    path = tmp_path_factory.mktemp("merl") / "blue-ggx.binary"
    write_merl(path, parse(MERL_SOURCE))
    return path


@pytest.fixture(scope="module")
def server(merl_file: Path):
    """The explorer on a free port, with the MERL file named as on the command line."""
    pytest.importorskip("starlette")
    pytest.importorskip("uvicorn")
    from brdfkit.explore.server import ExplorerServer
    from brdfkit.explore.session import Session

    session = Session()
    session.add_file(merl_file)
    srv = ExplorerServer(session, [INITIAL]).start()
    yield srv
    srv.stop()


@pytest.fixture(scope="module")
def browser():
    """Headless Chromium (Debian's) driven by Playwright, with software WebGL."""
    executable = chromium_or_skip()
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=executable, args=CHROMIUM_ARGS)
        yield b
        b.close()


@pytest.fixture(scope="module")
def page(server, browser):
    """The explorer's page, loaded and settled; ``page.errors`` collects page-side errors."""
    from _page import settled

    context = browser.new_context(
        viewport={"width": 1500, "height": 1100}, bypass_csp=True, accept_downloads=True
    )
    p = context.new_page()
    errors: list[str] = []
    p.on("pageerror", lambda e: errors.append(str(e)))
    p.goto(server.url)
    settled(p)
    p.errors = errors
    yield p
    context.close()
