//! The one dispatch point for the vector kernels: which SIMD level the CPU has, which one the
//! kernels use, and the `IMUNOISE_SIMD` cap.
//!
//! Every kernel family of the crate (the buffered and streamed MOAV kernels, the stability
//! family, the robust estimator's loops) asks [`level`] which of its paths to run:
//!
//! * [`SimdLevel::Avx512`]: AVX-512F (x86-64 only; AVX2 and FMA are required with it);
//! * [`SimdLevel::Avx2`]: AVX2 and FMA (x86-64 only);
//! * [`SimdLevel::Scalar`]: the architecture's baseline instruction set: the streamed kernels'
//!   two-lane f64 vectors where the baseline has them (SSE2 on x86-64, NEON on aarch64: every CPU
//!   of those targets has them), the portable code elsewhere and in the other kernels.
//!
//! [`level`] is the lower of [`detected`] (what the CPU reports) and the cap read once from the
//! environment variable `IMUNOISE_SIMD` (`scalar`, `avx2` or `avx512`, case-insensitive): a cap
//! lowers the level, it never raises it above what the CPU has. An empty or unset variable means
//! no cap; any other value is reported once on stderr and ignored (the detected level is used).
//! A program may set the cap itself with [`set_cap`] before the first kernel runs.
//!
//! The paths give bit-identical results wherever the kernels' docs promise it (the MOAV kernels,
//! the streamed stability kernel): the cap changes the speed, not the values. No kernel uses a
//! fused multiply-add: each square is rounded, then added (acc ← acc + d·d), in the vector
//! paths as in the portable code (Rust never contracts a multiply and an add), so the same
//! operations in the same order run at every level and on every architecture.
//!
//! What `scalar` means: nothing beyond the instruction set every CPU of the build's target has.
//! On x86-64 that is SSE2 (part of the x86-64 baseline): the streamed kernels (the MOAV chunk
//! walk, the stability family's) run with SSE2 vectors of two f64, the other kernels run their
//! portable Rust code compiled for the baseline (which the compiler may vectorise with SSE2
//! pairs); no AVX, no FMA. So `IMUNOISE_SIMD=scalar` runs what an x86-64 CPU without AVX2 runs.
//! On aarch64 the same streamed kernels run with NEON vectors of two f64 (NEON is part of the
//! aarch64 baseline, and the only level there); on other architectures the portable code runs.
//!
//! ```
//! use avar::simd::{SimdLevel, capped, detected, level};
//! // the level in use never exceeds what the CPU has, and the cap only lowers it
//! assert!(level() <= detected());
//! assert_eq!(capped(SimdLevel::Avx2, Some(SimdLevel::Avx512)), SimdLevel::Avx2);
//! assert_eq!(capped(SimdLevel::Avx512, Some(SimdLevel::Scalar)), SimdLevel::Scalar);
//! assert_eq!("AVX2".parse::<SimdLevel>(), Ok(SimdLevel::Avx2));
//! ```

use std::fmt;
use std::str::FromStr;
use std::sync::OnceLock;
use std::sync::atomic::{AtomicU8, Ordering};

/// The name of the environment variable that caps the SIMD level.
pub const ENV_VAR: &str = "IMUNOISE_SIMD";

/// A SIMD level of the vector kernels, ordered from the narrowest to the widest.
///
/// ```
/// use avar::simd::SimdLevel;
/// assert!(SimdLevel::Scalar < SimdLevel::Avx2 && SimdLevel::Avx2 < SimdLevel::Avx512);
/// assert_eq!(SimdLevel::Avx512.to_string(), "avx512");
/// ```
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug)]
#[repr(u8)]
pub enum SimdLevel {
    /// The architecture's baseline: the streamed kernels' two-lane vectors of SSE2 on x86-64 and
    /// NEON on aarch64 (elsewhere the portable code compiled for the baseline), no AVX and no
    /// FMA; on other architectures the portable code.
    Scalar = 1,
    /// AVX2 (x86-64; detected together with FMA, which the kernels do not use).
    Avx2 = 2,
    /// AVX-512F (x86-64; the CPU also has AVX2 and FMA).
    Avx512 = 3,
}

impl SimdLevel {
    /// Every level, from the narrowest to the widest.
    pub const ALL: [SimdLevel; 3] = [SimdLevel::Scalar, SimdLevel::Avx2, SimdLevel::Avx512];

    /// The name used by `IMUNOISE_SIMD` and in reports: `scalar`, `avx2` or `avx512`.
    ///
    /// ```
    /// use avar::simd::SimdLevel;
    /// for l in SimdLevel::ALL {
    ///     assert_eq!(l.name().parse::<SimdLevel>(), Ok(l));
    /// }
    /// ```
    pub fn name(self) -> &'static str {
        match self {
            SimdLevel::Scalar => "scalar",
            SimdLevel::Avx2 => "avx2",
            SimdLevel::Avx512 => "avx512",
        }
    }

    fn from_u8(v: u8) -> Option<SimdLevel> {
        SimdLevel::ALL.into_iter().find(|l| *l as u8 == v)
    }
}

impl fmt::Display for SimdLevel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A value of `IMUNOISE_SIMD` (or `--simd`) that names no level.
///
/// ```
/// use avar::simd::SimdLevel;
/// let e = "sse2".parse::<SimdLevel>().unwrap_err();
/// assert!(e.to_string().contains("sse2"));
/// ```
#[derive(Clone, PartialEq, Eq, Debug)]
pub struct UnknownLevel(pub String);

impl fmt::Display for UnknownLevel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "unknown SIMD level {:?} (expected scalar, avx2 or avx512)",
            self.0
        )
    }
}

impl std::error::Error for UnknownLevel {}

impl FromStr for SimdLevel {
    type Err = UnknownLevel;
    /// `scalar`, `avx2` or `avx512`, case-insensitive, surrounding blanks ignored.
    fn from_str(s: &str) -> Result<SimdLevel, UnknownLevel> {
        let t = s.trim().to_ascii_lowercase();
        SimdLevel::ALL
            .into_iter()
            .find(|l| l.name() == t)
            .ok_or_else(|| UnknownLevel(s.to_string()))
    }
}

/// The widest level this CPU supports (asked once, then cached): [`SimdLevel::Avx512`] with
/// AVX-512F, AVX2 and FMA, else [`SimdLevel::Avx2`] with AVX2 and FMA, else
/// [`SimdLevel::Scalar`] (always on other architectures than x86-64).
///
/// ```
/// use avar::simd::{SimdLevel, detected};
/// #[cfg(not(target_arch = "x86_64"))]
/// assert_eq!(detected(), SimdLevel::Scalar);
/// assert!(detected() >= SimdLevel::Scalar);
/// ```
pub fn detected() -> SimdLevel {
    static DETECTED: OnceLock<SimdLevel> = OnceLock::new();
    *DETECTED.get_or_init(|| {
        #[cfg(target_arch = "x86_64")]
        {
            let avx2 = std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma");
            if avx2 && std::arch::is_x86_feature_detected!("avx512f") {
                return SimdLevel::Avx512;
            }
            if avx2 {
                return SimdLevel::Avx2;
            }
        }
        SimdLevel::Scalar
    })
}

/// Parses a value of `IMUNOISE_SIMD`: `Ok(None)` for an empty value (no cap), `Ok(Some(level))`
/// for a level's name, an error for anything else.
///
/// ```
/// use avar::simd::{SimdLevel, parse_cap};
/// assert_eq!(parse_cap(""), Ok(None));
/// assert_eq!(parse_cap(" Scalar "), Ok(Some(SimdLevel::Scalar)));
/// assert!(parse_cap("avx").is_err());
/// ```
pub fn parse_cap(value: &str) -> Result<Option<SimdLevel>, UnknownLevel> {
    if value.trim().is_empty() {
        return Ok(None);
    }
    value.parse().map(Some)
}

/// The level the kernels use for a CPU that has `detected` under the cap `cap`: the lower of the
/// two (no cap: `detected`). A pure function: [`level`] is `capped(detected(), cap())`.
///
/// ```
/// use avar::simd::{SimdLevel, capped};
/// for d in SimdLevel::ALL {
///     assert_eq!(capped(d, None), d);
///     for c in SimdLevel::ALL {
///         assert_eq!(capped(d, Some(c)), d.min(c));
///     }
/// }
/// ```
pub fn capped(detected: SimdLevel, cap: Option<SimdLevel>) -> SimdLevel {
    match cap {
        Some(c) => detected.min(c),
        None => detected,
    }
}

/// The cap, fixed once per process: by [`set_cap`] if it came first, else from `IMUNOISE_SIMD`
/// when first needed.
static CAP: OnceLock<Option<SimdLevel>> = OnceLock::new();

/// The cap in force: [`set_cap`]'s, else `IMUNOISE_SIMD` read once per process (`None`: unset,
/// empty or unknown; an unknown value is reported once on stderr).
///
/// ```
/// use avar::simd::{cap, level, detected, capped};
/// assert_eq!(level(), capped(detected(), cap()));
/// ```
pub fn cap() -> Option<SimdLevel> {
    *CAP.get_or_init(|| {
        let v = std::env::var_os(ENV_VAR)?;
        match parse_cap(&v.to_string_lossy()) {
            Ok(c) => c,
            Err(e) => {
                eprintln!("warning: {ENV_VAR}: {e}; ignored, using the detected level");
                None
            }
        }
    })
}

/// Sets the cap for this process (instead of `IMUNOISE_SIMD`; `None`: no cap), if no kernel
/// has asked for the level yet; else returns the cap already in force as the error. For
/// programs that take the cap as an option (`cargo xtask avar-speed --simd LEVEL`).
///
/// ```
/// use avar::simd::{cap, set_cap};
/// let first = cap(); // fixes the cap
/// assert_eq!(set_cap(None), Err(first));
/// ```
pub fn set_cap(cap: Option<SimdLevel>) -> Result<(), Option<SimdLevel>> {
    CAP.set(cap).map_err(|_| *CAP.get().expect("set"))
}

/// The level every kernel dispatches to: [`detected`] capped by [`cap`] (`IMUNOISE_SIMD`).
/// Fixed for the life of the process.
///
/// ```
/// use avar::simd::{level, detected};
/// assert!(level() <= detected());
/// ```
#[inline]
pub fn level() -> SimdLevel {
    capped(detected(), cap())
}

/// Every level up to [`level`], narrowest first: the paths a test may compare on this host
/// under the current cap.
///
/// ```
/// use avar::simd::{SimdLevel, level, levels};
/// let l = levels();
/// assert_eq!(l[0], SimdLevel::Scalar);
/// assert_eq!(*l.last().unwrap(), level());
/// ```
pub fn levels() -> Vec<SimdLevel> {
    SimdLevel::ALL
        .into_iter()
        .filter(|l| *l <= level())
        .collect()
}

/// The highest level any kernel of this process has run a vector path at (0: none yet).
static HIGHEST: AtomicU8 = AtomicU8::new(0);

/// Records that a kernel is about to run its path of level `l` (called where each vector path is
/// entered). A relaxed load, and a read-modify-write only the first time a higher level is seen,
/// so that hot loops pay nothing measurable and threads do not contend.
#[inline(always)]
pub(crate) fn note(l: SimdLevel) {
    if HIGHEST.load(Ordering::Relaxed) < l as u8 {
        HIGHEST.fetch_max(l as u8, Ordering::Relaxed);
    }
}

/// The highest SIMD level a kernel of this process has actually run (`None` before any kernel
/// ran). For tests: under a cap it must never exceed [`level`].
///
/// ```
/// use avar::{allan_variance, AvarConfig};
/// use avar::simd::{highest_used, level};
/// let x: Vec<f64> = (0..1000).map(|i| ((i * 7919) % 13) as f64).collect();
/// allan_variance(&x, 1.0, &AvarConfig::default()).unwrap();
/// assert!(highest_used().is_some_and(|h| h <= level()));
/// ```
#[doc(hidden)]
pub fn highest_used() -> Option<SimdLevel> {
    SimdLevel::from_u8(HIGHEST.load(Ordering::Relaxed))
}
