"""imunoise.read and imunoise.analyze: the command's readers and results.json, the report
folder, to_dict and plot."""

import json

import numpy as np
import pytest

import imunoise
from conftest import RATE, assert_json_close


def test_read_csv(gyro):
    path, x, names = gyro
    rec = imunoise.read(path, rate=RATE)
    assert rec.names == names and rec.units == ["deg/s", "deg/s"]
    assert rec.rate_hz == RATE and rec.timing is None
    assert np.array_equal(rec.data, x)
    assert rec.data.flags.f_contiguous
    assert imunoise.avar(rec.data, RATE)[0].copied is False
    np.testing.assert_allclose(rec.t[:3], [0.0, 0.01, 0.02])


def test_read_binary_and_columns(tmp_path):
    x = np.random.default_rng(1).normal(size=(300, 4))
    p = tmp_path / "log.f64"
    x.astype("<f8").tofile(p)
    rec = imunoise.read(p, rate=50.0, binary="f64", channels=4, columns="2-3", scale=2.0)
    assert rec.data.shape == (300, 2)
    assert np.array_equal(rec.data, 2.0 * x[:, 1:3])


def test_read_time_column_gives_rate_and_timing(tmp_path):
    t = 1000.0 + np.arange(2000) / 200.0
    y = np.random.default_rng(2).normal(size=2000)
    p = tmp_path / "stamped.csv"
    np.savetxt(p, np.column_stack([t, y]), delimiter=",", fmt="%.17g", header="t,acc_z_mps2",
               comments="")
    rec = imunoise.read(p, time_column="t")
    assert rec.rate_hz == pytest.approx(200.0, rel=1e-9)
    assert rec.names == ["acc_z_mps2"] and rec.units == ["m/s^2"]
    assert rec.timing["span_s"][0] == pytest.approx(1000.0)
    assert rec.t[0] == pytest.approx(1000.0)


def test_analyze_file_equals_cli_results_json(gyro, cli, tmp_path):
    path, _, _ = gyro
    out = tmp_path / "cli_report"
    cli("analyze", path, "--rate", RATE, "--out", out, parse=False)
    doc = json.loads((out / "results.json").read_text())
    res = imunoise.analyze(str(path), rate=RATE)
    assert_json_close(res, doc)
    ch = res["channels"][0]
    assert ch["unit"] == "deg/s" and "N" in ch["fit"]["ieee"]


def test_analyze_array_equals_analyze_file(gyro):
    path, x, names = gyro
    a = imunoise.analyze(x, rate=RATE, names=names)
    f = imunoise.analyze(path, rate=RATE)
    assert a["source"] == "<array>"
    assert_json_close(a["channels"], f["channels"], rel=0)


def test_analyze_writes_report_folder(gyro, tmp_path):
    path, _, _ = gyro
    out = tmp_path / "report"
    res = imunoise.analyze(path, rate=RATE, out=out, select=False, model="WN+RW")
    assert (out / "report.html").exists()
    assert json.loads((out / "results.json").read_text()) == res
    assert res["channels"][0]["fit"]["model"].startswith("WN")


def test_to_dict_shapes(gyro):
    _, x, names = gyro
    r = imunoise.avar(x[:, 0].copy(), RATE, names=names[:1])
    d = imunoise.to_dict(r)
    assert list(d) == ["channels"] and d["channels"][0]["name"] == names[0]
    assert set(d["channels"][0]["points"][0]) == {
        "m", "tau", "avar", "adev", "avar_lo", "avar_hi", "edf", "n_terms"}
    t = imunoise.theory("WN(1)", 1.0)
    assert set(imunoise.to_dict(t)) == {"model", "rate_hz", "points", "components", "psd"}
    with pytest.raises(imunoise.UsageError):
        imunoise.to_dict(42)


def test_plot(gyro):
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    _, x, names = gyro
    ax = imunoise.plot(imunoise.avar(x, RATE, names=names))
    assert len(ax.get_lines()) == 2 and ax.get_xscale() == "log"
    ax2 = imunoise.plot(imunoise.analyze(x, rate=RATE, names=names))
    assert len(ax2.get_lines()) == 4  # two curves, two fitted models
    ax3 = imunoise.plot(imunoise.theory("WN(1e-4)+RW(1e-9)", 100.0))
    assert len(ax3.get_lines()) == 3
