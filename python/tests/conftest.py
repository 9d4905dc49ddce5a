"""Shared helpers of the tetfem Python tests: paths of the repository's scenes, the probe
mean computed in plain Python in the scene runner's order, and the optional packages' imports
(skipped without them, except under CI)."""

import importlib
import os
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


# CI (env CI=true, as .ci/run and hosted CI set it) installs scipy, meshio and scikit-fem on
# purpose: there a missing one, or a missing tetfem binary, fails its tests instead of
# skipping them, so that a broken install cannot pass CI with the cross-checks unrun.
IN_CI = os.environ.get("CI", "").lower() == "true"


def skip_outside_ci(reason):
    """``pytest.skip(reason)``, or under CI ``pytest.fail``: CI must run every test."""
    if IN_CI:
        pytest.fail(f"{reason} (CI=true: CI must run this test)")
    pytest.skip(reason)


def optional_import(module, reason):
    """``pytest.importorskip(module, reason=reason)`` outside CI; under CI a plain import, so
    that a missing optional package fails (with its ImportError) instead of skipping."""
    if IN_CI:
        return importlib.import_module(module)
    return pytest.importorskip(module, reason=reason)


@pytest.fixture
def scenes():
    return SCENES


def dense(matrix):
    """A tetfem matrix as a dense numpy array: from SciPy CSR, or from the
    (indptr, indices, data, shape) arrays handed out without SciPy."""
    import numpy as np

    if isinstance(matrix, tuple):
        indptr, indices, data, shape = matrix
        out = np.zeros(shape)
        for row in range(shape[0]):
            out[row, indices[indptr[row] : indptr[row + 1]]] = data[indptr[row] : indptr[row + 1]]
        return out
    return matrix.toarray()
