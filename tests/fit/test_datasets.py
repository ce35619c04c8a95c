"""The generated example scan is a clean partial scan at every size the CLI offers.

A scanner's noise stays below its sampling, so the built-in example must not fold over however
dense it is asked to be (``fit --example --example-faces N`` would otherwise warn about folds the
user cannot repair), while its coarse sizes stay exactly what the examples and pictures show.
"""
from __future__ import annotations

import numpy as np
import pytest

from trispline.fit.datasets.synthetic import NOISE, NOISE_PER_SPACING, scan_height, synthetic_scan
from trispline.param.validate import folded_edges


@pytest.mark.parametrize("n_faces", [800, 20_000, 100_000])
def test_the_example_scan_never_folds(n_faces):
    V, F = synthetic_scan(n_faces)
    edges, _ = folded_edges(V, F)
    assert len(edges) == 0


def test_an_explicit_noise_is_used_as_given():
    clean, F = synthetic_scan(20_000, noise=0.0, rotate=False)
    noisy, _ = synthetic_scan(20_000, noise=NOISE, rotate=False)
    assert np.std(noisy[:, 2] - clean[:, 2]) == pytest.approx(NOISE, rel=0.05)
    assert len(folded_edges(noisy, F)[0]) > 0  # an absolute noise of 22% of the spacing folds


@pytest.mark.parametrize("n_faces", [800, 20_000])
def test_the_default_noise_is_at_most_a_tenth_of_the_spacing(n_faces):
    V, F = synthetic_scan(n_faces, rotate=False)
    edge = np.linalg.norm(V[F[:, 0], :2] - V[F[:, 1], :2], axis=1)
    z_noise = np.std(V[:, 2] - scan_height(V[:, :2]))
    assert z_noise <= min(NOISE, NOISE_PER_SPACING * np.median(edge)) * 1.1
    if n_faces == 800:  # coarse examples keep the absolute noise, unchanged since the first release
        assert z_noise == pytest.approx(NOISE, rel=0.1)
