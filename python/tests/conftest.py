"""Shared helpers of the tetfem Python tests: paths of the repository's scenes and the
probe mean computed in plain Python, in the scene runner's order."""

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SCENES = REPO / "scenes"


def probe_mean(displacement, nodes):
    """Mean displacement of ``nodes`` as tetfem's scene probes form it: a running sum from
    zero in ascending node order, then one division per component (plain Python floats, so
    the bits match Rust's f64 arithmetic in that order)."""
    total = [0.0, 0.0, 0.0]
    for n in nodes:
        for axis in range(3):
            total[axis] += float(displacement[n, axis])
    return [t / len(nodes) for t in total]


@pytest.fixture
def scenes():
    return SCENES
