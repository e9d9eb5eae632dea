"""The package's index of its models (brdfkit.brdf._index) matches the modules, and a name
asked for imports its module alone."""

from __future__ import annotations

import importlib
import json
import pkgutil
import subprocess
import sys
import textwrap

import pytest

import brdfkit.brdf
from brdfkit.brdf import MODELS, _index
from brdfkit.brdf.base import BRDF, Registry


def _model_modules() -> list[str]:
    return sorted(
        m.name
        for m in pkgutil.iter_modules(brdfkit.brdf.__path__)
        if not m.name.startswith("_") and m.name not in ("base", "spec")
    )


def test_the_index_lists_every_module_and_its_exports():
    assert sorted(_index.MODULES) == _model_modules()
    for name, exported in _index.MODULES.items():
        module = importlib.import_module(f"brdfkit.brdf.{name}")
        assert exported == tuple(module.__all__), name


def test_the_index_names_the_module_of_every_registered_model():
    registered = {name: cls.__module__.rpartition(".")[2] for name, cls in MODELS.items()}
    assert registered == _index.SPEC_NAMES


def test_every_exported_name_is_the_modules_own():
    for module, names in _index.MODULES.items():
        for name in names:
            assert getattr(brdfkit.brdf, name) is getattr(
                importlib.import_module(f"brdfkit.brdf.{module}"), name
            )
    assert set(brdfkit.brdf.__all__) <= set(dir(brdfkit.brdf))
    with pytest.raises(AttributeError, match="no attribute 'NotAModel'"):
        brdfkit.brdf.NotAModel  # noqa: B018


def test_a_spec_imports_its_models_module_alone():
    code = textwrap.dedent(
        """
        import json, sys
        from brdfkit.brdf import parse, MODELS
        parse("ggx(alpha=0.3)")
        loaded = sorted(m for m in sys.modules if m.startswith("brdfkit.brdf."))
        count = len(MODELS)
        print(json.dumps([loaded, count]))
        """
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    loaded, count = json.loads(done.stdout)
    assert "brdfkit.brdf.rough_conductor" in loaded
    assert "brdfkit.brdf.hapke" not in loaded and "brdfkit.brdf.principled" not in loaded
    assert count == len(_index.SPEC_NAMES)


def test_the_registry_refuses_a_name_twice_and_takes_new_models():
    registry = Registry()

    class One(BRDF):
        pass

    class Other(BRDF):
        pass

    registry.add("one", One)
    registry.add("one", One)  # the same class again: a module imported twice
    with pytest.raises(ValueError, match="'one' is registered twice"):
        registry.add("one", Other)
    assert registry["one"] is One and "other" not in registry
