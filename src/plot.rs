//! Self-contained SVG plots (no system fonts, no external files): the log-log Allan
//! deviation with its CI band, fitted total, components and slope guides; a time-series
//! plot (min/max envelope per pixel); an ACF plot. With the default `png` feature the
//! SVGs are also rendered to PNG (resvg) with the embedded DejaVu Sans font.

use std::fmt::Write;

/// Plot width in pixels.
pub const WIDTH: f64 = 760.0;
/// Plot height in pixels.
pub const HEIGHT: f64 = 500.0;
const LEFT: f64 = 90.0;
const RIGHT: f64 = 24.0;
const TOP: f64 = 44.0;
const BOTTOM: f64 = 64.0;
const FONT: &str = "DejaVu Sans, Verdana, Arial, sans-serif";
/// Line colours of components (colour-blind-friendly Okabe–Ito palette).
const PALETTE: [&str; 7] = [
    "#E69F00", "#009E73", "#CC79A7", "#56B4E9", "#D55E00", "#0072B2", "#999999",
];

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A curve on the AD plot.
///
/// ```
/// use imunoise::plot::{AdevPlot, Series, adev_svg};
/// let fit = Series { label: "fitted model (gmwm)".into(), points: vec![(0.1, 1.0), (10.0, 0.1)] };
/// let plot = AdevPlot {
///     observed: vec![(0.1, 1.0, f64::NAN, f64::NAN), (10.0, 0.1, f64::NAN, f64::NAN)],
///     fitted: Some(fit),
///     ..Default::default()
/// };
/// // the label goes into the legend
/// assert!(adev_svg(&plot, "a").contains("fitted model (gmwm)"));
/// ```
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// (x, y) points.
    pub points: Vec<(f64, f64)>,
}

/// Everything drawn on an Allan-deviation plot.
///
/// ```
/// use imunoise::plot::{AdevPlot, Mark, Series, adev_svg};
/// // white noise: σ(τ) = 0.01/√τ, with a ±10 % band, and a fitted line on it
/// let taus = [0.01, 0.1, 1.0, 10.0];
/// let plot = AdevPlot {
///     title: "gyro x: Allan deviation".into(),
///     unit: "rad/s".into(),
///     observed: taus.iter().map(|&t| {
///         let s = 0.01 / f64::sqrt(t);
///         (t, s, 0.9 * s, 1.1 * s)
///     }).collect(),
///     fitted: Some(Series {
///         label: "fitted model (gmwm)".into(),
///         points: taus.iter().map(|&t| (t, 0.01 / f64::sqrt(t))).collect(),
///     }),
///     components: vec![Series {
///         label: "WN".into(),
///         points: vec![(0.01, 0.1), (10.0, 0.01 / 10f64.sqrt())],
///     }],
///     marks: vec![
///         Mark { label: "N = 0.0100".into(), tau: 1.0, sigma: 0.01 },
///         Mark { label: "far away".into(), tau: 1e6, sigma: 1e-5 },
///     ],
///     excluded: Vec::new(),
/// };
/// let svg = adev_svg(&plot, "gx");
/// assert!(svg.contains("gyro x: Allan deviation"));
/// assert!(svg.contains("Allan deviation σ(τ) [rad/s]"));
/// assert!(svg.contains("fitted model (gmwm)") && svg.contains(">WN<"));
/// // nothing observed: an empty plot
/// let empty = adev_svg(&AdevPlot::default(), "e");
/// assert!(empty.ends_with("</svg>\n") && !empty.contains("<circle"));
/// ```
#[derive(Debug, Clone, Default)]
pub struct AdevPlot {
    /// Title.
    pub title: String,
    /// Unit of the deviation, e.g. `°/s`.
    pub unit: String,
    /// Observed (τ, σ, σ_lo, σ_hi); bounds may be NaN when absent.
    pub observed: Vec<(f64, f64, f64, f64)>,
    /// The fitted total, if any.
    pub fitted: Option<Series>,
    /// Each fitted component.
    pub components: Vec<Series>,
    /// Read-off points marked on the curve (N at τ = 1 s, K at τ = 3 s, B at the minimum).
    pub marks: Vec<Mark>,
    /// τ (s) of the observed points left out of the fit (`--tau-min`/`--tau-max`): drawn grey.
    pub excluded: Vec<f64>,
}

/// A point marked and labelled on an Allan-deviation plot.
///
/// ```
/// # use imunoise::plot::{AdevPlot, Mark, Series, adev_svg};
/// # // white noise: σ(τ) = 0.01/√τ, with a ±10 % band, and a fitted line on it
/// # let taus = [0.01, 0.1, 1.0, 10.0];
/// # let plot = AdevPlot {
/// #     title: "gyro x: Allan deviation".into(),
/// #     unit: "rad/s".into(),
/// #     observed: taus.iter().map(|&t| {
/// #         let s = 0.01 / f64::sqrt(t);
/// #         (t, s, 0.9 * s, 1.1 * s)
/// #     }).collect(),
/// #     fitted: Some(Series {
/// #         label: "fitted model (gmwm)".into(),
/// #         points: taus.iter().map(|&t| (t, 0.01 / f64::sqrt(t))).collect(),
/// #     }),
/// #     components: vec![Series {
/// #         label: "WN".into(),
/// #         points: vec![(0.01, 0.1), (10.0, 0.01 / 10f64.sqrt())],
/// #     }],
/// #     marks: vec![
/// #         Mark { label: "N = 0.0100".into(), tau: 1.0, sigma: 0.01 },
/// #         Mark { label: "far away".into(), tau: 1e6, sigma: 1e-5 },
/// #     ],
/// #     excluded: Vec::new(),
/// # };
/// // `plot`: a white-noise curve with its CI band, a fit, a WN component and two marks
/// let svg = adev_svg(&plot, "gx");
/// // a mark inside the frame is drawn and labelled; one outside it is left out
/// assert!(svg.contains(">N = 0.0100</text>"));
/// assert!(!svg.contains("far away"));
/// assert_eq!(svg.matches("rotate(45").count(), 1);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Mark {
    /// Short label, e.g. `N = 3.1e-3`.
    pub label: String,
    /// τ (s).
    pub tau: f64,
    /// σ(τ) in the plot's unit.
    pub sigma: f64,
}

struct Frame {
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    logx: bool,
    logy: bool,
}

impl Frame {
    fn px(&self, x: f64) -> f64 {
        let (a, b, v) = if self.logx {
            (self.x0.log10(), self.x1.log10(), x.log10())
        } else {
            (self.x0, self.x1, x)
        };
        LEFT + (v - a) / (b - a) * (WIDTH - LEFT - RIGHT)
    }
    fn py(&self, y: f64) -> f64 {
        let (a, b, v) = if self.logy {
            (self.y0.log10(), self.y1.log10(), y.log10())
        } else {
            (self.y0, self.y1, y)
        };
        HEIGHT - BOTTOM - (v - a) / (b - a) * (HEIGHT - TOP - BOTTOM)
    }
}

fn header(s: &mut String, title: &str, id: &str) {
    let _ = write!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{HEIGHT}" viewBox="0 0 {WIDTH} {HEIGHT}" font-family="{FONT}" font-size="13">
<rect width="100%" height="100%" fill="white"/>
<defs><clipPath id="clip-{id}"><rect x="{LEFT}" y="{TOP}" width="{}" height="{}"/></clipPath></defs>
<text x="{}" y="26" text-anchor="middle" font-size="16" font-weight="bold">{}</text>
"#,
        WIDTH - LEFT - RIGHT,
        HEIGHT - TOP - BOTTOM,
        (LEFT + WIDTH - RIGHT) / 2.0,
        esc(title)
    );
}

fn fmt_tick(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if (1e-3..1e5).contains(&a) {
        let s = format!("{v:.6}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        let e = a.log10().floor() as i32;
        let m = v / 10f64.powi(e);
        if (m.abs() - 1.0).abs() < 1e-9 {
            format!("{}1e{e}", if v < 0.0 { "-" } else { "" })
        } else {
            format!("{m:.1}e{e}")
        }
    }
}

/// "Nice" linear ticks covering [a, b].
fn nice_ticks(a: f64, b: f64) -> Vec<f64> {
    let span = (b - a).abs().max(f64::MIN_POSITIVE);
    let raw = span / 6.0;
    let p = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|f| f * p)
        .find(|s| span / s <= 7.0)
        .unwrap_or(10.0 * p);
    let mut t = (a / step).ceil() * step;
    let mut out = Vec::new();
    while t <= b + 1e-9 * step {
        out.push(if t.abs() < 1e-12 * step { 0.0 } else { t });
        t += step;
    }
    out
}

fn axes(s: &mut String, f: &Frame, xlabel: &str, ylabel: &str) {
    let (l, r, t, b) = (LEFT, WIDTH - RIGHT, TOP, HEIGHT - BOTTOM);
    let grid = |s: &mut String, vals: Vec<(f64, bool)>, horizontal: bool| {
        for (v, major) in vals {
            let (stroke, w) = if major {
                ("#d0d0d0", 1.0)
            } else {
                ("#eeeeee", 0.7)
            };
            if horizontal {
                let y = f.py(v);
                let _ = writeln!(
                    s,
                    r#"<line x1="{l}" y1="{y:.2}" x2="{r}" y2="{y:.2}" stroke="{stroke}" stroke-width="{w}"/>"#
                );
                if major {
                    let _ = writeln!(
                        s,
                        r#"<text x="{}" y="{:.2}" text-anchor="end" dominant-baseline="middle">{}</text>"#,
                        l - 6.0,
                        y,
                        fmt_tick(v)
                    );
                }
            } else {
                let x = f.px(v);
                let _ = writeln!(
                    s,
                    r#"<line x1="{x:.2}" y1="{t}" x2="{x:.2}" y2="{b}" stroke="{stroke}" stroke-width="{w}"/>"#
                );
                if major {
                    let _ = writeln!(
                        s,
                        r#"<text x="{x:.2}" y="{}" text-anchor="middle">{}</text>"#,
                        b + 18.0,
                        fmt_tick(v)
                    );
                }
            }
        }
    };
    let ticks = |a: f64, bb: f64, log: bool| -> Vec<(f64, bool)> {
        if log {
            let mut v = Vec::new();
            let (e0, e1) = (a.log10().floor() as i32, bb.log10().ceil() as i32);
            let every = ((e1 - e0) / 8 + 1).max(1);
            for e in e0..=e1 {
                for k in 1..10 {
                    let x = k as f64 * 10f64.powi(e);
                    if x >= a * (1.0 - 1e-9) && x <= bb * (1.0 + 1e-9) {
                        v.push((x, k == 1 && (e - e0) % every == 0));
                    }
                }
            }
            v
        } else {
            nice_ticks(a, bb).into_iter().map(|x| (x, true)).collect()
        }
    };
    grid(s, ticks(f.x0, f.x1, f.logx), false);
    grid(s, ticks(f.y0, f.y1, f.logy), true);
    let _ = writeln!(
        s,
        r##"<rect x="{l}" y="{t}" width="{}" height="{}" fill="none" stroke="#333" stroke-width="1"/>"##,
        r - l,
        b - t
    );
    let _ = writeln!(
        s,
        r#"<text x="{}" y="{}" text-anchor="middle" font-size="14">{}</text>"#,
        (l + r) / 2.0,
        HEIGHT - 16.0,
        esc(xlabel)
    );
    let _ = writeln!(
        s,
        r#"<text transform="translate(20 {}) rotate(-90)" text-anchor="middle" font-size="14">{}</text>"#,
        (t + b) / 2.0,
        esc(ylabel)
    );
}

/// A polyline of the points inside the frame's axes (no clip of its own: the callers put the
/// curves of a plot in one group clipped to the frame, see [`clip_group`]).
fn polyline(s: &mut String, f: &Frame, pts: &[(f64, f64)], style: &str) {
    let mut d = String::new();
    for &(x, y) in pts {
        if x.is_finite() && y.is_finite() && (!f.logy || y > 0.0) && (!f.logx || x > 0.0) {
            let _ = write!(d, "{:.2},{:.2} ", f.px(x), f.py(y));
        }
    }
    let _ = writeln!(s, r#"<polyline points="{d}" fill="none" {style}/>"#);
}

/// Opens the group of a plot's curves, clipped to the frame. One clipped group instead of a
/// clip per curve: a PNG renderer draws each clipped element into a layer of its own (the
/// Allan-deviation plot of a 6-axis analysis took 57 ms to render with ten clips, 30 ms with
/// one).
fn clip_group(s: &mut String, id: &str) {
    let _ = writeln!(s, r#"<g clip-path="url(#clip-{id})">"#);
}

fn legend(s: &mut String, items: &[(String, String)]) {
    let x = LEFT + 12.0;
    let mut y = TOP + 14.0;
    let w = items
        .iter()
        .map(|(t, _)| t.chars().count())
        .max()
        .unwrap_or(0) as f64
        * 7.2
        + 44.0;
    let _ = writeln!(
        s,
        r##"<rect x="{}" y="{}" width="{w:.0}" height="{}" fill="white" fill-opacity="0.85" stroke="#bbb"/>"##,
        x - 6.0,
        y - 12.0,
        items.len() as f64 * 18.0 + 6.0
    );
    for (text, style) in items {
        let _ = writeln!(
            s,
            r#"<line x1="{x}" y1="{y}" x2="{}" y2="{y}" {style}/><text x="{}" y="{}" font-size="12">{}</text>"#,
            x + 26.0,
            x + 32.0,
            y + 4.0,
            esc(text)
        );
        y += 18.0;
    }
}

/// The log-log Allan deviation plot as an SVG document.
///
/// ```
/// # use imunoise::plot::{AdevPlot, Mark, Series, adev_svg};
/// # // white noise: σ(τ) = 0.01/√τ, with a ±10 % band, and a fitted line on it
/// # let taus = [0.01, 0.1, 1.0, 10.0];
/// # let plot = AdevPlot {
/// #     title: "gyro x: Allan deviation".into(),
/// #     unit: "rad/s".into(),
/// #     observed: taus.iter().map(|&t| {
/// #         let s = 0.01 / f64::sqrt(t);
/// #         (t, s, 0.9 * s, 1.1 * s)
/// #     }).collect(),
/// #     fitted: Some(Series {
/// #         label: "fitted model (gmwm)".into(),
/// #         points: taus.iter().map(|&t| (t, 0.01 / f64::sqrt(t))).collect(),
/// #     }),
/// #     components: vec![Series {
/// #         label: "WN".into(),
/// #         points: vec![(0.01, 0.1), (10.0, 0.01 / 10f64.sqrt())],
/// #     }],
/// #     marks: vec![
/// #         Mark { label: "N = 0.0100".into(), tau: 1.0, sigma: 0.01 },
/// #         Mark { label: "far away".into(), tau: 1e6, sigma: 1e-5 },
/// #     ],
/// #     excluded: Vec::new(),
/// # };
/// // `plot`: a white-noise curve with its CI band, a fit, a WN component and two marks
/// let svg = adev_svg(&plot, "gx");
/// assert!(svg.starts_with("<svg") && svg.ends_with("</svg>\n"));
/// // one dot per observed point, one CI band, the four IEEE 952 slope guides
/// assert_eq!(svg.matches("<circle").count(), 4);
/// assert_eq!(svg.matches("<polygon").count(), 1);
/// assert_eq!(svg.matches(r#"stroke-dasharray="2 4""#).count(), 4);
/// // the id keeps the clip paths of several plots in one page apart
/// assert!(svg.contains(r#"<clipPath id="clip-gx">"#));
/// ```
pub fn adev_svg(p: &AdevPlot, id: &str) -> String {
    let mut s = String::new();
    header(&mut s, &p.title, id);
    let obs: Vec<_> = p
        .observed
        .iter()
        .filter(|q| q.0 > 0.0 && q.1 > 0.0)
        .copied()
        .collect();
    if obs.is_empty() {
        s.push_str("</svg>\n");
        return s;
    }
    let xs = obs.iter().map(|q| q.0);
    let (mut x0, mut x1) = (
        xs.clone().fold(f64::INFINITY, f64::min),
        xs.fold(0.0, f64::max),
    );
    let mut ys: Vec<f64> = obs
        .iter()
        .flat_map(|q| [q.1, q.2, q.3])
        .filter(|v| v.is_finite() && *v > 0.0)
        .collect();
    if let Some(fit) = &p.fitted {
        ys.extend(fit.points.iter().map(|q| q.1).filter(|v| *v > 0.0));
    }
    let (ymin, ymax) = (
        ys.iter().copied().fold(f64::INFINITY, f64::min),
        ys.iter().copied().fold(0.0, f64::max),
    );
    x0 = 10f64.powf(x0.log10().floor());
    x1 = 10f64.powf(x1.log10().ceil());
    let y0 = 10f64.powf((ymin.log10() - 0.15).floor());
    let y1 = 10f64.powf((ymax.log10() + 0.15).ceil());
    let f = Frame {
        x0,
        x1,
        y0,
        y1,
        logx: true,
        logy: true,
    };
    let unit = if p.unit.is_empty() {
        String::new()
    } else {
        format!(" [{}]", p.unit)
    };
    axes(
        &mut s,
        &f,
        "averaging time τ [s]",
        &format!("Allan deviation σ(τ){unit}"),
    );
    // The curves, clipped to the frame as one group; the labels of the slope guides go on top.
    clip_group(&mut s, id);
    let mut labels = String::new();
    // Slope guides through the observed curve: −1, −½ from the first point; +½, +1 from the last.
    let first = obs[0];
    let last = *obs.last().expect("non-empty");
    for (slope, anchor, label) in [
        (-1.0, first, "−1"),
        (-0.5, first, "−1/2"),
        (0.5, last, "+1/2"),
        (1.0, last, "+1"),
    ] {
        let line: Vec<(f64, f64)> = [x0, x1]
            .iter()
            .map(|&x| (x, anchor.1 * (x / anchor.0).powf(slope)))
            .collect();
        polyline(
            &mut s,
            &f,
            &line,
            r##"stroke="#9a9a9a" stroke-width="1" stroke-dasharray="2 4""##,
        );
        // Label near the anchor, inside the plot.
        let tx = if slope < 0.0 {
            anchor.0 * 3.0
        } else {
            anchor.0 / 3.0
        };
        let ty = anchor.1 * (tx / anchor.0).powf(slope);
        if ty > y0 && ty < y1 && tx > x0 && tx < x1 {
            let _ = writeln!(
                labels,
                r##"<text x="{:.1}" y="{:.1}" font-size="11" fill="#777">slope {label}</text>"##,
                f.px(tx) + 4.0,
                f.py(ty) - 4.0
            );
        }
    }
    // CI band.
    let band: Vec<&(f64, f64, f64, f64)> = obs
        .iter()
        .filter(|q| q.2.is_finite() && q.3.is_finite())
        .collect();
    if band.len() >= 2 {
        let mut d = String::new();
        for q in &band {
            let _ = write!(d, "{:.2},{:.2} ", f.px(q.0), f.py(q.3));
        }
        for q in band.iter().rev() {
            let lo = if q.2 > 0.0 { q.2 } else { y0 };
            let _ = write!(d, "{:.2},{:.2} ", f.px(q.0), f.py(lo));
        }
        let _ = writeln!(
            s,
            r##"<polygon points="{d}" fill="#0072B2" fill-opacity="0.18" stroke="none"/>"##
        );
    }
    let mut items = vec![(
        "estimated AD with 95% CI".to_string(),
        r##"stroke="#0072B2" stroke-width="2""##.to_string(),
    )];
    for (i, c) in p.components.iter().enumerate() {
        let style = format!(
            r#"stroke="{}" stroke-width="1.6" stroke-dasharray="7 4""#,
            PALETTE[i % PALETTE.len()]
        );
        polyline(&mut s, &f, &c.points, &style);
        items.push((c.label.clone(), style));
    }
    let pts: Vec<(f64, f64)> = obs.iter().map(|q| (q.0, q.1)).collect();
    polyline(&mut s, &f, &pts, r##"stroke="#0072B2" stroke-width="2""##);
    for q in &pts {
        let left_out = p.excluded.iter().any(|t| (t / q.0 - 1.0).abs() < 1e-9);
        let _ = writeln!(
            s,
            r##"<circle cx="{:.2}" cy="{:.2}" r="2.8" fill="{}"/>"##,
            f.px(q.0),
            f.py(q.1),
            if left_out { "#b0b0b0" } else { "#0072B2" }
        );
    }
    if let Some(fit) = &p.fitted {
        let style = r##"stroke="#C00000" stroke-width="2""##.to_string();
        polyline(&mut s, &f, &fit.points, &style);
        items.insert(1, (fit.label.clone(), style));
    }
    s.push_str("</g>\n");
    s.push_str(&labels);
    for m in &p.marks {
        if !(m.tau > 0.0
            && m.sigma > 0.0
            && m.tau >= x0
            && m.tau <= x1
            && m.sigma >= y0
            && m.sigma <= y1)
        {
            continue;
        }
        let (cx, cy) = (f.px(m.tau), f.py(m.sigma));
        let _ = writeln!(
            s,
            r##"<rect x="{:.2}" y="{:.2}" width="9" height="9" transform="rotate(45 {cx:.2} {cy:.2})" fill="#E69F00" stroke="#222" stroke-width="0.8"/><text x="{:.1}" y="{:.1}" font-size="12" fill="#222">{}</text>"##,
            cx - 4.5,
            cy - 4.5,
            cx + 8.0,
            cy + 16.0,
            esc(&m.label)
        );
    }
    legend(&mut s, &items);
    s.push_str("</svg>\n");
    s
}

/// One curve of the stability overlay: (τ in s, deviation, lower, upper bound); bounds may be
/// NaN when absent.
///
/// ```
/// use imunoise::plot::{StabilitySeries, stability_svg};
/// let mdev = StabilitySeries {
///     label: "MDEV".into(),
///     points: vec![(1.0, 1.0, 0.8, 1.2), (2.0, 0.7, 0.5, 0.9), (4.0, 0.5, 0.4, 0.6)],
/// };
/// let svg = stability_svg("clock", std::slice::from_ref(&mdev), "m");
/// assert!(svg.contains("MDEV"));
/// assert_eq!(svg.matches("<polygon").count(), 1); // its CI band
/// ```
#[derive(Debug, Clone)]
pub struct StabilitySeries {
    /// Legend text (e.g. `MDEV`).
    pub label: String,
    /// (τ, σ, σ_lo, σ_hi).
    pub points: Vec<(f64, f64, f64, f64)>,
}

/// Several deviations (OADEV, MDEV, HDEV, …) overlaid on one log-log plot, each with its CI
/// band (when it has bounds), in the palette's colours, as an SVG document.
///
/// ```
/// use imunoise::plot::{stability_svg, StabilitySeries};
/// let a = StabilitySeries { label: "OADEV".into(), points: vec![(1.0, 1.0, 0.9, 1.1), (10.0, 0.3, 0.25, 0.36)] };
/// let b = StabilitySeries { label: "MDEV".into(), points: vec![(1.0, 1.0, f64::NAN, f64::NAN), (10.0, 0.2, f64::NAN, f64::NAN)] };
/// let svg = stability_svg("clock", &[a, b], "s");
/// assert!(svg.contains("OADEV") && svg.contains("MDEV"));
/// assert_eq!(svg.matches("<polygon").count(), 1); // one band: MDEV has no bounds
/// ```
pub fn stability_svg(title: &str, series: &[StabilitySeries], id: &str) -> String {
    let mut s = String::new();
    header(&mut s, title, id);
    let ok =
        |q: &&(f64, f64, f64, f64)| q.0 > 0.0 && q.1 > 0.0 && q.0.is_finite() && q.1.is_finite();
    let all: Vec<(f64, f64, f64, f64)> = series
        .iter()
        .flat_map(|c| c.points.iter().filter(ok).copied())
        .collect();
    if all.is_empty() {
        s.push_str("</svg>\n");
        return s;
    }
    let x0 = all.iter().map(|q| q.0).fold(f64::INFINITY, f64::min);
    let x1 = all.iter().map(|q| q.0).fold(0.0, f64::max);
    let ys: Vec<f64> = all
        .iter()
        .flat_map(|q| [q.1, q.2, q.3])
        .filter(|v| v.is_finite() && *v > 0.0)
        .collect();
    let ymin = ys.iter().copied().fold(f64::INFINITY, f64::min);
    let ymax = ys.iter().copied().fold(0.0, f64::max);
    let f = Frame {
        x0: 10f64.powf(x0.log10().floor()),
        x1: 10f64.powf(x1.log10().ceil()),
        y0: 10f64.powf((ymin.log10() - 0.15).floor()),
        y1: 10f64.powf((ymax.log10() + 0.15).ceil()),
        logx: true,
        logy: true,
    };
    axes(&mut s, &f, "averaging time τ [s]", "deviation σ(τ)");
    let mut items = Vec::new();
    clip_group(&mut s, id);
    for (i, c) in series.iter().enumerate() {
        let colour = PALETTE[(i + 5) % PALETTE.len()];
        let obs: Vec<(f64, f64, f64, f64)> = c.points.iter().filter(ok).copied().collect();
        let band: Vec<&(f64, f64, f64, f64)> = obs
            .iter()
            .filter(|q| q.2.is_finite() && q.3.is_finite())
            .collect();
        if band.len() >= 2 {
            let mut d = String::new();
            for q in &band {
                let _ = write!(d, "{:.2},{:.2} ", f.px(q.0), f.py(q.3));
            }
            for q in band.iter().rev() {
                let lo = if q.2 > 0.0 { q.2 } else { f.y0 };
                let _ = write!(d, "{:.2},{:.2} ", f.px(q.0), f.py(lo));
            }
            let _ = writeln!(
                s,
                r##"<polygon points="{d}" fill="{colour}" fill-opacity="0.15" stroke="none"/>"##
            );
        }
        let style = format!(r#"stroke="{colour}" stroke-width="2""#);
        let pts: Vec<(f64, f64)> = obs.iter().map(|q| (q.0, q.1)).collect();
        polyline(&mut s, &f, &pts, &style);
        for q in &pts {
            let _ = writeln!(
                s,
                r##"<circle cx="{:.2}" cy="{:.2}" r="2.6" fill="{colour}"/>"##,
                f.px(q.0),
                f.py(q.1)
            );
        }
        items.push((c.label.clone(), style));
    }
    s.push_str("</g>\n");
    legend(&mut s, &items);
    s.push_str("</svg>\n");
    s
}

/// A time-series plot (hours on the x axis when longer than 2 h) as SVG: the min/max
/// envelope of the samples in each of ~700 columns, so every sample is represented.
///
/// ```
/// use imunoise::plot::timeseries_svg;
/// let x: Vec<f64> = (0..10_000).map(|i| (i as f64 * 0.01).sin()).collect();
/// // 10 000 samples at 1 Hz: 2.8 h, in hours; at 100 Hz: 100 s, in seconds
/// let long = timeseries_svg("gyro x", "rad/s", &x, 1.0, "ts");
/// assert!(long.contains("time [h]") && long.contains("value [rad/s]"));
/// assert!(timeseries_svg("gyro x", "rad/s", &x, 100.0, "ts").contains("time [s]"));
/// // many samples per column: the envelope is drawn as one filled path
/// assert_eq!(long.matches("<path").count(), 1);
/// ```
pub fn timeseries_svg(title: &str, unit: &str, x: &[f64], rate_hz: f64, id: &str) -> String {
    let mut s = String::new();
    header(&mut s, title, id);
    let n = x.len();
    let dur = n as f64 / rate_hz;
    let (scale, tl) = if dur > 7200.0 {
        (1.0 / 3600.0, "time [h]")
    } else if dur > 600.0 {
        (1.0 / 60.0, "time [min]")
    } else {
        (1.0, "time [s]")
    };
    let cols = 700.min(n.max(1));
    let mut env = Vec::with_capacity(cols);
    for c in 0..cols {
        let a = c * n / cols;
        let b = ((c + 1) * n / cols).max(a + 1).min(n);
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for &v in &x[a..b] {
            lo = lo.min(v);
            hi = hi.max(v);
        }
        env.push((a as f64 / rate_hz * scale, lo, hi));
    }
    let ymin = env.iter().map(|e| e.1).fold(f64::INFINITY, f64::min);
    let ymax = env.iter().map(|e| e.2).fold(f64::NEG_INFINITY, f64::max);
    let pad = ((ymax - ymin) * 0.05).max(1e-300);
    let f = Frame {
        x0: 0.0,
        x1: (dur * scale).max(1e-12),
        y0: ymin - pad,
        y1: ymax + pad,
        logx: false,
        logy: false,
    };
    let unit = if unit.is_empty() {
        String::new()
    } else {
        format!(" [{unit}]")
    };
    axes(&mut s, &f, tl, &format!("value{unit}"));
    let mut d = String::new();
    if n >= 2 * cols {
        // dense: the min/max envelope as one filled band (upper edge left to right, lower
        // edge back), at least 1.2 px thick; it looks like the stems of every column side by
        // side, and rasterizes several times faster than as many stroked stems
        for (k, e) in env.iter().enumerate() {
            let (lo, hi) = (f.py(e.1), f.py(e.2));
            let mid = 0.5 * (lo + hi);
            let top = hi.min(mid - 0.6);
            let _ = write!(
                d,
                "{}{:.2},{:.2}",
                if k == 0 { 'M' } else { 'L' },
                f.px(e.0),
                top
            );
        }
        for e in env.iter().rev() {
            let (lo, hi) = (f.py(e.1), f.py(e.2));
            let mid = 0.5 * (lo + hi);
            let _ = write!(d, "L{:.2},{:.2}", f.px(e.0), lo.max(mid + 0.6));
        }
        d.push('Z');
        let _ = writeln!(
            s,
            r##"<path d="{d}" fill="#0072B2" stroke="none" clip-path="url(#clip-{id})"/>"##
        );
    } else {
        // sparse: a short stem per sample
        for e in &env {
            let _ = write!(
                d,
                "M{:.2},{:.2}V{:.2}",
                f.px(e.0),
                f.py(e.1),
                f.py(e.2) - 0.5
            );
        }
        let _ = writeln!(
            s,
            r##"<path d="{d}" stroke="#0072B2" stroke-width="1.2" fill="none" clip-path="url(#clip-{id})"/>"##
        );
    }
    s.push_str("</svg>\n");
    s
}

/// An ACF plot (stems) with the ±1.96/√n band of a white noise, as SVG.
///
/// ```
/// use imunoise::plot::acf_svg;
/// // an AR(1)-like ACF, 0.9^h, of a series of 10 000 samples at 100 Hz
/// let acf: Vec<f64> = (0..50).map(|h| 0.9f64.powi(h)).collect();
/// let svg = acf_svg("gyro x: sample ACF", &acf, 10_000, 100.0, "acf");
/// assert!(svg.contains("gyro x: sample ACF") && svg.contains("lag [s]"));
/// // the two lines of the white-noise band at ±1.96/√n
/// assert_eq!(svg.matches(r##"stroke="#C00000" stroke-dasharray="5 4""##).count(), 2);
/// ```
pub fn acf_svg(title: &str, acf: &[f64], n: usize, rate_hz: f64, id: &str) -> String {
    let mut s = String::new();
    header(&mut s, title, id);
    let lags = acf.len().max(2);
    let f = Frame {
        x0: 0.0,
        x1: (lags - 1) as f64 / rate_hz,
        y0: acf.iter().copied().fold(0.0, f64::min).min(-0.1) - 0.05,
        y1: 1.05,
        logx: false,
        logy: false,
    };
    axes(&mut s, &f, "lag [s]", "autocorrelation");
    let band = 1.96 / (n as f64).sqrt();
    for b in [band, -band] {
        let _ = writeln!(
            s,
            r##"<line x1="{LEFT}" y1="{y:.2}" x2="{}" y2="{y:.2}" stroke="#C00000" stroke-dasharray="5 4"/>"##,
            WIDTH - RIGHT,
            y = f.py(b)
        );
    }
    // one stem per lag, or, with more lags than pixel columns of the frame, one per column
    // from 0 to the column's extreme values (what the overlapping stems would cover): a
    // stroked stem costs its rasterization whether or not it is hidden by its neighbours
    let cols = (WIDTH - LEFT - RIGHT) as usize;
    let mut d = String::new();
    // per column, a little wider than the column so that no seam shows between them
    let mut width = 1.3;
    if acf.len() <= cols {
        width = 1.0;
        for (h, &r) in acf.iter().enumerate() {
            let x = f.px(h as f64 / rate_hz);
            let _ = write!(d, "M{x:.2},{:.2}V{:.2}", f.py(0.0), f.py(r));
        }
    } else {
        for c in 0..cols {
            let (a, b) = (c * acf.len() / cols, (c + 1) * acf.len() / cols);
            let (lo, hi) = acf[a..b]
                .iter()
                .fold((0.0f64, 0.0f64), |(lo, hi), &r| (lo.min(r), hi.max(r)));
            let x = f.px(a as f64 / rate_hz);
            let _ = write!(d, "M{x:.2},{:.2}V{:.2}", f.py(lo), f.py(hi));
        }
    }
    let _ = writeln!(
        s,
        r##"<path d="{d}" stroke="#0072B2" stroke-width="{width}" fill="none" clip-path="url(#clip-{id})"/>"##
    );
    s.push_str("</svg>\n");
    s
}

/// The fit check of one channel: the standardised residual z = ln(AV / fitted AV) / s of each
/// scale against τ (log axis), with the ±`z_crit` band of the CI (dashed); scales outside it
/// are drawn in red. Points with a non-finite z are left out.
///
/// ```
/// let svg = imunoise::plot::residuals_svg("gyro x: fit check", &[0.01, 0.1, 1.0], &[0.5, -3.0, 1.0], 1.96, "r0");
/// assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
/// assert_eq!(svg.matches("<circle").count(), 3);
/// assert_eq!(svg.matches("fill=\"#C00000\"").count(), 1); // one scale outside the band
/// ```
pub fn residuals_svg(title: &str, tau: &[f64], z: &[f64], z_crit: f64, id: &str) -> String {
    let mut s = String::new();
    header(&mut s, title, id);
    let pts: Vec<(f64, f64)> = tau
        .iter()
        .zip(z)
        .filter(|(t, z)| t.is_finite() && **t > 0.0 && z.is_finite())
        .map(|(&t, &z)| (t, z))
        .collect();
    let (t0, t1) = pts.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
        (a.min(p.0), b.max(p.0))
    });
    let (t0, t1) = if t0 < t1 {
        (t0 / 1.5, t1 * 1.5)
    } else {
        (0.1, 10.0)
    };
    let zmax = pts.iter().fold(z_crit, |m, p| m.max(p.1.abs())) * 1.1;
    let f = Frame {
        x0: t0,
        x1: t1,
        y0: -zmax,
        y1: zmax,
        logx: true,
        logy: false,
    };
    axes(&mut s, &f, "τ [s]", "standardised residual z");
    for b in [z_crit, -z_crit] {
        let _ = writeln!(
            s,
            r##"<line x1="{LEFT}" y1="{y:.2}" x2="{}" y2="{y:.2}" stroke="#555" stroke-dasharray="5 4"/>"##,
            WIDTH - RIGHT,
            y = f.py(b)
        );
    }
    let _ = writeln!(
        s,
        r##"<line x1="{LEFT}" y1="{y:.2}" x2="{}" y2="{y:.2}" stroke="#999"/>"##,
        WIDTH - RIGHT,
        y = f.py(0.0)
    );
    for &(t, z) in &pts {
        let colour = if z.abs() > z_crit {
            "#C00000"
        } else {
            "#0072B2"
        };
        let (x, y) = (f.px(t), f.py(z));
        let _ = writeln!(
            s,
            r##"<line x1="{x:.2}" y1="{:.2}" x2="{x:.2}" y2="{y:.2}" stroke="{colour}"/><circle cx="{x:.2}" cy="{y:.2}" r="4" fill="{colour}"/>"##,
            f.py(0.0)
        );
    }
    s.push_str("</svg>\n");
    s
}

/// Renders an SVG document to PNG bytes with the embedded DejaVu Sans font (no system
/// fonts are consulted), at `zoom` × the SVG's size.
///
/// ```
/// use imunoise::plot::{HEIGHT, WIDTH, svg_to_png, timeseries_svg};
/// let x: Vec<f64> = (0..1000).map(|i| (i as f64 * 0.05).sin()).collect();
/// let svg = timeseries_svg("gyro x", "rad/s", &x, 100.0, "ts");
/// let png = svg_to_png(&svg, 0.5)?;
/// assert_eq!(png[..8], *b"\x89PNG\r\n\x1a\n");
/// // width and height in the IHDR chunk, big-endian: the SVG's, times the zoom
/// let dim = |at: usize| u32::from_be_bytes(png[at..at + 4].try_into().unwrap());
/// assert_eq!((dim(16), dim(20)), ((WIDTH * 0.5) as u32, (HEIGHT * 0.5) as u32));
/// assert!(svg_to_png("not svg", 1.0).is_err());
/// # Ok::<(), String>(())
/// ```
#[cfg(feature = "png")]
pub fn svg_to_png(svg: &str, zoom: f32) -> Result<Vec<u8>, String> {
    use resvg::{tiny_skia, usvg};
    static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
    let mut opt = usvg::Options {
        font_family: "DejaVu Sans".into(),
        ..Default::default()
    };
    opt.fontdb_mut().load_font_data(FONT.to_vec());
    let tree = usvg::Tree::from_str(svg, &opt).map_err(|e| format!("SVG: {e}"))?;
    let size = tree
        .size()
        .to_int_size()
        .scale_by(zoom)
        .ok_or("empty SVG")?;
    let mut pixmap = tiny_skia::Pixmap::new(size.width(), size.height()).ok_or("PNG too large")?;
    resvg::render(
        &tree,
        tiny_skia::Transform::from_scale(zoom, zoom),
        &mut pixmap.as_mut(),
    );
    pixmap.encode_png().map_err(|e| format!("PNG: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_and_labels() {
        assert_eq!(nice_ticks(0.0, 10.0), [0.0, 2.0, 4.0, 6.0, 8.0, 10.0]);
        assert_eq!(fmt_tick(0.01), "0.01");
        assert_eq!(fmt_tick(1e-5), "1e-5");
        assert_eq!(fmt_tick(1000.0), "1000");
    }

    #[test]
    fn adev_svg_has_band_curves_and_labels() {
        let obs: Vec<(f64, f64, f64, f64)> = (0..10)
            .map(|j| {
                let t = 0.02 * 2f64.powi(j);
                let a = 0.01 / t.sqrt();
                (t, a, 0.9 * a, 1.1 * a)
            })
            .collect();
        let svg = adev_svg(
            &AdevPlot {
                title: "gyro_x".into(),
                unit: "°/s".into(),
                observed: obs.clone(),
                fitted: Some(Series {
                    label: "fit".into(),
                    points: obs.iter().map(|q| (q.0, q.1)).collect(),
                }),
                components: vec![],
                marks: vec![
                    Mark {
                        label: "N = 0.01".into(),
                        tau: 1.0,
                        sigma: 0.01,
                    },
                    // Outside the frame: not drawn.
                    Mark {
                        label: "K = 1".into(),
                        tau: 1e6,
                        sigma: 1.0,
                    },
                ],
                excluded: vec![0.02],
            },
            "t",
        );
        // the point left out of the fit is grey, the other nine blue
        assert_eq!(svg.matches(r##"r="2.8" fill="#b0b0b0""##).count(), 1);
        assert_eq!(svg.matches(r##"r="2.8" fill="#0072B2""##).count(), 9);
        assert!(svg.contains(">N = 0.01</text>"));
        assert!(!svg.contains("K = 1"));
        assert!(svg.contains("<polygon"));
        assert!(svg.contains("Allan deviation σ(τ) [°/s]"));
        assert!(svg.contains("slope −1/2"));
        assert_eq!(svg.matches("<circle").count(), 10);
        // the curves sit in one group clipped to the frame (one clip, not one per curve), the
        // slope labels after it
        assert_eq!(svg.matches("clip-path=").count(), 1);
        let open = svg.find(r#"<g clip-path="url(#clip-t)">"#).unwrap();
        let close = open + svg[open..].find("</g>").unwrap();
        let inside = &svg[open..close];
        assert_eq!(
            inside.matches("<polyline").count(),
            svg.matches("<polyline").count()
        );
        assert!(inside.contains("<polygon") && !inside.contains("slope"));
        assert!(svg[close..].contains("slope −1/2"));
    }

    /// With more lags than pixel columns, the ACF has one stem per column spanning 0 and the
    /// column's extremes (a lone spike still shows); with fewer, one stem per lag.
    #[test]
    fn acf_svg_has_a_stem_per_column_or_per_lag() {
        let cols = (WIDTH - LEFT - RIGHT) as usize;
        let mut acf = vec![0.01; 4000];
        acf[0] = 1.0;
        acf[1234] = -0.5;
        let svg = acf_svg("a", &acf, 1_000_000, 1000.0, "a");
        let path = |svg: &str| {
            let d0 = svg.find(r#"<path d=""#).unwrap() + 9;
            svg[d0..d0 + svg[d0..].find('"').unwrap()].to_string()
        };
        let d = path(&svg);
        assert_eq!(d.matches('M').count(), cols);
        let f = Frame {
            x0: 0.0,
            x1: 3.999,
            y0: -0.55,
            y1: 1.05,
            logx: false,
            logy: false,
        };
        // the column of lag 1234 reaches −0.5
        let c = 1234 * cols / 4000;
        let a = c * 4000 / cols;
        let stem = format!(
            "M{:.2},{:.2}V{:.2}",
            f.px(a as f64 / 1000.0),
            f.py(-0.5),
            f.py(0.01)
        );
        assert!(d.contains(&stem), "{stem}");
        let short = acf_svg("a", &acf[..100], 1_000_000, 1000.0, "b");
        assert_eq!(path(&short).matches('M').count(), 100);
    }

    /// A dense series is drawn as one filled band from its column minima and maxima, a sparse
    /// one as a stem per sample.
    #[test]
    fn timeseries_svg_is_a_band_when_dense() {
        let x: Vec<f64> = (0..100_000).map(|i| ((i * 7919) % 101) as f64).collect();
        let svg = timeseries_svg("x", "", &x, 100.0, "x");
        assert!(svg.contains(r##"fill="#0072B2" stroke="none""##));
        assert_eq!(svg.matches('Z').count(), 1);
        let sparse = timeseries_svg("x", "", &x[..500], 100.0, "y");
        assert!(sparse.contains(r##"stroke="#0072B2" stroke-width="1.2" fill="none""##));
    }
}
