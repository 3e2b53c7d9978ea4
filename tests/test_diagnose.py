"""Missing-physics diagnosis: exactness of the extensions, gradients, verdicts on simulated
recordings, and the CLI end to end. Diagnoses are expensive: few recordings, 1500 samples."""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jadhesion.cli import main
from jadhesion.data.recording import save_recording
from jadhesion.data.simulator import simulate
from jadhesion.diagnose import diagnose
from jadhesion.diagnose import extensions as ext
from jadhesion.diagnose.signals import from_columns
from jadhesion.models.polach import polach_adhesion

N = 1500
RAW = ("time", "vehicle_speed", "wheel_speed", "traction_torque")
#: Clear magnitudes, the extended model's parameter that estimates them, and a relative tolerance.
#: (torque_offset, signal_delay and load_transfer are not reliably named on these profiles; see
#: benchmarks/diagnose_blind.py.)
CLEAR = {
    "rail_change": (0.2, "drop", 0.25),
    "wheel_radius_error": (-0.01, "delta_r", 0.2),
    "thermal_softening": (1.5, "softening", 0.5),
}


@pytest.fixture(scope="module")
def clean():
    return simulate("dry", 3, (), N)


def _raw(sim):
    return {k: sim.columns[k] for k in RAW}


def test_zero_extras_equal_base_exactly(clean):
    sig = from_columns(_raw(clean), clean.vehicle)
    theta = jnp.array([0.43, 0.9, 0.35, 0.36, 0.13])
    params = jnp.concatenate([theta, ext.NEUTRAL])
    base = polach_adhesion(theta, (sig.wheel_speed - sig.speed) / jnp.maximum(jnp.abs(sig.speed),
                                                                              0.01),
                           sig.wheel_speed - sig.speed, sig.k_eps)
    for name in ext.NAMES:
        target, pred = ext.predict(params, ext.active_mask([name]), sig)
        np.testing.assert_array_equal(np.asarray(pred), np.asarray(base), err_msg=name)
        np.testing.assert_array_equal(np.asarray(target), np.asarray(sig.adhesion), err_msg=name)


def test_gradients_finite(clean):
    sig = from_columns(_raw(clean), clean.vehicle)
    params = jnp.concatenate([jnp.array([0.43, 0.9, 0.35, 0.36, 0.13]), ext.NEUTRAL + 0.01])
    active = jnp.ones(ext.N_EXTRA, bool)
    args = (active, jnp.ones_like(sig.time), sig)
    g = jax.grad(lambda p: jnp.sum(ext.residual(p, args) ** 2))(params)
    assert np.all(np.isfinite(np.asarray(g)))
    assert np.all(np.asarray(g)[5:] != 0.0)


def test_clean_is_none(clean):
    result = diagnose(_raw(clean), clean.vehicle)
    assert result["verdict"] == "none", result["candidates"][:2]
    assert result["effects"] == []


@pytest.mark.parametrize("name", sorted(CLEAR))
def test_effect_named_and_recovered(name):
    magnitude, param, tol = CLEAR[name]
    sim = simulate("wet", 7, [(name, magnitude)], N)
    result = diagnose(_raw(sim), sim.vehicle)
    assert result["verdict"] == name, [(c["name"], c["gain"]) for c in result["candidates"][:3]]
    est = result["extended"]["params"][param]
    assert abs(est - magnitude) <= tol * abs(magnitude), (est, magnitude)
    assert result["extended"]["heldout_mae"] < result["base"]["heldout_mae"]


def test_cli_json_and_report(tmp_path, capsys):
    sim = simulate("sand", 5, [("torque_offset", 0.03)], N)
    path = save_recording(_raw(sim), sim.vehicle, tmp_path / "rec.csv")
    assert main(["diagnose", str(path), "--json", "--report", str(tmp_path / "rep")]) == 0
    doc = json.loads(capsys.readouterr().out)
    for key in ("verdict", "effects", "candidates", "base", "extended", "explanation"):
        assert key in doc
    assert isinstance(doc["verdict"], str)
    assert {"name", "params", "mae", "heldout_mae", "delta_bic"} <= set(doc["candidates"][0])
    assert (tmp_path / "rep" / "report.md").exists()
    assert (tmp_path / "rep" / "adhesion_vs_creep.png").exists()


def test_cli_bad_file(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("time,vehicle_speed\n0,1\n")
    assert main(["diagnose", str(bad), "--json"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert "bad.csv" in captured.err
