"""MaterialX and USD export: the MaterialX document validates against the standard node
libraries (and a wrong input type does not), the USD stage opens with usd-core and its
UsdPreviewSurface holds the values."""

from __future__ import annotations

import numpy as np
import pytest

from brdfkit.brdf import GGXConductor, Lambertian, Principled, RoughConductor, SmoothDielectric
from brdfkit.interop import export
from brdfkit.interop.pbr import pbr_material

FIT = Lambertian([0.5, 0.2, 0.1]) + 0.02 * GGXConductor(alpha=0.09)
PRINCIPLED = Principled(base_color=[0.2, 0.4, 0.8], roughness=0.3, clearcoat=0.7, sheen=0.4)


@pytest.fixture(scope="module")
def mx():
    return pytest.importorskip("MaterialX")


@pytest.fixture(scope="module")
def stdlib(mx):
    from brdfkit.interop.materialx import standard_libraries

    return standard_libraries()


def _validated(mx, document, stdlib) -> tuple[bool, str]:
    check = mx.createDocument()
    check.copyContentFrom(document)
    check.importLibrary(stdlib)
    return check.validate()


@pytest.mark.parametrize(
    "brdf", [FIT, PRINCIPLED, SmoothDielectric(eta=1.33)], ids=["fit", "principled", "glass"]
)
def test_materialx_document_validates_with_the_standard_libraries(mx, stdlib, tmp_path, brdf):
    path = export(brdf, "mtlx", tmp_path / "material.mtlx").path
    document = mx.createDocument()
    mx.readFromXmlFile(document, str(path))
    valid, message = _validated(mx, document, stdlib)
    assert valid, message
    shader = document.getNode("brdfkit_surface")
    assert shader.getCategory() == "open_pbr_surface"
    assert document.getNode("brdfkit").getType() == "material"
    np.testing.assert_allclose(
        list(shader.getInputValue("base_color")), np.broadcast_to(pbr_material(brdf).base_color, 3)
    )


def test_a_wrong_input_type_fails_validation_only_with_the_libraries(mx, stdlib, tmp_path):
    path = export(FIT, "mtlx", tmp_path / "material.mtlx").path
    document = mx.createDocument()
    mx.readFromXmlFile(document, str(path))
    base = document.getNode("brdfkit_surface").getInput("base_color")
    base.setType("float")
    base.setValueString("0.5")
    assert document.validate()[0]  # without the node definitions nothing says it is wrong
    valid, message = _validated(mx, document, stdlib)
    assert not valid and "base_color" in message


def test_fit_f0_survives_the_conversion(mx):
    from brdfkit.interop.materialx import materialx_document

    document = materialx_document(FIT)  # held: nodes die with their document
    shader = document.getNode("brdfkit_surface")
    eta = shader.getInputValue("specular_ior")
    assert ((eta - 1) / (eta + 1)) ** 2 == pytest.approx(0.02, rel=1e-4)  # F = 1 scaled by 0.02
    assert shader.getInputValue("specular_roughness") == pytest.approx(0.3, rel=1e-5)


@pytest.mark.parametrize("suffix", [".usda", ".usdc"])
def test_usd_stage_opens_and_holds_the_values(tmp_path, suffix):
    pxr = pytest.importorskip("pxr")
    from pxr import Usd, UsdGeom, UsdShade

    path = export(PRINCIPLED, "usd", tmp_path / f"ball{suffix}").path
    stage = Usd.Stage.Open(str(path))
    assert stage is not None and pxr
    sphere = stage.GetPrimAtPath("/brdfkit/Sphere")
    assert UsdGeom.Sphere(sphere).GetRadiusAttr().Get() == 1.0
    material, _ = UsdShade.MaterialBindingAPI(sphere).ComputeBoundMaterial()
    shader = UsdShade.Shader(stage.GetPrimAtPath("/brdfkit/Material/PreviewSurface"))
    assert material.GetPath() == "/brdfkit/Material"
    assert shader.GetIdAttr().Get() == "UsdPreviewSurface"
    np.testing.assert_allclose(shader.GetInput("diffuseColor").Get(), [0.2, 0.4, 0.8], rtol=1e-6)
    assert shader.GetInput("roughness").Get() == pytest.approx(0.3)
    assert shader.GetInput("clearcoat").Get() == pytest.approx(0.7)
    assert shader.GetInput("useSpecularWorkflow").Get() == 1
    np.testing.assert_allclose(shader.GetInput("specularColor").Get(), [0.04] * 3, rtol=1e-5)


def test_usd_metal_uses_the_metallic_workflow(tmp_path):
    pytest.importorskip("pxr")
    from pxr import Usd, UsdShade

    gold = RoughConductor(alpha=0.25, material="Au")
    path = export(gold, "usd", tmp_path / "gold.usda").path
    stage = Usd.Stage.Open(str(path))  # held: prims die with their stage
    shader = UsdShade.Shader(stage.GetPrimAtPath("/brdfkit/Material/PreviewSurface"))
    assert shader.GetInput("metallic").Get() == 1.0 and not shader.GetInput("useSpecularWorkflow")
    np.testing.assert_allclose(
        shader.GetInput("diffuseColor").Get(), pbr_material(gold).base_color, rtol=1e-6
    )
