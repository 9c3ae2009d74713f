"""The sky through Python, against its closed form: an open plane of reflectance rho under a
uniform sky of radiance L sees the whole upper hemisphere, so its irradiance is pi L and its
radiosity rho pi L (it shows the radiance rho L), on every patch, in each solver. The sky comes
from ``load_dict``'s ``environment`` or from ``Engine.set_sky``; removing it leaves the plane
black."""

import math

import numpy as np
import pytest

import shrad

RHO = np.array([0.5, 0.3, 0.8], np.float32)


def open_plane(environment=None, patches=400):
    """A 4 m square facing up (+Y), alone: nothing but the sky lights it or is seen from it."""
    d = {
        "name": "open-plane",
        "settings": {"patches": patches},
        "objects": [
            {
                "name": "ground",
                "shape": "quad",
                "role": "boundary",
                "corners": [[-2, 0, -2], [-2, 0, 2], [2, 0, 2], [2, 0, -2]],
                "reflectance": RHO.tolist(),
            }
        ],
    }
    if environment is not None:
        d["environment"] = environment
    return shrad.load_dict(d)


def converged(engine):
    engine.converge(2)
    return engine.radiosity


@pytest.mark.parametrize("solver,preset", [("reference", "fast"), ("dispersive", "default")])
def test_a_uniform_sky_gives_an_open_plane_pi_l_and_rho_pi_l(solver, preset):
    L = np.array([0.4, 0.7, 1.3], np.float32)
    e = shrad.Engine(open_plane({"radiance": L.tolist()}), solver=solver, preset=preset)
    B = converged(e)
    want = RHO * math.pi * L
    # Cosine sampling of a uniform sky: every unoccluded sample is exactly pi L.
    np.testing.assert_allclose(B, np.broadcast_to(want, B.shape), rtol=1e-4)
    # The radiance the plane shows: rho L.
    np.testing.assert_allclose(B / math.pi, np.broadcast_to(RHO * L, B.shape), rtol=1e-4)


def test_set_sky_changes_and_removes_the_sky():
    e = shrad.Engine(open_plane(), solver="reference", preset="fast")
    assert np.all(converged(e) == 0), "no sky, no light"
    L = np.array([2.0, 1.0, 0.5], np.float32)
    e.set_sky(radiance=L.tolist())
    B = converged(e)
    np.testing.assert_allclose(B, np.broadcast_to(RHO * math.pi * L, B.shape), rtol=1e-4)
    e.set_sky(radiance=(0.5 * L).tolist())
    np.testing.assert_allclose(converged(e), 0.5 * B, rtol=1e-4)
    e.set_sky()
    assert np.all(converged(e) == 0), "the sky removed, the plane is black again"


def test_a_bad_sky_is_an_error_that_says_why():
    with pytest.raises(Exception, match="radiance"):
        open_plane({"radiance": [-1, 0, 0]})
    e = shrad.Engine(open_plane(), solver="reference", preset="fast")
    with pytest.raises(Exception, match="radiance"):
        e.set_sky(radiance=[math.nan, 0, 0])
