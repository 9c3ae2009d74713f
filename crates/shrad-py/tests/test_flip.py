"""Per-pixel error of the dispersive default against the reference on the same patches
(issue 22): NVIDIA's HDR-FLIP (`flip-evaluator` on PyPI), its mean and its 99th percentile,
on the built-in Cornell box. A block-averaged error hides blotches and mottling that a
person sees first; FLIP's 99th percentile does not. The check can fail: the dispersive
solver without its wall-to-wall light is outside both bounds."""

import flip_evaluator as flip  # pinned in requirements.txt: the suite runs this, never skips it
import numpy as np
import pytest

import shrad

SIZE = 128
SPP = 16
PATCHES = 5000
PASSES = 8

# Bounds with margin over what was measured when the test was written (2026-12, dispersive
# default against the reference, Cornell 5000 patches, 128 x 128, 16 spp, smooth shading):
# mean 0.091, 99th percentile 0.397 (without the wall exchange: 0.508 and 0.970).
# Since issue 22's near field (64 rays a patch on the interior objects, whose error it
# lowers 3.7 -> 2.8 %): mean 0.096, 99th percentile 0.471, its per-pixel noise on the blocks.
FLIP_MEAN_BOUND = 0.11
FLIP_P99_BOUND = 0.50


def picture(solver, **settings):
    e = shrad.Engine(shrad.load("cornell", patches=PATCHES), solver=solver, **settings)
    e.converge(PASSES)
    img = np.asarray(e.render(SIZE, SIZE, spp=SPP), np.float32)
    return np.ascontiguousarray(np.maximum(img, 0.0))


def hdr_flip(reference, test):
    """(mean, 99th percentile) of the HDR-FLIP error map."""
    error_map, mean, _ = flip.evaluate(reference, test, "HDR", applyMagma=False)
    return float(mean), float(np.percentile(np.asarray(error_map), 99))


@pytest.fixture(scope="module")
def reference_picture():
    return picture("reference")


def test_dispersive_flip_against_the_reference(reference_picture):
    mean, p99 = hdr_flip(reference_picture, picture("dispersive"))
    print(f"dispersive vs reference: HDR-FLIP mean {mean:.4f}, 99th percentile {p99:.4f}")
    assert mean < FLIP_MEAN_BOUND, mean
    assert p99 < FLIP_P99_BOUND, p99


def test_flip_sees_missing_wall_light(reference_picture):
    mean, p99 = hdr_flip(reference_picture, picture("dispersive", wall_exchange=False))
    print(f"without the wall exchange: HDR-FLIP mean {mean:.4f}, 99th percentile {p99:.4f}")
    assert mean > FLIP_MEAN_BOUND and p99 > FLIP_P99_BOUND, (mean, p99)
