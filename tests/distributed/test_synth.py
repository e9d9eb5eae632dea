"""``brdfkit synth`` writes DiLiGenT sets that ``brdfkit ps`` reads back and solves."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

pytest.importorskip("distributed", reason="needs the dask extra: pip install 'brdfkit[dask]'")

from brdfkit.brdf import parse
from brdfkit.cli import app
from brdfkit.distributed.synth import shape_normals
from brdfkit.measured.merl import write_merl
from brdfkit.vision.datasets import diligent_like_lights, load_diligent
from brdfkit.vision.synthesis import render_brdf

runner = CliRunner()


@pytest.mark.slow
def test_synth_sets_read_back_by_ps_lambertian_below_half_a_degree(tmp_path):
    measured = tmp_path / "grey.binary"
    write_merl(measured, parse("lambertian(rho=0.5)"))
    specular = "lambertian(rho=[0.5, 0.3, 0.2]) + ggx(alpha=0.3)"
    out = tmp_path / "sets"
    args = ["synth", "-s", "sphere:48", "-b", "lambertian(rho=0.6)", "-b", specular,
            "-b", str(measured), "-l", "grid:5x4:40", "--all-lit", "--workers", "1"]  # fmt: skip
    made = runner.invoke(app, [*args, "-o", str(out), "--json"])
    assert made.exit_code == 0, made.output
    sets = {r["brdf"]: out / r["folder"] for r in json.loads(made.stdout)["sets"]}
    assert len(sets) == 3 and all(r["images"] == 20 for r in json.loads(made.stdout)["sets"])
    for brdf in ("lambertian(rho=0.6)", str(measured)):  # analytic and measured Lambertian
        solved = runner.invoke(
            app,
            ["ps", str(sets[brdf]), "-m", "least_squares", "-o", str(tmp_path / "ps"), "--json"],
        )
        assert solved.exit_code == 0, solved.output
        errors = json.loads(solved.stdout)["angular_error_deg"]
        assert errors["mean"] < 0.5, (brdf, errors)
    # What the loader returns is the radiance f_r cos θ_i, to the 16-bit quantisation.
    data = load_diligent(sets[specular])
    normals, mask = shape_normals("sphere:48")
    lights = diligent_like_lights(5, 4, np.radians(40))
    mask &= np.all(normals @ lights.T > 0, axis=-1)
    radiance = render_brdf(normals, mask, lights, parse(specular))
    step = data.light_intensities[0, 0] ** -1 / 65535
    assert np.abs(data.images - radiance).max() <= 0.51 * step
    assert np.array_equal(data.mask, mask) and np.allclose(data.normals, normals * mask[..., None])
