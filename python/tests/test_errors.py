"""Each error class: a ValueError subclass carrying the library's message."""

import numpy as np
import pytest

import imunoise


def test_hierarchy():
    for cls in (imunoise.InputError, imunoise.UsageError, imunoise.ModelError,
                imunoise.EstimationError, imunoise.OutputError):
        assert issubclass(cls, imunoise.ImunoiseError)
    assert issubclass(imunoise.ImunoiseError, ValueError)


def test_input_error_missing_file(tmp_path):
    p = tmp_path / "nope.csv"
    with pytest.raises(imunoise.InputError, match="no such file or directory") as e:
        imunoise.read(p, rate=100.0)
    assert str(p) in str(e.value)


def test_input_error_located(tmp_path):
    p = tmp_path / "bad.csv"
    p.write_text("a,b\n1,2\n3,x\n")
    with pytest.raises(imunoise.InputError, match=r"bad\.csv:3:"):
        imunoise.read(p, rate=1.0)


def test_usage_errors():
    x = np.zeros(1000)
    with pytest.raises(imunoise.UsageError, match="rate"):
        imunoise.avar(x, rate=-1.0)
    with pytest.raises(imunoise.UsageError, match="scales"):
        imunoise.avar(x, rate=1.0, scales="fortnightly")
    with pytest.raises(imunoise.UsageError, match="ci"):
        imunoise.avar(x, rate=1.0, ci="bogus")
    with pytest.raises(imunoise.UsageError, match="alpha"):
        imunoise.avar(x, rate=1.0, alpha=1.5)
    with pytest.raises(ValueError):
        imunoise.avar(np.zeros((2, 2, 2)), rate=1.0)


def test_model_error():
    with pytest.raises(imunoise.ModelError):
        imunoise.Model("WN + NOPE(3)")
    with pytest.raises(imunoise.ModelError):
        imunoise.simulate("WN(sigma2=-1)", 10, 1.0)


def test_estimation_error():
    with pytest.raises(imunoise.EstimationError, match="<array>"):
        imunoise.avar(np.array([1.0, 2.0, 3.0]), rate=1.0)
    x = np.ones(1000)
    x[10] = np.nan
    with pytest.raises(imunoise.EstimationError):
        imunoise.avar(x, rate=1.0)


def test_output_error(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    x = imunoise.simulate("WN(1e-4)", 4096, 100.0)
    with pytest.raises(imunoise.ImunoiseError) as e:
        imunoise.analyze(x, rate=100.0, out=blocker / "sub")
    assert isinstance(e.value, (imunoise.OutputError, imunoise.UsageError))
    assert "file" in str(e.value)


def test_analyze_checks_its_settings_before_reading(tmp_path):
    # the file does not exist: a setting checked after the read would give InputError instead
    missing = str(tmp_path / "missing.csv")
    with pytest.raises(imunoise.ModelError, match="FOO"):
        imunoise.analyze(missing, rate=1.0, model="WN+FOO")
    with pytest.raises(imunoise.UsageError, match="record"):
        imunoise.analyze(missing, rate=1.0, record_halfwidth=2.0)
    assert not (tmp_path / "report").exists()
    with pytest.raises(imunoise.ModelError, match="FOO"):
        imunoise.analyze(missing, rate=1.0, out=str(tmp_path / "report"), model="WN+FOO")
    assert not (tmp_path / "report").exists()


def test_values_in_the_model_template_are_named_as_unused():
    x = imunoise.simulate("WN(sigma2=1e-4) + RW(gamma2=1e-9)", 4096, 100.0, seed=2)
    with pytest.warns(UserWarning, match="does not use them"):
        with_values = imunoise.fit(x, 100.0, model="WN(sigma2=5) + RW")
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no warning for the bare template
        bare = imunoise.fit(x, 100.0, model="WN+RW")
    assert with_values.parameters == bare.parameters


def test_equal_channel_names_are_refused():
    x = imunoise.simulate("WN(sigma2=1e-4)", 4096, 100.0, seed=2, channels=2)
    with pytest.raises(imunoise.UsageError, match="both named"):
        imunoise.analyze(x, 100.0, names=["gx", "gx"])
