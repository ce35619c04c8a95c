"""The wheel holds every source module under the trispline namespace, and the
layers import one way only (spline <- param <- fit)."""
from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = {"spline": "trispline/spline", "param": "trispline/param", "fit": "trispline/fit"}


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("wheel")
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w", str(out), str(ROOT)],
        check=True, capture_output=True, text=True,
    )
    (whl,) = out.glob("trispline-*.whl")
    return whl


def test_wheel_holds_every_source_module(wheel):
    """Every ``.py`` file of every sub-package (``spline/util/gather.py`` ...) is in the wheel:
    a sub-package missing from ``pyproject.toml``'s package list would be left out."""
    names = set(zipfile.ZipFile(wheel).namelist())
    for folder, target in PACKAGES.items():
        sources = sorted(p.relative_to(ROOT / folder).as_posix() for p in (ROOT / folder).rglob("*.py"))
        assert f"{folder}/__init__.py" in [f"{folder}/{s}" for s in sources], folder
        missing = [f"{folder}/{name}" for name in sources if f"{target}/{name}" not in names]
        assert not missing, f"missing from the wheel: {missing}"


def test_wheel_has_no_bare_top_level_packages(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    tops = {n.split("/")[0] for n in names}
    assert not tops & {"spline", "param", "fit"}, tops
    assert "trispline" in tops
    assert not any(n == "trispline/__init__.py" for n in names), "trispline must stay a namespace package"


def _loaded_after(stmt: str) -> set[str]:
    code = f"import sys; {stmt}; print(' '.join(sorted(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True, cwd="/")
    return set(out.stdout.split())


def test_spline_core_imports_no_heavy_layers():
    mods = _loaded_after("import trispline.spline, trispline.spline.propagation, trispline.spline.surface")
    for banned in ("igl", "trimesh", "optimistix", "jax", "trispline.param", "trispline.fit"):
        assert banned not in mods, banned


def test_param_does_not_import_fit_or_jax():
    mods = _loaded_after("import trispline.param")
    for banned in ("trimesh", "optimistix", "jax", "trispline.fit"):
        assert banned not in mods, banned
