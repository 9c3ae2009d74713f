"""Probes for dynamic objects (issue 19, item 2): the dispersive solver's corner probes as
numpy arrays, in three.js's LightProbe coefficient order."""

import json

import numpy as np
import pytest

import shrad


def three_js_irradiance(sh, n):
    """three.js's shader shGetIrradianceAt (lights_pars_begin), constants as written there."""
    x, y, z = n
    return (sh[0] * 0.886227 + sh[1] * 2.0 * 0.511664 * y + sh[2] * 2.0 * 0.511664 * z
            + sh[3] * 2.0 * 0.511664 * x + sh[4] * 2.0 * 0.429043 * x * y
            + sh[5] * 2.0 * 0.429043 * y * z + sh[6] * (0.743125 * z * z - 0.247708)
            + sh[7] * 2.0 * 0.429043 * x * z + sh[8] * 0.429043 * (x * x - y * y))


def plain_sh_sum(c, n):
    """sum_k c_k Y_k(n) over the real orthonormal basis of 3 bands (1, y, z, x, xy, ...)."""
    x, y, z = n
    basis = [0.282095, 0.488603 * y, 0.488603 * z, 0.488603 * x, 1.092548 * x * y,
             1.092548 * y * z, 0.315392 * (3 * z * z - 1), 1.092548 * x * z,
             0.546274 * (x * x - y * y)]
    return sum(b * c[k] for k, b in enumerate(basis))


def test_probes_are_arrays_in_three_js_order(cornell):
    e = shrad.Engine(cornell, solver="dispersive", preset="default")
    e.converge(2)
    p = e.probes()
    n = len(p["positions"])
    assert n == 16 and p["bands"] == 3
    assert p["positions"].shape == (n, 3) and p["positions"].dtype == np.float32
    assert p["sh"].shape == (n, 9, 3) and p["irradiance_sh"].shape == (n, 9, 3)
    assert sorted(set(p["corners"].tolist())) == list(range(8))
    assert set(p["states"]) <= {"valid", "repaired", "invalid"}
    # Both sets of coefficients give one irradiance: three.js's shader on `sh`, a plain SH
    # sum on `irradiance_sh` (1 % of the brightest direction: the constants' 6 digits).
    dirs = [np.array(d, dtype=np.float64) / np.linalg.norm(d)
            for d in [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1),
                      (1, 1, 1), (-1, 1, -1)]]
    lit = 0
    for k in range(n):
        a = np.array([three_js_irradiance(p["sh"][k].astype(np.float64), d) for d in dirs])
        b = np.array([plain_sh_sum(p["irradiance_sh"][k].astype(np.float64), d) for d in dirs])
        scale = np.abs(a).max()
        if scale > 0:
            lit += 1
            assert np.abs(a - b).max() <= 0.01 * scale, (k, a, b)
    assert lit >= 8


def test_export_probes_writes_what_probes_returns(cornell, tmp_path):
    # The JSON `shrad bake --probes corners` writes, from Python: the same probes, in the
    # same order, as the arrays.
    e = shrad.Engine(cornell, solver="dispersive", preset="default")
    e.converge(1)
    p = e.probes()
    written = e.export_probes(tmp_path / "box.probes.json")
    assert written["probes"] == len(p["positions"]) == 16
    assert written["path"] == str(tmp_path / "box.probes.json")
    doc = json.loads((tmp_path / "box.probes.json").read_text())
    assert doc["format"] == "shrad-probes" and doc["version"] == 1
    probes = doc["probes"]
    assert [q["corner"] for q in probes] == p["corners"].tolist()
    assert [q["object_index"] for q in probes] == p["objects"].tolist()
    np.testing.assert_allclose([q["position"] for q in probes], p["positions"], rtol=1e-6)
    np.testing.assert_allclose([q["coefficients"] for q in probes], p["sh"], rtol=1e-5, atol=1e-9)
    np.testing.assert_allclose(
        [q["irradiance_coefficients"] for q in probes], p["irradiance_sh"], rtol=1e-5, atol=1e-9
    )
    with pytest.raises(OSError, match="does not exist"):
        e.export_probes(tmp_path / "no" / "p.json")


def test_a_solver_without_probes_says_so(cornell, tmp_path):
    e = shrad.Engine(cornell, solver="grid")
    with pytest.raises(ValueError, match="no per-object probes"):
        e.probes()
    with pytest.raises(ValueError, match="export_probes: the grid solver has no per-object probes"):
        e.export_probes(tmp_path / "p.json")
    assert not list(tmp_path.iterdir())
