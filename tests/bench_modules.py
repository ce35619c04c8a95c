"""The benchmarks' own generators and runners, loaded as modules for the tests that check the same cases."""
from __future__ import annotations

import importlib.util
from functools import cache
from pathlib import Path
from types import ModuleType

import numpy as np

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


@cache
def bench_module(name: str) -> ModuleType:
    """``benchmarks/<name>.py`` as a module (loaded once)."""
    spec = importlib.util.spec_from_file_location(name, BENCHMARKS / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def speed_scan(n_faces: int) -> tuple[np.ndarray, np.ndarray]:
    """``(V, F)``: the speed benchmark's jittered-grid height field (``benchmarks/bench_fit_speed.py``)."""
    return bench_module("bench_fit_speed").make_scan(n_faces)
