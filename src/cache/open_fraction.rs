//! The open-fraction test of far-field caches: a record is used only at queries whose open
//! fraction is close to its own (documented on [`OpenFractionTest`], where users see it), and how
//! a record stores its open fraction.

use crate::error::{Error, Result};

/// The open-fraction test of far-field caches (the near/far decomposition of
/// [`gather::near_far`](crate::gather::near_far)).
///
/// A far-field record holds F, the mean radiance-weighted cosine over the directions its gather
/// found open beyond the reach, and its open fraction Vᵢ (the share of the gather's measure in
/// those directions). A query x adds `V·F` to its own near field, V its own open fraction. Where
/// x and the record see different parts of the hemisphere open (a pixel under a ledge next to
/// records in the open, the foot of a step), F is the mean over the wrong directions: the
/// real-scene benchmark found most of the error the metric leaves at such pixels
/// (`docs/real-scenes.md`). So a record i is not used at a query whose open fraction V differs
/// from its own by more than the tolerance:
///
/// ```text
///   |Vᵢ − V| > tolerance  ⇒  record i is not used
/// ```
///
/// The test needs both open fractions: records inserted without one
/// ([`Record::open_fraction`](super::Record::open_fraction) `None`) and lookups made without one
/// ([`Cache::lookup`](super::Cache::lookup) rather than
/// [`Cache::lookup_open`](super::Cache::lookup_open)) are never refused by it.
///
/// # Choosing the tolerance
/// V is a share, so the tolerance is dimensionless and scale-free. A gather of N rays estimates V
/// with a standard deviation of at most `0.5/√N` (less with stratification): 0.016 for the
/// 1,024 near rays of a query. A tolerance well above that (0.1-0.2) refuses records only where
/// the openness really changes; a tighter one makes records for the noise. Every refused record
/// leaves its pixels to other records or to new ones, so the test suits dense caches (the
/// benchmark's 8,192 records at 512 px) and costs coverage in sparse ones.
///
/// # Keeping coverage
/// By default a query whose covering records the test all refuses finds none (`NotFound`), and a
/// renderer that makes a record wherever a lookup fails makes one there: the refusals spend the
/// record budget where the open fraction changes, and at a fixed budget the open regions get
/// fewer, larger records. A [coverage tolerance](Self::coverage_tolerance) above the tolerance
/// lets such a query read the refused records whose open fraction is within the coverage
/// tolerance of its own instead (the leak guard still applies); it is `NotFound` only when none
/// is. With an infinite coverage tolerance ([`keeping_coverage`](Self::keeping_coverage)) the test
/// chooses among the records covering a query and never uncovers one, so records are made exactly
/// where they would be without it; with a finite one the test still makes records where the open
/// fraction changes by more than the coverage tolerance (the foot of a wall, the edge of a
/// ledge), not where it changes by a little more than the tolerance.
///
/// On the real-scene benchmark (`docs/real-scenes.md`, tolerance 0.1) an infinite coverage
/// tolerance gave lower errors than the test off at every record budget measured, and lower than
/// the default test below 5,000 to 8,000 records at 512 px (where the curves cross on the two
/// scenes); above that the default test's own records where the openness changes win. The best
/// finite coverage tolerance falls as the budget grows: 0.3 or more below about one record per 65
/// pixels, 0.15-0.25 from one per 44 pixels on; 0.25 came within 1.06x of the best of 0.15, 0.2,
/// 0.25, 0.3 and infinity at every budget from 4,000 to 14,000 records (two seeds; the page gives
/// the figures).
///
/// The test is off when the tolerance is infinite ([`OpenFractionTest::OFF`], the default).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OpenFractionTest {
    /// Largest difference of open fractions for a record to be used (dimensionless, ≥ 0; may be
    /// `f64::INFINITY`: off).
    pub tolerance: f64,
    /// Largest difference of open fractions for a refused record to be read at a query that no
    /// record passes within [`tolerance`](Self::tolerance) (dimensionless, ≥ 0; may be
    /// `f64::INFINITY`: every refused record). Any value not above the tolerance, such as the
    /// default 0, keeps nothing: such a query is `NotFound` (see "Keeping coverage" above).
    pub coverage_tolerance: f64,
}

impl Default for OpenFractionTest {
    /// [`OpenFractionTest::OFF`].
    fn default() -> Self {
        OpenFractionTest::OFF
    }
}

impl OpenFractionTest {
    /// The test switched off (infinite tolerance): every record passes.
    pub const OFF: OpenFractionTest = OpenFractionTest {
        tolerance: f64::INFINITY,
        coverage_tolerance: 0.0,
    };

    /// A test with the given tolerance that uncovers the queries whose covering records it all
    /// refuses (coverage tolerance 0).
    pub fn new(tolerance: f64) -> Self {
        OpenFractionTest {
            tolerance,
            coverage_tolerance: 0.0,
        }
    }

    /// The same test, keeping all coverage: a query whose covering records it all refuses reads
    /// them (an infinite coverage tolerance).
    pub fn keeping_coverage(self) -> Self {
        self.with_coverage_tolerance(f64::INFINITY)
    }

    /// The same test with the given coverage tolerance (see "Keeping coverage" above).
    pub fn with_coverage_tolerance(self, coverage_tolerance: f64) -> Self {
        OpenFractionTest {
            coverage_tolerance,
            ..self
        }
    }

    /// Whether the test is on and keeps some coverage: its coverage tolerance is above its
    /// tolerance.
    pub fn keeps_coverage(&self) -> bool {
        self.is_on() && self.coverage_tolerance > self.tolerance
    }

    /// Whether a query of open fraction `open` that found no record through the test reads the
    /// records it refused within the coverage tolerance (the test keeping coverage, and the query
    /// with an open fraction).
    pub(crate) fn reads_refused(&self, open: Option<f64>) -> bool {
        self.keeps_coverage() && open.is_some()
    }

    /// Whether the test refuses anything (a finite tolerance).
    pub fn is_on(&self) -> bool {
        self.tolerance.is_finite()
    }

    /// `InvalidArgument` unless the tolerance and the coverage tolerance are ≥ 0 (NaN and
    /// negative values are refused).
    pub fn validate(&self) -> Result<()> {
        if self.tolerance.is_nan() || self.tolerance < 0.0 {
            return Err(Error::InvalidArgument(format!(
                "the open-fraction tolerance must be >= 0 (or infinite: off), got {}",
                self.tolerance
            )));
        }
        if self.coverage_tolerance.is_nan() || self.coverage_tolerance < 0.0 {
            return Err(Error::InvalidArgument(format!(
                "the open-fraction coverage tolerance must be >= 0 (or infinite), got {}",
                self.coverage_tolerance
            )));
        }
        Ok(())
    }
}

/// Steps of the stored open fraction: V is kept as `1 + round(V·2³⁰)` in a record's head (0: no
/// open fraction), exact for the open fractions of gathers of up to 2³⁰ rays of equal measure.
const STEPS: f64 = (1u32 << 30) as f64;

/// Largest stored code (V = 1).
pub(crate) const CODE_MAX: u32 = (1u32 << 30) + 1;

/// The stored code of an open fraction (`None`: 0). `InvalidArgument` unless V is in [0, 1].
pub(crate) fn encode(open_fraction: Option<f64>) -> Result<u32> {
    match open_fraction {
        None => Ok(0),
        Some(v) if (0.0..=1.0).contains(&v) => Ok(1 + (v * STEPS).round() as u32),
        Some(v) => Err(Error::InvalidArgument(format!(
            "a record's open fraction must be in [0, 1], got {v}"
        ))),
    }
}

/// The open fraction of a stored code (0: `None`).
#[inline]
pub(crate) fn decode(code: u32) -> Option<f64> {
    (code != 0).then(|| (code - 1) as f64 / STEPS)
}

/// The open fractions a query of open fraction V admits: `[V − tolerance, V + tolerance]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct OpenWindow {
    lowest: f64,
    highest: f64,
}

impl OpenWindow {
    /// The window of a query with open fraction `open` (in [0, 1]) at `tolerance`; `None` when
    /// the tolerance is infinite (nothing refused).
    pub(crate) fn new(tolerance: f64, open: f64) -> Option<Self> {
        tolerance.is_finite().then_some(OpenWindow {
            lowest: open - tolerance,
            highest: open + tolerance,
        })
    }

    /// Whether a record whose stored code is `code` is refused (never one without an open
    /// fraction).
    #[inline]
    pub(crate) fn refuses(&self, code: u32) -> bool {
        match decode(code) {
            Some(v) => !(self.lowest..=self.highest).contains(&v),
            None => false,
        }
    }
}

/// `InvalidArgument` unless a query's open fraction is in [0, 1].
pub(crate) fn check_query_open_fraction(open: f64) -> Result<()> {
    if (0.0..=1.0).contains(&open) {
        Ok(())
    } else {
        Err(Error::InvalidArgument(format!(
            "the query's open fraction must be in [0, 1], got {open}"
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_round_trip_and_keep_none_apart_from_zero() {
        assert_eq!(encode(None).unwrap(), 0);
        assert_eq!(encode(Some(0.0)).unwrap(), 1);
        assert_eq!(encode(Some(1.0)).unwrap(), CODE_MAX);
        assert_eq!(decode(0), None);
        for k in 0..=4096u32 {
            let v = k as f64 / 4096.0;
            assert_eq!(decode(encode(Some(v)).unwrap()), Some(v), "{k}/4096");
        }
        // any open fraction within half a step
        let v = 0.123_456_789_012_345;
        assert!((decode(encode(Some(v)).unwrap()).unwrap() - v).abs() <= 0.5 / STEPS);
        for bad in [-1e-300, 1.000_000_001, f64::NAN, f64::INFINITY] {
            assert!(encode(Some(bad)).is_err(), "{bad}");
        }
    }

    #[test]
    fn the_window_refuses_differences_beyond_the_tolerance_only() {
        let window = OpenWindow::new(0.125, 0.5).unwrap();
        let refuses = |v: f64| window.refuses(encode(Some(v)).unwrap());
        assert!(!refuses(0.5) && !refuses(0.375) && !refuses(0.625));
        assert!(refuses(0.374) && refuses(0.626) && refuses(0.0) && refuses(1.0));
        assert!(
            !window.refuses(0),
            "a record without an open fraction passes"
        );
        // a zero tolerance admits the same open fraction only
        let exact = OpenWindow::new(0.0, 0.25).unwrap();
        assert!(!exact.refuses(encode(Some(0.25)).unwrap()));
        assert!(exact.refuses(encode(Some(0.25 + 1.0 / 1024.0)).unwrap()));
        assert_eq!(OpenWindow::new(OpenFractionTest::OFF.tolerance, 0.5), None);
    }

    #[test]
    fn validation_refuses_nan_and_negative() {
        assert!(OpenFractionTest::OFF.validate().is_ok() && !OpenFractionTest::OFF.is_on());
        assert!(OpenFractionTest::new(0.0).validate().is_ok());
        assert!(OpenFractionTest::new(0.0).is_on());
        for bad in [f64::NAN, -0.1, f64::NEG_INFINITY] {
            assert!(OpenFractionTest::new(bad).validate().is_err(), "{bad}");
        }
        assert!(check_query_open_fraction(0.0).is_ok() && check_query_open_fraction(1.0).is_ok());
        assert!(check_query_open_fraction(f64::NAN).is_err());
        assert!(check_query_open_fraction(1.5).is_err());
    }
}
