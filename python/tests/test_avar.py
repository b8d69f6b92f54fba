"""imunoise.avar: closed forms, an independent numpy implementation, the command's JSON,
scale grids, CI families, the angle input, and the documented no-copy rule."""

import threading

import numpy as np
import pytest

import imunoise
from conftest import RATE, assert_json_close


def numpy_oavar(x, m):
    """The maximum-overlapping AV (book eq. 4.2) written directly with cumulative sums."""
    c = np.concatenate([[0.0], np.cumsum(x)])
    means = (c[m:] - c[:-m]) / m
    d = means[m:] - means[:-m]
    return 0.5 * np.mean(d * d)


def numpy_navar(x, m):
    k = len(x) // m
    means = x[: k * m].reshape(k, m).mean(axis=1)
    return 0.5 * np.mean(np.diff(means) ** 2)


def test_ramp_closed_form():
    # x_t = t: every cluster mean of size m is m larger than the one before, so AV(m) = m^2/2
    x = np.arange(4096, dtype=np.float64)
    r = imunoise.avar(x, rate=10.0, ci="none")
    np.testing.assert_allclose(r.avar, r.m.astype(float) ** 2 / 2, rtol=1e-9)
    np.testing.assert_allclose(r.tau, r.m / 10.0, rtol=0, atol=0)
    np.testing.assert_allclose(r.adev, np.sqrt(r.avar), rtol=1e-15)


def test_overlapping_matches_numpy_implementation():
    x = np.random.default_rng(3).normal(size=10000)
    r = imunoise.avar(x, rate=RATE, scales=[1, 3, 7, 50, 1000], ci="none")
    for m, a in zip(r.m, r.avar):
        assert a == pytest.approx(numpy_oavar(x, int(m)), rel=1e-10)


def test_non_overlapping_matches_numpy_implementation():
    x = np.random.default_rng(4).normal(size=10000)
    r = imunoise.avar(x, rate=RATE, scales=[1, 4, 10, 100], ci="none", estimator="non_overlapping")
    assert r.estimator == "non_overlapping"
    for m, a in zip(r.m, r.avar):
        assert a == pytest.approx(numpy_navar(x, int(m)), rel=1e-10)


def test_equals_cli_json(gyro, cli):
    path, x, names = gyro
    doc = cli("avar", path, "--rate", RATE, "--format", "json")
    res = imunoise.avar(x, RATE, names=names)
    assert_json_close(imunoise.to_dict(res), doc)


@pytest.mark.parametrize("scales,ci", [("octave", "gaussian"), ("decade", "none"), ("log5", "chi2")])
def test_equals_cli_json_grids_and_cis(gyro, cli, scales, ci):
    path, x, names = gyro
    doc = cli("avar", path, "--rate", RATE, "--format", "json", "--scales", scales, "--ci", ci)
    res = imunoise.avar(x, RATE, scales=scales, ci=ci, names=names)
    assert_json_close(imunoise.to_dict(res), doc)


def test_two_d_gives_one_result_per_column(gyro):
    _, x, _ = gyro
    res = imunoise.avar(x, RATE)
    assert len(res) == 2 and [r.name for r in res] == ["col1", "col2"]
    for j, r in enumerate(res):
        one = imunoise.avar(np.ascontiguousarray(x[:, j]), RATE)
        assert np.array_equal(r.avar, one.avar) and np.array_equal(r.hi, one.hi)


def test_white_noise_within_chi2_interval():
    # sigma^2 = 1 white noise: AV(m) = 1/m. With 2^16 samples the 99 % chi-square interval
    # covers it at each of the first scales (a fixed seed; 5 scales at 1 % each)
    x = np.random.default_rng(7).normal(size=1 << 16)
    r = imunoise.avar(x, RATE, alpha=0.01)
    truth = 1.0 / r.m[:5]
    assert np.all((r.lo[:5] <= truth) & (truth <= r.hi[:5]))
    assert np.all(r.edf[:5] > 100)


def test_ci_none_gives_nan_bounds():
    r = imunoise.avar(np.random.default_rng(1).normal(size=2048), RATE, ci="none")
    assert np.isnan(r.lo).all() and np.isnan(r.hi).all() and np.isnan(r.edf).all()
    assert r.to_dict()["points"][0]["avar_lo"] is None


def test_explicit_scales_and_dyadic_grid():
    x = np.random.default_rng(2).normal(size=1000)
    assert list(imunoise.avar(x, 1.0, scales=[2, 5, 9]).m) == [2, 5, 9]
    # the book's dyadic grid: m = 2^j, j = 1 .. ceil(log2 T) - 2  (T = 1000: j = 1..8)
    assert list(imunoise.avar(x, 1.0).m) == [2**j for j in range(1, 9)]
    assert list(imunoise.avar(x, 1.0, scales="octave").m) == [2**j for j in range(0, 8)]


def test_angle_input_equals_rate_input():
    x = np.random.default_rng(5).normal(size=5000)
    theta = np.concatenate([[0.0], np.cumsum(x) / RATE])  # integrated samples, T + 1 of them
    a = imunoise.avar(theta, RATE, input="angle", ci="none")
    r = imunoise.avar(x, RATE, ci="none")
    assert list(a.m) == list(r.m)
    np.testing.assert_allclose(a.avar, r.avar, rtol=1e-9)


def test_no_copy_for_c_contiguous_float64_and_view_gives_same_result():
    x = np.random.default_rng(6).normal(size=20000)
    r = imunoise.avar(x, RATE)
    assert r.copied is False
    v = x[5:15005]  # a contiguous view into x: read in place
    rv = imunoise.avar(v, RATE)
    assert rv.copied is False
    assert np.array_equal(rv.avar, imunoise.avar(v.copy(), RATE).avar)
    s = x[::2]  # a strided view: converted (copied) first, same numbers as its copy
    rs = imunoise.avar(s, RATE)
    assert rs.copied is True
    assert np.array_equal(rs.avar, imunoise.avar(np.ascontiguousarray(s), RATE).avar)


def test_other_dtypes_and_layouts_are_converted():
    x32 = np.random.default_rng(8).normal(size=4096).astype(np.float32)
    r = imunoise.avar(x32, RATE)
    assert r.copied is True
    assert np.array_equal(r.avar, imunoise.avar(x32.astype(np.float64), RATE).avar)
    assert imunoise.avar(list(map(float, x32)), RATE).copied is True
    m = np.random.default_rng(9).normal(size=(4096, 3))
    rc = imunoise.avar(m, RATE)  # C-ordered 2-D: columns are strided, so copied
    rf = imunoise.avar(np.asfortranarray(m), RATE)  # Fortran-ordered: columns read in place
    assert all(r.copied for r in rc) and not any(r.copied for r in rf)
    for a, b in zip(rc, rf):
        assert np.array_equal(a.avar, b.avar)


def test_gil_is_released_while_computing():
    # while one thread computes a long AV, another Python thread keeps running
    x = np.random.default_rng(10).normal(size=4_000_000)
    ticks = []
    done = threading.Event()

    def count():
        while not done.is_set():
            ticks.append(1)

    t = threading.Thread(target=count)
    t.start()
    try:
        before = len(ticks)
        imunoise.avar(x, RATE)
        during = len(ticks) - before
    finally:
        done.set()
        t.join()
    # with the GIL held the counter thread would get at most a switch or two
    assert during > 1000


def test_file_path_equals_the_command_and_the_array(gyro, cli):
    # a CSV path is read through the command's readers: the command's JSON, and the numbers of
    # the same samples given as an array
    path, x, names = gyro
    res = imunoise.avar(path, RATE)
    assert [r.name for r in res] == names
    assert_json_close(imunoise.to_dict(res), cli("avar", path, "--rate", RATE, "--format", "json"))
    arr = imunoise.avar(x, RATE, names=names)
    for a, b in zip(res, arr):
        assert a.to_dict() == b.to_dict()


def test_raw_binary_file_is_streamed_bit_for_bit(tmp_path, cli):
    # three interleaved f64 channels, above the streaming threshold (2^22 samples): read by
    # groups of channels, never loaded whole; the same bits as the array path and the command
    n = (1 << 22) + 123
    x = imunoise.simulate("WN(sigma2=1e-4) + RW(gamma2=1e-10)", n, RATE, seed=5, channels=3)
    p = tmp_path / "imu.f64"
    np.ascontiguousarray(x).tofile(p)
    res = imunoise.avar(p, RATE, ci="none", binary="f64", channels=3, columns="3,1")
    assert [r.name for r in res] == ["ch3", "ch1"]
    for r, c in zip(res, [2, 0]):
        a = imunoise.avar(np.ascontiguousarray(x[:, c]), RATE, ci="none")
        assert np.array_equal(r.avar, a.avar) and np.array_equal(r.m, a.m)
        assert r.n == n and not r.copied
    doc = cli("avar", p, "--rate", RATE, "--format", "json", "--ci", "none",
              "--binary", "f64", "--channels", 3, "--columns", "3,1")
    assert_json_close(imunoise.to_dict(res), doc)
    one = imunoise.avar(str(p), RATE, ci="none", binary="f64", channels=3, columns="2")
    assert isinstance(one, imunoise.AvarResult) and one.name == "ch2"


def test_file_and_array_argument_errors(tmp_path):
    p = tmp_path / "w.f64"
    np.zeros(64).tofile(p)
    with pytest.raises(imunoise.UsageError, match="--rate is required"):
        imunoise.avar(p, binary="f64")
    with pytest.raises(imunoise.UsageError, match="rate"):
        imunoise.avar(np.zeros(64))
    with pytest.raises(imunoise.UsageError, match="files only"):
        imunoise.avar(np.zeros(64), RATE, binary="f64")
    with pytest.raises(imunoise.InputError, match="missing.f64"):
        imunoise.avar(tmp_path / "missing.f64", RATE, binary="f64")
