"""Shared test set-up: hypothesis profiles, float64 JAX, the tests folder on ``sys.path``.

Profiles (``HYPOTHESIS_PROFILE``): ``ci`` (the default) is derandomised with no deadline, so
a run passes or fails the same way every time; ``dev`` explores new random examples.
"""
from __future__ import annotations

import os

import jax
from hypothesis import HealthCheck, settings

jax.config.update("jax_enable_x64", True)  # as the CLI does: fits need float64 (X64Error otherwise)

settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("dev", deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))
