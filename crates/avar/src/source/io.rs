//! How the estimator reads a series: the traits a source of samples implements
//! ([`SampleSource`], and [`SampleWindow`] for the far walk's private copies), the in-memory
//! [`SliceSource`], and [`Io`], the streamed kernel's view of a source (its release hints and
//! windows).
//!
//! A leaf: the kernel reads its data through these without this module knowing the kernel.

/// A series of rate (or angle) samples read by position, possibly paged in on demand.
///
/// `samples()[k]` is sample k (0-based, any finite value, in the unit of the series); the
/// slice must stay valid and unchanged while the source lives. Reading a position may page it
/// in (a memory-mapped file); [`release`](SampleSource::release) is a hint that the estimator
/// does not need the samples of a range for a while, after which a file-backed source may drop
/// their resident pages (reading them again pages them in again). Release never changes a
/// value, so results do not depend on it.
///
/// ```
/// use avar::source::SampleSource;
/// struct Ramp(Vec<f64>);
/// impl SampleSource for Ramp {
///     fn samples(&self) -> &[f64] { &self.0 }
/// }
/// let r = Ramp(vec![1.0, 2.0, 3.0]);
/// assert_eq!(r.samples()[2], 3.0);
/// r.release(0, 3); // the default does nothing
/// ```
pub trait SampleSource: Sync {
    /// All samples, indexed by position.
    fn samples(&self) -> &[f64];
    /// The estimator is done with samples [lo, hi) for now (a hint; default: nothing).
    fn release(&self, lo: usize, hi: usize) {
        let _ = (lo, hi);
    }
    /// A private window for one thread of the far-scale walk, which reads small chunks spread
    /// over the whole series (a file-backed source reads them into its own pages with
    /// positioned reads, because mapping them would keep whole large page-cache folios of
    /// the file resident); `None` (the default): the walk reads [`samples`](Self::samples).
    fn window(&self) -> Option<Box<dyn SampleWindow + '_>> {
        None
    }
}

/// A position-indexed private copy of parts of a [`SampleSource`], for one thread.
///
/// ```
/// use avar::source::SampleWindow;
/// struct Copy { src: Vec<f64>, buf: Vec<f64> }
/// impl SampleWindow for Copy {
///     fn fill(&mut self, lo: usize, hi: usize) {
///         let hi = hi.min(self.src.len());
///         self.buf[lo..hi].copy_from_slice(&self.src[lo..hi]);
///     }
///     fn view(&self) -> &[f64] { &self.buf }
///     fn clear(&mut self) { self.buf.iter_mut().for_each(|v| *v = 0.0) }
/// }
/// let mut w = Copy { src: vec![1.0, 2.0, 3.0], buf: vec![0.0; 3] };
/// w.fill(1, 9);
/// assert_eq!(w.view(), &[0.0, 2.0, 3.0]);
/// ```
pub trait SampleWindow {
    /// Makes samples [lo, hi) (clamped to the series) readable in [`view`](Self::view).
    fn fill(&mut self, lo: usize, hi: usize);
    /// The window, as long as the series: `view()[k]` is sample k wherever filled since the
    /// last [`clear`](Self::clear) (elsewhere unspecified).
    fn view(&self) -> &[f64];
    /// Forgets what was filled.
    fn clear(&mut self);
    /// Starts a walk whose chunks lie at `origin` + multiples of `period` (samples): what was
    /// filled before is forgotten, and the window may place the samples anew (a file-backed
    /// window maps the walk's chunks onto the pages of the previous walk, so that no page is
    /// faulted in twice). Default: [`clear`](Self::clear).
    fn rebase(&mut self, origin: usize, period: usize) {
        let _ = (origin, period);
        self.clear();
    }
}

/// An in-memory slice as a [`SampleSource`] (release is a no-op).
///
/// ```
/// use avar::source::{SampleSource, SliceSource};
/// let v = [1.0, 2.0];
/// assert_eq!(SliceSource(&v).samples().len(), 2);
/// ```
#[derive(Debug, Clone, Copy)]
pub struct SliceSource<'a>(pub &'a [f64]);

impl SampleSource for SliceSource<'_> {
    fn samples(&self) -> &[f64] {
        self.0
    }
}

/// What the streamed kernel calls when it is done with the samples [lo, hi) for now (a hint
/// that lets a file-backed source drop their resident pages; no effect on any value).
pub(crate) type Release<'a> = &'a (dyn Fn(usize, usize) + Sync);

/// Makes a private window for one job of the far walk (see [`SampleWindow`]), or `None`.
pub(crate) type Windows<'a> = &'a (dyn Fn() -> Option<Box<dyn SampleWindow + 'a>> + Sync);

/// How the streamed kernel talks to a [`SampleSource`].
pub(crate) struct Io<'a> {
    pub(crate) release: Release<'a>,
    pub(crate) windows: Windows<'a>,
}

impl Io<'_> {
    /// No release hints, no windows (an in-memory slice).
    pub(crate) const NONE: Io<'static> = Io {
        release: &|_, _| {},
        windows: &|| None,
    };
}
