"""``brdfkit materials``: lists the presets (text and JSON), filters by fit and model, refuses
an unknown fit with one line and status 2."""

from __future__ import annotations

import json

from typer.testing import CliRunner

from brdfkit.brdf import parse
from brdfkit.brdf.presets import catalogue
from brdfkit.cli import app

runner = CliRunner()


def test_json_lists_every_preset_with_a_spec_that_parses():
    result = runner.invoke(app, ["materials", "--json"])
    assert result.exit_code == 0, result.output
    records = json.loads(result.stdout)
    assert records == catalogue()
    assert len(records) == 86 * 6 + 100 * 7
    assert parse(records[0]["spec"]).eval is not None


def test_filters_by_fit_and_model():
    result = runner.invoke(app, ["materials", "--json", "--model", "ward"])
    assert {r["fit"] for r in json.loads(result.stdout)} == {"ngan_ward", "ngan_wardduer"}
    result = runner.invoke(app, ["materials", "--fit", "low_lowsmooth_E2"])
    assert result.exit_code == 0
    assert "low_lowsmooth_E2" in result.stdout and "alum-bronze" in result.stdout
    assert "ngan_ward" not in result.stdout


def test_unknown_fit_is_one_line_and_status_2():
    result = runner.invoke(app, ["materials", "--fit", "ngan_he"])
    assert result.exit_code == 2
    assert "--fit" in result.stderr and "ngan_he" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def test_gallery_draws_one_lit_sphere_per_preset(tmp_path):
    """``--gallery`` writes one page with a sphere per preset kept, each captioned and tooltipped
    with its spec; the spheres are lit (not black) and differ between materials."""
    import base64
    import io
    import re

    import numpy as np
    from PIL import Image

    out = tmp_path / "gallery.html"
    result = runner.invoke(app, ["materials", "--fit", "ngan_ward", "--gallery", str(out)])
    assert result.exit_code == 0, result.output
    page = out.read_text(encoding="utf-8")
    records = catalogue(fit="ngan_ward")
    assert page.count("<figure") == len(records) == 86
    assert all(f"<figcaption>{r['name']}</figcaption>" in page for r in records)
    images = [
        np.asarray(Image.open(io.BytesIO(base64.b64decode(b))))
        for b in re.findall(r'base64,([^"]+)"', page)
    ]
    means = np.array([image.reshape(-1, image.shape[-1])[:, :3].mean(axis=0) for image in images])
    assert len(images) == 86 and all(image.shape[:2] == (32, 32) for image in images)
    assert (means.sum(axis=1) > 0).all()
    assert np.unique(means.round(1), axis=0).shape[0] > 80  # the materials look different


def test_gallery_refuses_a_wrong_suffix_and_writes_nothing(tmp_path):
    out = tmp_path / "gallery.png"
    result = runner.invoke(app, ["materials", "--gallery", str(out)])
    assert result.exit_code == 2
    assert "--gallery" in result.stderr and len(result.stderr.strip().splitlines()) == 1
    assert not out.exists()
