"""imunoise.fit, simulate, theory and Model: the command's JSON, closed forms, and the
Monte Carlo behaviour of the fit."""

import subprocess

import numpy as np
import pytest

import imunoise
from conftest import RATE, assert_json_close


def test_fit_array_equals_cli_json(gyro, cli):
    path, x, names = gyro
    doc = cli("fit", path, "--rate", RATE, "--model", "WN+RW+AR1", "--format", "json")
    res = imunoise.fit(x, RATE, model="WN+RW+AR1", names=names)
    assert_json_close(imunoise.to_dict(res), doc)


def test_fit_select_equals_cli_json(gyro, cli):
    path, x, names = gyro
    doc = cli("fit", path, "--rate", RATE, "--select", "--format", "json")
    res = imunoise.fit(x, RATE, select=True, names=names)
    assert_json_close(imunoise.to_dict(res), doc)
    assert all("wic" in r.to_dict() for r in res)


def test_fit_of_avar_result_equals_fit_of_samples(gyro):
    _, x, names = gyro
    curves = imunoise.avar(x, RATE, names=names)
    a = imunoise.fit(curves, model="WN+RW+AR1")
    b = imunoise.fit(x, RATE, model="WN+RW+AR1", names=names)
    for fa, fb in zip(a, b):
        assert fa.model == fb.model
        assert fa.parameters == fb.parameters
        assert fa.ieee == fb.ieee


def test_fit_recovers_white_noise_within_standard_errors():
    # WN sigma^2 = 1e-4 per sample at 2^17 samples: the estimate's relative SE is about
    # sqrt(2/T) ~ 0.4 % (the GMWM is close to efficient for WN alone): 5 SE is 2 %
    x = imunoise.simulate("WN(sigma2=1e-4)", 1 << 17, RATE, seed=5)
    f = imunoise.fit(x, RATE, model="WN", unit="deg/s")
    v, lo, hi = f.parameters["WN.sigma2"]
    assert abs(v / 1e-4 - 1) < 0.02
    assert lo < 1e-4 < hi
    # N = sqrt(sigma2 / rate) in deg/s/sqrt(Hz), times 60 for deg/sqrt(h)
    n_val, _, _, unit = f.ieee["N"]
    assert n_val == pytest.approx(np.sqrt(v / RATE) * 60, rel=1e-9)
    assert "h" in unit


@pytest.mark.parametrize("method", ["avlr", "ieee952"])
def test_other_methods_equal_cli(gyro, cli, method):
    path, x, names = gyro
    extra = ["--bootstrap", "20"] if method == "avlr" else []
    doc = cli("fit", path, "--rate", RATE, "--method", method, *extra, "--format", "json")
    res = imunoise.fit(x, RATE, method=method, bootstrap=20 if extra else 0, names=names)
    assert_json_close(imunoise.to_dict(res), doc)
    assert all(r.method for r in res)


def test_simulate_equals_cli_bits(tmp_path, cli):
    out = tmp_path / "sim.f64"
    cli("simulate", "--model", "WN(1e-4)+RW(1e-9)", "-n", 5000, "--rate", 200, "--seed", 7,
        "--channels", 3, "-o", out, parse=False)
    cli_x = np.fromfile(out, dtype="<f8").reshape(5000, 3)
    x = imunoise.simulate("WN(1e-4)+RW(1e-9)", 5000, 200.0, seed=7, channels=3)
    assert x.shape == (5000, 3) and x.flags.f_contiguous
    assert np.array_equal(x, cli_x)


def test_simulate_streams_and_seeds():
    a = imunoise.simulate("WN(1)", 1000, 10.0, seed=3, channels=3)
    b = imunoise.simulate("WN(1)", 1000, 10.0, seed=3, channels=2)
    assert np.array_equal(a[:, 1], b[:, 1])  # channel k is stream k of the seed
    one = imunoise.simulate("WN(1)", 1000, 10.0, seed=3)
    assert one.ndim == 1 and np.array_equal(one, a[:, 0])
    assert not np.array_equal(one, imunoise.simulate("WN(1)", 1000, 10.0, seed=4))
    # unit-variance white noise: the sample variance of 3000 draws is 1 within 5 SE (SE 0.026)
    assert abs(a.var() - 1) < 5 * np.sqrt(2 / 3000)


def test_theory_equals_cli_json(cli):
    model = "QN(q2=1e-6)+WN(1e-4)+RW(1e-10)"
    doc = cli("theory", "--model", model, "--rate", 200, "--scales", "octave", "-n", 100000,
              "--format", "json")
    t = imunoise.theory(model, 200.0, scales="octave", n=100000)
    assert_json_close(t.to_dict(), doc)
    assert len(t.components) == 3


def test_theory_white_noise_closed_form():
    t = imunoise.theory("WN(sigma2=2e-4)", 50.0, scales=[1, 2, 8, 100])
    np.testing.assert_allclose(t.avar, 2e-4 / np.array([1, 2, 8, 100]), rtol=1e-12)
    np.testing.assert_allclose(t.tau, np.array([1, 2, 8, 100]) / 50.0, rtol=1e-15)


def test_model_parse_str_components():
    m = imunoise.Model("WN(sigma2=1e-4) + RW + 2*AR1")
    assert len(m.components) == 4 and m.components[0].startswith("WN")
    assert m.n_params == 1 + 1 + 2 * 2
    assert not m.complete
    assert imunoise.Model(str(m)) == m
    c = imunoise.Model("WN(1e-4)+RW(1e-9)")
    assert c.complete and "WN" in str(c) and "RW" in str(c)
    x = imunoise.simulate(c, 100, 10.0)  # a Model is accepted where text is
    assert x.shape == (100,)
