"""glTF 2.0 export: the Khronos validator finds no error, and the material holds the conversion."""

from __future__ import annotations

import json
import shutil
import subprocess

import numpy as np
import pytest

from brdfkit.brdf import GGXConductor, Lambertian, Phong, Principled, RoughConductor
from brdfkit.errors import ParameterError
from brdfkit.interop import export
from brdfkit.interop.gltf import gltf_document, uv_sphere

pytest.importorskip("pygltflib")

VALIDATE = """
const fs = require("fs");
const validator = require("gltf-validator");
Promise.all(process.argv.slice(1).map((path) =>
  validator.validateBytes(new Uint8Array(fs.readFileSync(path))).then((r) => r.issues)))
  .then((issues) => console.log(JSON.stringify(issues)))
  .catch((error) => { console.error(String(error)); process.exit(3); });
"""

MODELS = {
    "principled": Principled(
        base_color=[0.8, 0.2, 0.1], clearcoat=1.0, clearcoat_gloss=0.5, sheen=0.5,
        sheen_tint=1.0, specular_tint=0.5, specular=0.3,
    ),
    "fit": Lambertian([0.5, 0.2, 0.1]) + 0.5 * GGXConductor(alpha=0.1),
    "gold": RoughConductor(alpha=0.2, material="Au"),
}  # fmt: skip


def _validator_issues(paths) -> list[dict]:
    node, npm = shutil.which("node"), shutil.which("npm")
    if node is None or npm is None:
        pytest.skip("node and npm are needed for the Khronos glTF validator")
    root = subprocess.run([npm, "root", "-g"], capture_output=True, text=True).stdout.strip()
    env = {"NODE_PATH": root, "PATH": ""}
    run = subprocess.run(
        [node, "-e", VALIDATE, *map(str, paths)], capture_output=True, text=True, env=env
    )
    if "Cannot find module 'gltf-validator'" in run.stderr:
        pytest.skip("gltf-validator is not installed (npm install -g gltf-validator)")
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout)


def test_khronos_validator_finds_no_error(tmp_path):
    paths = [
        export(brdf, "gltf", tmp_path / f"{name}{suffix}").path
        for name, brdf in MODELS.items()
        for suffix in (".glb", ".gltf")
    ]
    for path, issues in zip(paths, _validator_issues(paths), strict=True):
        assert issues["numErrors"] == 0, (path.name, issues["messages"])
        assert issues["numWarnings"] == 0, (path.name, issues["messages"])


def test_principled_conversion():
    document = gltf_document(MODELS["principled"])
    material = document.materials[0]
    assert material.pbrMetallicRoughness.baseColorFactor == [0.8, 0.2, 0.1, 1.0]
    assert material.pbrMetallicRoughness.roughnessFactor == 0.5
    ext = material.extensions
    f0 = ((ext["KHR_materials_ior"]["ior"] - 1) / (ext["KHR_materials_ior"]["ior"] + 1)) ** 2
    assert f0 == pytest.approx(0.08 * 0.3)  # Burley's specular
    assert ext["KHR_materials_clearcoat"] == {
        "clearcoatFactor": 1.0, "clearcoatRoughnessFactor": pytest.approx(np.sqrt(0.0505))
    }  # fmt: skip
    sheen = ext["KHR_materials_sheen"]["sheenColorFactor"]
    assert sheen[0] > sheen[1] > sheen[2]  # tinted as the base colour
    assert set(document.extensionsUsed) == set(ext)


def test_metal_and_fit_conversions():
    gold = gltf_document(MODELS["gold"]).materials[0]
    assert gold.pbrMetallicRoughness.metallicFactor == 1.0
    np.testing.assert_allclose(gold.pbrMetallicRoughness.roughnessFactor, np.sqrt(0.2))
    assert (
        gold.pbrMetallicRoughness.baseColorFactor[0] > gold.pbrMetallicRoughness.baseColorFactor[2]
    )
    fit = gltf_document(MODELS["fit"]).materials[0]
    assert fit.pbrMetallicRoughness.metallicFactor == 0.0
    # F = 1 scaled by 0.5: F0 = 0.5 = 0.04 × specularColorFactor
    assert fit.extensions["KHR_materials_specular"]["specularColorFactor"] == [12.5] * 3


def test_sphere_is_closed_and_outward():
    sphere = uv_sphere(8, 16)
    p = sphere["positions"][sphere["indices"]]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    assert np.all(np.sum(normal * p.mean(axis=1), axis=-1) > 0)  # counter-clockwise outside
    np.testing.assert_allclose(np.linalg.norm(sphere["normals"], axis=-1), 1, rtol=1e-6)


def test_models_without_counterpart_are_refused(tmp_path):
    with pytest.raises(ParameterError, match="Phong has no glTF/MaterialX/USD counterpart"):
        export(Phong(), "gltf", tmp_path / "p.glb")
    assert not any(tmp_path.iterdir())
