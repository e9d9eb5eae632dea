"""Every command that takes a model takes a BRDF Explorer file (through ``brdfkit.load``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from brdfkit.cli import app
from brdfkit.io import read_image

runner = CliRunner()
CONSTRUCTS = Path(__file__).parent / "data" / "constructs.brdf"


@pytest.fixture(scope="module")
def lambert(shared_data):
    path = shared_data / "brdf_explorer" / "lambert.brdf"
    if not path.is_file():
        pytest.skip(f"{path} is absent")
    return path


def test_check_a_brdf_explorer_file(lambert):
    result = runner.invoke(app, ["check", str(lambert), "--json"])
    assert result.exit_code == 0, result.output
    assert '"consistent": true' in result.stdout


def test_render_a_brdf_explorer_file_matches_the_closed_form(lambert, tmp_path):
    out = tmp_path / "s.exr"
    light = "directional:1,0,0:3.14159265358979"
    result = runner.invoke(app, ["render", "sphere", "-b", str(lambert), "-l", light, "-r", "16",
                                 "-o", str(out)])  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "lambert.brdf" in result.stdout
    from brdfkit.render import Sphere, gbuffer

    g = gbuffer(Sphere(), None, 16)
    expected = np.clip(g.normals[..., 0], 0, None) * g.mask * (np.pi / 3.14159265)
    np.testing.assert_allclose(read_image(out)[..., 0], expected, atol=1e-5)


def test_a_shader_the_subset_refuses_is_one_line_naming_file_line_and_construct(tmp_path):
    bad = tmp_path / "bad.brdf"
    bad.write_text(
        CONSTRUCTS.read_text().replace("    return tint / PI;", "    mat3 m;\n    return tint;")
    )
    result = runner.invoke(app, ["render", "sphere", "-b", str(bad), "-o", str(tmp_path / "x.png")])
    assert result.exit_code == 2
    line = CONSTRUCTS.read_text().splitlines().index("    return tint / PI;") + 1
    assert f"bad.brdf (line {line}): GLSL: unsupported type 'mat3'" in " ".join(
        result.output.split()
    )
    assert not (tmp_path / "x.png").exists()
