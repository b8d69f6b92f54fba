//! `imunoise._imunoise`: the native half of the Python package. Thin: every function parses
//! its arguments into the library's plain structs, calls the same `imunoise::pipeline` code
//! as the `imunoise` command (with the GIL released), and hands back the command's JSON
//! document as a string, which the pure-Python half (`python/imunoise/`) turns into dicts
//! and numpy arrays. Errors become `ImunoiseError` subclasses carrying the crate's message.

use imunoise::Error;
use imunoise::avar::{AllanVariance, AvarConfig, CiMethod, Estimator, InputKind};
use imunoise::io::Table;
use imunoise::pipeline::{analyze, estimate, fit, read, simulate, theory};
use imunoise::processes::{Model, Unit};
use numpy::ndarray::{Array2, ShapeBuilder};
use numpy::{IntoPyArray, PyArray2, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

pyo3::create_exception!(
    _imunoise,
    ImunoiseError,
    PyValueError,
    "Base class of every imunoise error (a ValueError): the message is the library's."
);
pyo3::create_exception!(
    _imunoise,
    InputError,
    ImunoiseError,
    "An input file could not be read, or holds a bad value (located by file:line:column)."
);
pyo3::create_exception!(
    _imunoise,
    UsageError,
    ImunoiseError,
    "A bad argument value (rate <= 0, unknown scale grid, unknown column, ...)."
);
pyo3::create_exception!(
    _imunoise,
    ModelError,
    ImunoiseError,
    "A bad model text or parameter value, or a failed simulation."
);
pyo3::create_exception!(
    _imunoise,
    EstimationError,
    ImunoiseError,
    "The samples of an array could not be analysed (too few for the scales, NaN or infinity, not representable)."
);
pyo3::create_exception!(
    _imunoise,
    OutputError,
    ImunoiseError,
    "An output (report folder, file) could not be written."
);

/// The name of samples handed over as an array (in messages, and `source` of results.json).
const ARRAY: &str = "<array>";

/// The library error as the matching Python exception, with the library's message.
fn py_err(e: Error) -> PyErr {
    let msg = e.to_string();
    match e {
        // arrays are named ARRAY: a problem with their samples is the estimator's
        Error::File { file, .. } if file == ARRAY => EstimationError::new_err(msg),
        Error::Io { .. } | Error::Located { .. } | Error::File { .. } => InputError::new_err(msg),
        Error::Usage(_) => UsageError::new_err(msg),
        Error::Process(_) => ModelError::new_err(msg),
        Error::Avar(_) => EstimationError::new_err(msg),
        Error::Write { .. } | Error::Json(_) => OutputError::new_err(msg),
    }
}

fn usage(msg: String) -> PyErr {
    UsageError::new_err(msg)
}

fn json_string(v: &impl serde::Serialize) -> PyResult<String> {
    serde_json::to_string(v).map_err(|e| py_err(Error::Json(e)))
}

/// Channels handed over by Python: borrowed numpy memory where the layout allows it.
enum Channels<'py> {
    /// A 1-D C-contiguous float64 array.
    One(PyReadonlyArray1<'py, f64>),
    /// A 2-D float64 array (rows = samples, columns = channels).
    Two(PyReadonlyArray2<'py, f64>),
}

impl<'py> Channels<'py> {
    fn extract(x: &Bound<'py, PyAny>) -> PyResult<Self> {
        if let Ok(a) = x.extract::<PyReadonlyArray1<'py, f64>>() {
            return Ok(Channels::One(a));
        }
        if let Ok(a) = x.extract::<PyReadonlyArray2<'py, f64>>() {
            return Ok(Channels::Two(a));
        }
        Err(usage(
            "expected a 1-D or 2-D float64 numpy array (samples in rows, channels in columns)"
                .into(),
        ))
    }

    /// The channels as slices: borrowed for a contiguous 1-D array and for a Fortran-ordered
    /// 2-D one (whose columns are contiguous); copied column by column otherwise. The flag
    /// says whether a copy was made.
    fn columns(&self) -> (Vec<std::borrow::Cow<'_, [f64]>>, bool) {
        use std::borrow::Cow;
        match self {
            Channels::One(a) => match a.as_slice() {
                Ok(s) => (vec![Cow::Borrowed(s)], false),
                Err(_) => (vec![Cow::Owned(a.as_array().to_vec())], true),
            },
            Channels::Two(a) => {
                let (n, k) = (a.shape()[0], a.shape()[1]);
                if a.is_fortran_contiguous()
                    && let Ok(s) = a.as_slice()
                {
                    let cols = if n == 0 {
                        vec![Cow::Borrowed(s); k]
                    } else {
                        s.chunks_exact(n).map(Cow::Borrowed).collect()
                    };
                    return (cols, false);
                }
                let v = a.as_array();
                let cols = (0..k).map(|j| Cow::Owned(v.column(j).to_vec())).collect();
                (cols, true)
            }
        }
    }

    fn n_channels(&self) -> usize {
        match self {
            Channels::One(_) => 1,
            Channels::Two(a) => a.shape()[1],
        }
    }
}

fn channel_names(names: Option<Vec<String>>, k: usize) -> PyResult<Vec<String>> {
    match names {
        Some(n) if n.len() == k => {
            imunoise::pipeline::read::unique_names("<array>", &n).map_err(py_err)?;
            Ok(n)
        }
        Some(n) => Err(usage(format!("{} names given for {k} channels", n.len()))),
        None => Ok((1..=k).map(|i| format!("col{i}")).collect()),
    }
}

fn check_rate(rate: f64) -> PyResult<f64> {
    if rate.is_finite() && rate > 0.0 {
        Ok(rate)
    } else {
        Err(usage(format!(
            "rate must be a positive number of Hz, got {rate}"
        )))
    }
}

fn avar_config(
    scales: &str,
    ci: &str,
    alpha: f64,
    input: &str,
    estimator: &str,
) -> PyResult<AvarConfig> {
    if !(alpha > 0.0 && alpha < 1.0) {
        return Err(usage(format!("alpha must lie in (0, 1), got {alpha}")));
    }
    Ok(AvarConfig {
        scales: estimate::parse_scales(scales).map_err(|e| usage(format!("scales: {e}")))?,
        estimator: match estimator {
            "overlapping" => Estimator::Overlapping,
            "non_overlapping" | "non-overlapping" => Estimator::NonOverlapping,
            e => {
                return Err(usage(format!(
                    "estimator: expected 'overlapping' or 'non_overlapping', got {e:?}"
                )));
            }
        },
        input: match input {
            "rate" => InputKind::Rate,
            "angle" => InputKind::Angle,
            i => {
                return Err(usage(format!(
                    "input: expected 'rate' or 'angle', got {i:?}"
                )));
            }
        },
        ci: match ci {
            "chi2" => CiMethod::ChiSquare,
            "gaussian" => CiMethod::Gaussian,
            "none" => CiMethod::None,
            c => {
                return Err(usage(format!(
                    "ci: expected 'chi2', 'gaussian' or 'none', got {c:?}"
                )));
            }
        },
        alpha,
    })
}

/// One channel's Allan variance, kept on the Rust side so that `fit` can take it back.
#[pyclass(module = "imunoise._imunoise", frozen)]
struct Curve {
    name: String,
    av: AllanVariance,
}

#[pymethods]
impl Curve {
    /// The channel entry of the `imunoise avar --format json` document, as a JSON string.
    fn to_json(&self) -> PyResult<String> {
        let doc = estimate::to_json(&[(self.name.clone(), self.av.clone())]);
        json_string(&doc.channels[0])
    }

    #[getter]
    fn name(&self) -> &str {
        &self.name
    }
}

/// Allan variance of every channel of `x` (see `imunoise.avar`). Returns the curves and
/// whether the samples had to be copied.
#[pyfunction]
#[pyo3(signature = (x, rate, scales, ci, alpha, input, estimator, names=None))]
#[allow(clippy::too_many_arguments)]
fn avar(
    py: Python<'_>,
    x: &Bound<'_, PyAny>,
    rate: f64,
    scales: &str,
    ci: &str,
    alpha: f64,
    input: &str,
    estimator: &str,
    names: Option<Vec<String>>,
) -> PyResult<(Vec<Curve>, bool)> {
    let rate = check_rate(rate)?;
    let cfg = avar_config(scales, ci, alpha, input, estimator)?;
    let ch = Channels::extract(x)?;
    let names = channel_names(names, ch.n_channels())?;
    let (cols, copied) = ch.columns();
    let slices: Vec<&[f64]> = cols.iter().map(|c| c.as_ref()).collect();
    let curves = py
        .detach(|| {
            estimate::compute_columns(ARRAY, &names, &slices, rate, &cfg, &imunoise::Ui::quiet())
        })
        .map_err(py_err)?;
    Ok((
        curves
            .into_iter()
            .map(|(name, av)| Curve { name, av })
            .collect(),
        copied,
    ))
}

/// Allan variance of every channel of a file, as `imunoise avar FILE` (see `imunoise.avar`):
/// raw binary streamed (used in place or decoded by groups of channels, never loaded whole),
/// every other input read through the command's readers.
#[pyfunction]
#[pyo3(signature = (path, scales, ci, alpha, input, estimator, rate=None, topic=None,
    columns=None, binary=None, channels=None, scale=None, names=None, unit=None,
    time_column=None, time_unit="s", gaps="refuse"))]
#[allow(clippy::too_many_arguments)]
fn avar_file(
    py: Python<'_>,
    path: std::path::PathBuf,
    scales: &str,
    ci: &str,
    alpha: f64,
    input: &str,
    estimator: &str,
    rate: Option<f64>,
    topic: Option<String>,
    columns: Option<String>,
    binary: Option<&str>,
    channels: Option<usize>,
    scale: Option<f64>,
    names: Option<String>,
    unit: Option<String>,
    time_column: Option<String>,
    time_unit: &str,
    gaps: &str,
) -> PyResult<Vec<Curve>> {
    let cfg = avar_config(scales, ci, alpha, input, estimator)?;
    let spec = input_spec(
        path,
        rate,
        topic.map(|t| vec![t]),
        columns,
        binary,
        channels,
        scale,
        names,
        unit,
        time_column,
        time_unit,
        gaps,
    )?;
    let (_, curves) = py
        .detach(|| estimate::avar_file(&spec, &cfg, &imunoise::Ui::quiet()))
        .map_err(py_err)?;
    Ok(curves
        .into_iter()
        .map(|(name, av)| Curve { name, av })
        .collect())
}

/// The fit settings from the Python arguments.
#[allow(clippy::too_many_arguments)]
fn fit_settings(
    model: &str,
    method: &str,
    select: bool,
    weighting: &str,
    bootstrap: usize,
    seed: u64,
    alpha: f64,
    tau: (Option<f64>, Option<f64>),
) -> PyResult<fit::FitSettings> {
    if !(alpha > 0.0 && alpha < 1.0) {
        return Err(usage(format!("alpha must lie in (0, 1), got {alpha}")));
    }
    let settings = fit::FitSettings {
        model: model.to_string(),
        method: match method {
            "gmwm" => fit::Method::Gmwm,
            "avlr" => fit::Method::Avlr,
            "ieee952" => fit::Method::Ieee952,
            m => {
                return Err(usage(format!(
                    "method: expected 'gmwm', 'avlr' or 'ieee952', got {m:?}"
                )));
            }
        },
        select,
        weighting: match weighting {
            "diagonal" => fit::FitWeighting::Diagonal,
            "model-diagonal" | "model_diagonal" => fit::FitWeighting::ModelDiagonal,
            "model-full" | "model_full" => fit::FitWeighting::ModelFull,
            w => {
                return Err(usage(format!(
                    "weighting: expected 'diagonal', 'model-diagonal' or 'model-full', got {w:?}"
                )));
            }
        },
        bootstrap,
        seed,
        alpha,
        tau_min: tau.0,
        tau_max: tau.1,
    };
    // the model parses (and the rest holds) before any file is read
    settings.check().map_err(py_err)?;
    Ok(settings)
}

fn robust_eff(robust: bool, efficiency: f64) -> PyResult<Option<f64>> {
    fit::robust_efficiency(robust, efficiency).map_err(py_err)
}

/// A table of copied channels at `rate` (what `fit` and `analyze` take from an array).
fn array_table(x: &Bound<'_, PyAny>, rate: f64, names: Option<Vec<String>>) -> PyResult<Table> {
    let ch = Channels::extract(x)?;
    let names = channel_names(names, ch.n_channels())?;
    let (cols, _) = ch.columns();
    Ok(Table {
        file: ARRAY.into(),
        names,
        columns: cols.into_iter().map(|c| c.into_owned().into()).collect(),
        rate_hz: Some(check_rate(rate)?),
        timing: None,
        topic: None,
    })
}

fn units_of(names: &[String], unit: Option<&str>) -> PyResult<Vec<Unit>> {
    imunoise::units::channel_units(names, unit).map_err(py_err)
}

/// Fits a noise model to every channel of an array (as `imunoise fit` does to a file), or to
/// Allan variance curves; returns the `fit --format json` document as a string.
#[pyfunction]
#[pyo3(signature = (x, rate, model, method, select, bootstrap, weighting, seed, alpha,
    robust, efficiency, names=None, unit=None, tau_min=None, tau_max=None))]
#[allow(clippy::too_many_arguments)]
fn fit_array(
    py: Python<'_>,
    x: &Bound<'_, PyAny>,
    rate: f64,
    model: &str,
    method: &str,
    select: bool,
    bootstrap: usize,
    weighting: &str,
    seed: u64,
    alpha: f64,
    robust: bool,
    efficiency: f64,
    names: Option<Vec<String>>,
    unit: Option<&str>,
    tau_min: Option<f64>,
    tau_max: Option<f64>,
) -> PyResult<String> {
    let tau = (tau_min, tau_max);
    let settings = fit_settings(
        model, method, select, weighting, bootstrap, seed, alpha, tau,
    )?;
    let robust = robust_eff(robust, efficiency)?;
    let table = array_table(x, rate, names)?;
    let units = units_of(&table.names, unit)?;
    let fits = py
        .detach(|| fit::fit_table(&table, &units, &settings, robust, &imunoise::Ui::quiet()))
        .map_err(py_err)?;
    json_string(&fit::FitJson { channels: fits })
}

/// Fits a noise model to Allan variance curves made by `avar` (no data-quality pass: the
/// samples are not at hand); returns the `fit --format json` document as a string.
#[pyfunction]
#[pyo3(signature = (curves, model, method, select, bootstrap, weighting, seed, alpha, unit=None,
    tau_min=None, tau_max=None))]
#[allow(clippy::too_many_arguments)]
fn fit_curves(
    py: Python<'_>,
    curves: Vec<PyRef<'_, Curve>>,
    model: &str,
    method: &str,
    select: bool,
    bootstrap: usize,
    weighting: &str,
    seed: u64,
    alpha: f64,
    unit: Option<&str>,
    tau_min: Option<f64>,
    tau_max: Option<f64>,
) -> PyResult<String> {
    let tau = (tau_min, tau_max);
    let settings = fit_settings(
        model, method, select, weighting, bootstrap, seed, alpha, tau,
    )?;
    let named: Vec<(String, AllanVariance)> = curves
        .iter()
        .map(|c| (c.name.clone(), c.av.clone()))
        .collect();
    let names: Vec<String> = named.iter().map(|(n, _)| n.clone()).collect();
    let units = units_of(&names, unit)?;
    let fits = py
        .detach(|| fit::fit_all(&named, &units, &settings, &imunoise::Ui::quiet()))
        .map_err(py_err)?;
    json_string(&fit::FitJson { channels: fits })
}

/// `n` samples per channel of `model` at `rate` Hz with `seed`, as a Fortran-ordered
/// (n, channels) array: the same numbers as `imunoise simulate`.
#[pyfunction]
fn simulate_array<'py>(
    py: Python<'py>,
    model: &str,
    n: usize,
    rate: f64,
    seed: u64,
    channels: usize,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let rate = check_rate(rate)?;
    if channels == 0 {
        return Err(usage("channels must be at least 1".into()));
    }
    let model = Model::parse_at_rate(model, rate).map_err(|e| py_err(Error::Process(e)))?;
    let cols = py
        .detach(|| simulate::simulate_channels(&model, n, rate, seed, channels))
        .map_err(py_err)?;
    let flat: Vec<f64> = cols.into_iter().flatten().collect();
    let arr = Array2::from_shape_vec((n, channels).f(), flat)
        .map_err(|e| usage(format!("simulate: {e}")))?;
    Ok(arr.into_pyarray(py))
}

/// The theoretical Allan variance of `model` (every parameter given) at `rate` Hz on the
/// scale grid `scales` made for `n` samples: the `imunoise theory --format json` document.
#[pyfunction]
fn theory_json(model: &str, rate: f64, scales: &str, n: usize) -> PyResult<String> {
    let rate = check_rate(rate)?;
    let model = Model::parse_at_rate(model, rate).map_err(|e| py_err(Error::Process(e)))?;
    let ms = estimate::parse_scales(scales)
        .map_err(|e| usage(format!("scales: {e}")))?
        .cluster_sizes(n)
        .map_err(|e| usage(format!("scales: {e}")))?;
    json_string(&theory::curves(&model, rate, &ms).map_err(py_err)?)
}

/// A noise model: parsed from text such as "WN(sigma2=1e-4) + RW + AR1".
#[pyclass(module = "imunoise._imunoise", frozen, eq, str)]
#[derive(PartialEq)]
struct NativeModel {
    model: Model,
}

impl std::fmt::Display for NativeModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.model)
    }
}

#[pymethods]
impl NativeModel {
    #[new]
    fn new(text: &str) -> PyResult<Self> {
        Ok(NativeModel {
            model: text.parse().map_err(|e| py_err(Error::Process(e)))?,
        })
    }

    /// Each component as text, in order.
    fn components(&self) -> Vec<String> {
        self.model
            .components()
            .iter()
            .map(|c| c.to_string())
            .collect()
    }

    /// Total number of parameters.
    fn n_params(&self) -> usize {
        self.model.n_params()
    }

    /// True when every parameter has a value (the model can be simulated).
    fn is_complete(&self) -> bool {
        self.model.processes().is_ok()
    }
}

/// The read specification from Python's keyword arguments (the command's input flags).
#[allow(clippy::too_many_arguments)]
fn input_spec(
    path: std::path::PathBuf,
    rate: Option<f64>,
    topic: Option<Vec<String>>,
    columns: Option<String>,
    binary: Option<&str>,
    channels: Option<usize>,
    scale: Option<f64>,
    names: Option<String>,
    unit: Option<String>,
    time_column: Option<String>,
    time_unit: &str,
    gaps: &str,
) -> PyResult<read::Input> {
    use clap::ValueEnum;
    if let Some(r) = rate {
        check_rate(r)?;
    }
    Ok(read::Input {
        rate,
        columns,
        binary: binary
            .map(|b| b.parse::<imunoise::io::BinaryType>())
            .transpose()
            .map_err(|e| usage(format!("binary: {e}")))?,
        channels,
        scale,
        names,
        unit,
        topic: topic.unwrap_or_default(),
        time_column,
        time_unit: read::TimeUnit::from_str(time_unit, true)
            .map_err(|e| usage(format!("time_unit: {e}")))?,
        gaps: imunoise::logs::GapPolicy::from_str(gaps, true)
            .map_err(|e| usage(format!("gaps: {e}")))?,
        ..read::Input::new(path)
    })
}

/// Reads a file through the command's readers: (samples as a Fortran-ordered (n, channels)
/// array, names, units, rate in Hz, topic, timing as JSON or None, file).
#[pyfunction]
#[pyo3(signature = (path, rate=None, topic=None, columns=None, binary=None, channels=None,
    scale=None, names=None, unit=None, time_column=None, time_unit="s", gaps="refuse"))]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
fn read_file<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    rate: Option<f64>,
    topic: Option<Vec<String>>,
    columns: Option<String>,
    binary: Option<&str>,
    channels: Option<usize>,
    scale: Option<f64>,
    names: Option<String>,
    unit: Option<String>,
    time_column: Option<String>,
    time_unit: &str,
    gaps: &str,
) -> PyResult<(
    Bound<'py, PyArray2<f64>>,
    Vec<String>,
    Vec<String>,
    Option<f64>,
    Option<String>,
    Option<String>,
    String,
)> {
    let spec = input_spec(
        path,
        rate,
        topic,
        columns,
        binary,
        channels,
        scale,
        names,
        unit,
        time_column,
        time_unit,
        gaps,
    )?;
    let table = py
        .detach(|| spec.read(&imunoise::Ui::quiet()))
        .map_err(py_err)?;
    let units: Vec<String> = spec
        .units(&table)
        .map_err(py_err)?
        .iter()
        .map(|u| match serde_json::to_value(u) {
            // the unit as results.json spells it ("deg/s", "m/s^2")
            Ok(serde_json::Value::String(s)) => s,
            _ => u.to_string(),
        })
        .collect();
    let timing = match &table.timing {
        Some(t) => Some(json_string(t)?),
        None => None,
    };
    let (n, k) = (table.n_rows(), table.columns.len());
    let flat: Vec<f64> = table
        .columns
        .iter()
        .flat_map(|c| c.iter().copied())
        .collect();
    let arr = Array2::from_shape_vec((n, k).f(), flat).map_err(|e| usage(format!("read: {e}")))?;
    Ok((
        arr.into_pyarray(py),
        table.names,
        units,
        table.rate_hz,
        table.topic,
        timing,
        table.file,
    ))
}

/// The analysis settings from Python's keyword arguments (the command's flags).
#[allow(clippy::too_many_arguments)]
fn analyze_settings(
    model: &str,
    method: &str,
    select: bool,
    bootstrap: usize,
    weighting: &str,
    seed: u64,
    alpha: f64,
    robust: bool,
    efficiency: f64,
    record_halfwidth: f64,
    tau: (Option<f64>, Option<f64>),
) -> PyResult<analyze::AnalyzeSettings> {
    let settings = analyze::AnalyzeSettings {
        // `select` is the command's `!--no-select`; the fit's own flag stays off as there
        fit: fit_settings(model, method, false, weighting, bootstrap, seed, alpha, tau)?,
        select,
        robust,
        efficiency,
        record_halfwidth,
    };
    // checked before any file is read
    settings.check().map_err(py_err)?;
    Ok(settings)
}

fn run_analysis(
    py: Python<'_>,
    table: Table,
    units: Vec<Unit>,
    settings: &analyze::AnalyzeSettings,
    out: Option<std::path::PathBuf>,
) -> PyResult<String> {
    let doc = py
        .detach(|| {
            let ui = imunoise::Ui::quiet();
            if let Some(dir) = &out {
                imunoise::output::create_dir(dir, "out")?;
            }
            let a = analyze::analyze(table, units, settings, &ui)?;
            if let Some(dir) = &out {
                a.write_report(dir, &ui)?;
            }
            a.results_json()
        })
        .map_err(py_err)?;
    json_string(&doc)
}

/// `imunoise analyze` on a file: the `results.json` document as a string (and the report
/// folder in `out` when given).
#[pyfunction]
#[pyo3(signature = (path, out, model, method, select, bootstrap, weighting, seed, alpha,
    robust, efficiency, record_halfwidth, rate=None, topic=None, columns=None, binary=None,
    channels=None, scale=None, names=None, unit=None, time_column=None, time_unit="s",
    gaps="refuse", tau_min=None, tau_max=None))]
#[allow(clippy::too_many_arguments)]
fn analyze_file(
    py: Python<'_>,
    path: std::path::PathBuf,
    out: Option<std::path::PathBuf>,
    model: &str,
    method: &str,
    select: bool,
    bootstrap: usize,
    weighting: &str,
    seed: u64,
    alpha: f64,
    robust: bool,
    efficiency: f64,
    record_halfwidth: f64,
    rate: Option<f64>,
    topic: Option<String>,
    columns: Option<String>,
    binary: Option<&str>,
    channels: Option<usize>,
    scale: Option<f64>,
    names: Option<String>,
    unit: Option<String>,
    time_column: Option<String>,
    time_unit: &str,
    gaps: &str,
    tau_min: Option<f64>,
    tau_max: Option<f64>,
) -> PyResult<String> {
    let settings = analyze_settings(
        model,
        method,
        select,
        bootstrap,
        weighting,
        seed,
        alpha,
        robust,
        efficiency,
        record_halfwidth,
        (tau_min, tau_max),
    )?;
    let spec = input_spec(
        path,
        rate,
        topic.map(|t| vec![t]),
        columns,
        binary,
        channels,
        scale,
        names,
        unit,
        time_column,
        time_unit,
        gaps,
    )?;
    let (table, units) = py
        .detach(|| {
            let table = spec.read(&imunoise::Ui::quiet())?;
            let units = spec.units(&table)?;
            Ok::<_, Error>((table, units))
        })
        .map_err(py_err)?;
    run_analysis(py, table, units, &settings, out)
}

/// `imunoise analyze` on an array's channels: the `results.json` document as a string.
#[pyfunction]
#[pyo3(signature = (x, rate, out, model, method, select, bootstrap, weighting, seed, alpha,
    robust, efficiency, record_halfwidth, names=None, unit=None, tau_min=None, tau_max=None))]
#[allow(clippy::too_many_arguments)]
fn analyze_array(
    py: Python<'_>,
    x: &Bound<'_, PyAny>,
    rate: f64,
    out: Option<std::path::PathBuf>,
    model: &str,
    method: &str,
    select: bool,
    bootstrap: usize,
    weighting: &str,
    seed: u64,
    alpha: f64,
    robust: bool,
    efficiency: f64,
    record_halfwidth: f64,
    names: Option<Vec<String>>,
    unit: Option<&str>,
    tau_min: Option<f64>,
    tau_max: Option<f64>,
) -> PyResult<String> {
    let settings = analyze_settings(
        model,
        method,
        select,
        bootstrap,
        weighting,
        seed,
        alpha,
        robust,
        efficiency,
        record_halfwidth,
        (tau_min, tau_max),
    )?;
    let table = array_table(x, rate, names)?;
    let units = units_of(&table.names, unit)?;
    run_analysis(py, table, units, &settings, out)
}

/// Bench support (python/bench/bench.py): the seconds each of `repeats` calls of the Rust
/// kernel `avar::allan_variance` takes on the borrowed samples of a contiguous 1-D float64
/// array, timed inside Rust (no Python, no JSON), so that `imunoise.avar` can be compared
/// with the kernel on the same data and the same compiled code.
#[pyfunction]
fn kernel_seconds(
    py: Python<'_>,
    x: PyReadonlyArray1<'_, f64>,
    rate: f64,
    scales: &str,
    ci: &str,
    repeats: usize,
) -> PyResult<Vec<f64>> {
    let cfg = avar_config(scales, ci, 0.05, "rate", "overlapping")?;
    let s = x
        .as_slice()
        .map_err(|_| usage("kernel_seconds needs a contiguous array".into()))?;
    py.detach(|| {
        (0..repeats)
            .map(|_| {
                let t = std::time::Instant::now();
                let av = imunoise::avar::allan_variance(s, rate, &cfg)?;
                std::hint::black_box(&av);
                Ok(t.elapsed().as_secs_f64())
            })
            .collect::<Result<Vec<f64>, imunoise::avar::AvarError>>()
    })
    .map_err(|e| py_err(Error::Avar(e)))
}

/// An online Allan variance of one or more channels (see `imunoise.Online`): fed chunks of
/// samples, its snapshot equals `imunoise.avar` of everything fed so far.
#[pyclass(module = "imunoise._imunoise")]
struct NativeOnline {
    inner: imunoise::avar::OnlineChannels,
    names: Vec<String>,
}

#[pymethods]
impl NativeOnline {
    #[new]
    #[pyo3(signature = (channels, rate, tau_max, scales, ci, alpha, names=None))]
    fn new(
        channels: usize,
        rate: f64,
        tau_max: f64,
        scales: &str,
        ci: &str,
        alpha: f64,
        names: Option<Vec<String>>,
    ) -> PyResult<Self> {
        let rate = check_rate(rate)?;
        if !(tau_max.is_finite() && tau_max > 0.0) {
            return Err(usage(format!("tau_max must be > 0 s, got {tau_max}")));
        }
        if channels == 0 {
            return Err(usage("channels must be at least 1".into()));
        }
        let cfg = avar_config(scales, ci, alpha, "rate", "overlapping")?;
        let max_m = ((tau_max * rate).floor() as u64).max(1);
        let inner = imunoise::avar::OnlineChannels::new(channels, rate, max_m, &cfg)
            .map_err(|e| usage(e.to_string()))?;
        Ok(NativeOnline {
            inner,
            names: channel_names(names, channels)?,
        })
    }

    /// Adds the next samples: a 1-D array (one channel) or a 2-D one (rows = samples).
    fn update(&mut self, py: Python<'_>, x: &Bound<'_, PyAny>) -> PyResult<()> {
        let ch = Channels::extract(x)?;
        let k = self.inner.channels().len();
        if ch.n_channels() != k {
            return Err(usage(format!(
                "update: {} channels given, the accumulator has {k}",
                ch.n_channels()
            )));
        }
        let (cols, _) = ch.columns();
        let slices: Vec<&[f64]> = cols.iter().map(|c| c.as_ref()).collect();
        let inner = &mut self.inner;
        py.detach(|| inner.update(&slices))
            .map_err(|e| py_err(Error::Avar(e)))
    }

    /// The Allan variance of everything fed so far, one curve per channel.
    fn snapshot(&self, py: Python<'_>) -> PyResult<Vec<Curve>> {
        let avs = py
            .detach(|| self.inner.snapshots())
            .map_err(|e| py_err(Error::Avar(e)))?;
        Ok(self
            .names
            .iter()
            .cloned()
            .zip(avs)
            .map(|(name, av)| Curve { name, av })
            .collect())
    }

    /// Samples fed so far (per channel).
    #[getter]
    fn n(&self) -> u64 {
        self.inner.channels()[0].len()
    }

    /// Bytes held by the accumulators (independent of the number of samples fed).
    fn heap_bytes(&self) -> usize {
        self.inner.channels().iter().map(|c| c.heap_bytes()).sum()
    }
}

#[pymodule]
fn _imunoise(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("ImunoiseError", py.get_type::<ImunoiseError>())?;
    m.add("InputError", py.get_type::<InputError>())?;
    m.add("UsageError", py.get_type::<UsageError>())?;
    m.add("ModelError", py.get_type::<ModelError>())?;
    m.add("EstimationError", py.get_type::<EstimationError>())?;
    m.add("OutputError", py.get_type::<OutputError>())?;
    m.add_class::<Curve>()?;
    m.add_class::<NativeModel>()?;
    m.add_class::<NativeOnline>()?;
    m.add_function(wrap_pyfunction!(avar, m)?)?;
    m.add_function(wrap_pyfunction!(avar_file, m)?)?;
    m.add_function(wrap_pyfunction!(fit_array, m)?)?;
    m.add_function(wrap_pyfunction!(fit_curves, m)?)?;
    m.add_function(wrap_pyfunction!(simulate_array, m)?)?;
    m.add_function(wrap_pyfunction!(theory_json, m)?)?;
    m.add_function(wrap_pyfunction!(read_file, m)?)?;
    m.add_function(wrap_pyfunction!(analyze_file, m)?)?;
    m.add_function(wrap_pyfunction!(analyze_array, m)?)?;
    m.add_function(wrap_pyfunction!(kernel_seconds, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
