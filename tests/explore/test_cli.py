"""``brdfkit explore``: bad input is one line on stderr and exit 2; a good one serves the page."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import urllib.request
from pathlib import Path

import pytest
from typer.testing import CliRunner

from brdfkit.cli import app

pytest.importorskip("starlette")
pytest.importorskip("uvicorn")

runner = CliRunner()


def one_error_line(result, *fragments: str) -> str:
    assert result.exit_code == 2, result.output
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])
    return lines[0]


def test_a_bad_spec_is_refused_before_serving():
    one_error_line(runner.invoke(app, ["explore", "--no-browser", "ggx(alpha=99)"]), "alpha")
    one_error_line(runner.invoke(app, ["explore", "--no-browser", "nosuch"]), "nosuch")


def test_a_bad_file_is_refused_before_serving(tmp_path):
    bad = tmp_path / "broken.binary"
    bad.write_bytes(b"not a table")
    one_error_line(runner.invoke(app, ["explore", "--no-browser", str(bad)]), "broken.binary")
    missing = tmp_path / "missing.brdf"
    one_error_line(runner.invoke(app, ["explore", "--no-browser", str(missing)]), "missing.brdf")
    envmap = tmp_path / "sky.hdr"
    result = runner.invoke(app, ["explore", "--no-browser", "--envmap", str(envmap)])
    one_error_line(result, "sky.hdr")
    broken_mesh = tmp_path / "broken.ply"
    broken_mesh.write_text("garbage")
    result = runner.invoke(app, ["explore", "--no-browser", str(broken_mesh)])
    one_error_line(result, "broken.ply")


def test_a_bad_port_is_refused():
    one_error_line(runner.invoke(app, ["explore", "--no-browser", "--port", "70000"]), "--port")


@pytest.mark.slow
def test_the_command_serves_the_page_on_loopback():
    import brdfkit

    env = {**os.environ, "PYTHONPATH": str(Path(brdfkit.__file__).parents[1])}
    process = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "from brdfkit.cli import main; main()",
            "explore",
            "--no-browser",
            "ggx(alpha=0.1)",
        ],
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    try:
        for _ in range(100):  # the address line (warnings may come first)
            found = re.search(r"http://127\.0\.0\.1:\d+/[\w-]+/", process.stderr.readline())
            if found:
                break
        url = found.group(0)
        with urllib.request.urlopen(url, timeout=10) as response:
            assert response.status == 200 and b"explorer" in response.read()
    finally:
        process.terminate()
        process.wait(timeout=10)


def test_a_bad_fit_json_is_refused(tmp_path):
    fit = tmp_path / "fit.json"
    fit.write_text('{"spec": "ggx(alpha=-1)"}')
    one_error_line(runner.invoke(app, ["explore", "--no-browser", str(fit)]), "alpha")
    fit.write_text("[]")
    one_error_line(runner.invoke(app, ["explore", "--no-browser", str(fit)]), "fit.json")
