"""The smooth-rotations energy (SR-ARAP) through the Python Deformer: it is a different energy
from plain ARAP, its bending length is checked with the solver's one message, reported in world
units, and recorded in an exported glTF."""
import json

import numpy as np
import pytest

import bsarap
from bsarap import BsarapError
from conftest import tube

# The top ring turned 50 degrees about x and pushed sideways: a bend along the tube.
POSE = {1: ((0.0, 1.0, -0.5), bsarap.rotation((1, 0, 0), 50.0))}


def pose(**settings):
    V, F, labels = tube(nu=16, nv=14)
    d = bsarap.Deformer(V, F, labels, method="arap", tol=1e-7, max_iters=2000, **settings)
    return V, d, d.solve(POSE)


def test_smooth_rotations_differ_from_plain_arap():
    V, plain, U_plain = pose(energy="spokes")
    _, sr, U_sr = pose(energy="smooth-rotations", bending_length=0.1)
    diagonal = np.linalg.norm(V.max(axis=0) - V.min(axis=0))
    assert sr.energy == "smooth-rotations" and plain.energy == "spokes"
    assert sr.bending_length == 0.1
    assert sr.bending_length_world == pytest.approx(0.1 * diagonal, rel=1e-12)
    assert np.isfinite(U_sr).all()
    # Same handles on target, a different pose in between.
    hv = sr.handle_vertices
    np.testing.assert_allclose(U_sr[hv], U_plain[hv], atol=1e-12)
    gap = np.linalg.norm(U_sr - U_plain, axis=1).max() / diagonal
    assert gap > 1e-3, f"smooth rotations moved the pose by only {gap:.2e} of the diagonal"
    # A longer bending length is a different minimum again.
    _, _, U_long = pose(energy="smooth-rotations", bending_length=0.3)
    assert np.linalg.norm(U_long - U_sr, axis=1).max() / diagonal > 1e-4
    # The default bending length is the solver's.
    _, d, _ = pose(energy="smooth-rotations")
    assert d.bending_length == bsarap.DEFAULT_BENDING_LENGTH


@pytest.mark.parametrize(
    "value, message",
    [
        (0.0, r"bending_length must be in \(0, 1\] .*got 0\)"),
        (-0.02, r"bending_length must be in \(0, 1\] .*got -0.02\)"),
        (float("nan"), r"bending_length must be in \(0, 1\] .*got NaN\)"),
        (float("inf"), r"bending_length must be in \(0, 1\] .*got inf\)"),
        (2.0, r"bending_length must be in \(0, 1\] .*got 2\)"),
        ("long", r"bending_length must be a number"),
    ],
)
def test_bad_bending_length_is_refused_clearly(value, message):
    V, F, labels = tube()
    with pytest.raises(BsarapError, match=message):
        bsarap.Deformer(V, F, labels, energy="smooth-rotations", bending_length=value)


def test_energy_names_and_the_libigl_shaped_arap():
    V, F, labels = tube()
    assert "smooth-rotations" in bsarap.ENERGIES
    with pytest.raises(BsarapError, match=r"energy must be one of .*smooth-rotations"):
        bsarap.Deformer(V, F, labels, energy="smooth")
    # libigl's ARAP has no rotation-smoothness term: the drop-in says where it is.
    with pytest.raises(BsarapError, match=r"Deformer\(.*energy=\"smooth-rotations\"\)"):
        bsarap.Arap(V, F, np.nonzero(labels >= 0)[0], energy="smooth-rotations")


def test_export_records_energy_and_bending_length(tmp_path):
    V, F, labels = tube()
    d = bsarap.Deformer(V, F, labels, method="arap", energy="smooth-rotations",
                        bending_length=0.05, max_iters=50)
    tl = bsarap.Timeline.from_json(json.dumps({
        "duration": 1.0, "fps": 2, "paths": [{"group": 1, "path": {
            "type": "circular", "axis": [0, 0, 1], "reference": [1, 0, 0], "radius": 0.2,
            "period": 1.0, "phase": 0.0, "turn_with_path": False}}]}))
    rec = bsarap.record(d, tl)
    out = tmp_path / "sr.gltf"
    bsarap.export_gltf(out, rec, quantized=False)
    settings = json.loads(out.read_text())["asset"]["extras"]["bsarap"]
    assert settings["method"] == "arap" and settings["energy"] == "smooth-rotations"
    assert settings["bending_length"] == 0.05
    assert settings["bending_length_world"] == pytest.approx(d.bending_length_world, rel=1e-12)
