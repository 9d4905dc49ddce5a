//! Amplitudes a(t): the dimensionless factor by which a load or a prescribed displacement
//! follows time, with its rate ȧ(t) and acceleration ä(t) (what prescribed velocities and
//! accelerations of moving supports need).
//!
//! A static analysis evaluates amplitudes at one time, [`STATIC_TIME`] (t = 1), so a ramp that
//! ends by then is at its full value.

use crate::base::error::{Error, Result};

/// The time (s) at which static analyses evaluate amplitudes: a ramp from 0 to 1 s is at its
/// full value there.
pub const STATIC_TIME: f64 = 1.0;

/// A dimensionless factor of time a(t) (time in seconds), with ȧ (1/s) and ä (1/s²).
#[derive(Debug, Clone, PartialEq)]
pub enum Amplitude {
    /// a(t) = c for all t; the default is c = 1 (the behaviour of data without an amplitude).
    Constant(f64),
    /// Tabulated points (tᵢ, aᵢ), built by [`Amplitude::table`]: linear between points,
    /// constant beyond the ends (a(t) = a₀ before t₀, the last value after the last time).
    /// ȧ is the slope of the segment holding t (the right one at a point, 0 beyond the ends);
    /// ä is 0 (its Dirac masses at the points are not represented).
    Table {
        /// Strictly increasing, finite times (s).
        times: Vec<f64>,
        /// The finite values at those times.
        values: Vec<f64>,
    },
    /// 0 before `start`, (t − start)/(end − start) between, 1 after (built by
    /// [`Amplitude::ramp`]).
    Ramp {
        /// t₀ (s).
        start: f64,
        /// t₁ > t₀ (s).
        end: f64,
    },
    /// The quintic smooth step 10s³ − 15s⁴ + 6s⁵ of s = (t − start)/(end − start) clamped to
    /// [0, 1]: 0 before, 1 after, C² (its rate and acceleration vanish at both ends, so a
    /// support started with it starts without a jump in velocity or acceleration). Built by
    /// [`Amplitude::smooth_step`].
    SmoothStep {
        /// t₀ (s).
        start: f64,
        /// t₁ > t₀ (s).
        end: f64,
    },
    /// A·sin(2π·f·(t − start) + φ) from `start` on, A·sin(φ) before (built by
    /// [`Amplitude::sine`]).
    Sine {
        /// A (dimensionless).
        amplitude: f64,
        /// f (Hz), ≥ 0.
        frequency_hz: f64,
        /// φ (radians).
        phase: f64,
        /// The time the oscillation starts (s).
        start: f64,
    },
}

impl Default for Amplitude {
    fn default() -> Self {
        Amplitude::Constant(1.0)
    }
}

fn finite(name: &str, value: f64) -> Result<f64> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(Error::invalid_parameter(name, value, "must be finite"))
    }
}

/// `(start, end)` checked: both finite, end > start, and the width end − start such that
/// 1/width^`power` is finite (the rate of a ramp divides by the width, the acceleration of a
/// smooth step by its square: a width of 1e-320 s would make them infinite).
fn interval(start: f64, end: f64, power: i32) -> Result<(f64, f64)> {
    finite("start", start)?;
    finite("end", end)?;
    if end <= start {
        return Err(Error::invalid_parameter(
            "end",
            end,
            format!("must be after start ({start})"),
        ));
    }
    let width = end - start;
    if !(width.is_finite() && width.powi(power).recip().is_finite()) {
        return Err(Error::invalid_parameter(
            "end",
            end,
            format!(
                "end − start = {width:e} s: its rate or acceleration (1/width^{power}) is not finite; use a width between {:e} and {:e} s",
                f64::MAX.powf(-1.0 / f64::from(power)),
                f64::MAX
            ),
        ));
    }
    Ok((start, end))
}

impl Amplitude {
    /// A table of points: [`Error::InvalidParameter`] naming the point unless there is at least
    /// one, times and values have equal length, all are finite and the times strictly increase.
    pub fn table(times: Vec<f64>, values: Vec<f64>) -> Result<Self> {
        if times.is_empty() || times.len() != values.len() {
            return Err(Error::invalid_parameter(
                "table",
                format!("{} times, {} values", times.len(), values.len()),
                "needs at least one point and as many values as times",
            ));
        }
        for (i, (&t, &a)) in times.iter().zip(&values).enumerate() {
            finite(&format!("time of point {i}"), t)?;
            finite(&format!("value of point {i}"), a)?;
            if i > 0 && t <= times[i - 1] {
                return Err(Error::invalid_parameter(
                    format!("time of point {i}"),
                    t,
                    format!(
                        "times must strictly increase (point {} is at {})",
                        i - 1,
                        times[i - 1]
                    ),
                ));
            }
            // The segment's rate ȧ = Δa/Δt must be a number: points 1e-320 s apart (or values
            // ±1e308 apart) would give an infinite rate, and an infinite load rate.
            if i > 0 {
                let (dt, da) = (t - times[i - 1], a - values[i - 1]);
                if !(dt.is_finite() && (da / dt).is_finite()) {
                    return Err(Error::invalid_parameter(
                        format!("time of point {i}"),
                        t,
                        format!(
                            "the segment from point {} (t = {:e}, a = {:e}) has slope Δa/Δt = {da:e}/{dt:e}, not finite; points must be far enough apart for a finite rate",
                            i - 1,
                            times[i - 1],
                            values[i - 1]
                        ),
                    ));
                }
            }
        }
        Ok(Amplitude::Table { times, values })
    }

    /// A ramp from 0 at `start` to 1 at `end` (s): both finite, end > start, its rate
    /// 1/(end − start) finite.
    pub fn ramp(start: f64, end: f64) -> Result<Self> {
        let (start, end) = interval(start, end, 1)?;
        Ok(Amplitude::Ramp { start, end })
    }

    /// The quintic smooth step from 0 at `start` to 1 at `end` (s): both finite, end > start,
    /// its acceleration scale 1/(end − start)² finite.
    pub fn smooth_step(start: f64, end: f64) -> Result<Self> {
        let (start, end) = interval(start, end, 2)?;
        Ok(Amplitude::SmoothStep { start, end })
    }

    /// A·sin(2πf(t − start) + φ): all finite, f ≥ 0 (Hz), the acceleration's scale
    /// |A|·(2πf)² finite.
    pub fn sine(amplitude: f64, frequency_hz: f64, phase: f64, start: f64) -> Result<Self> {
        finite("amplitude", amplitude)?;
        finite("phase", phase)?;
        finite("start", start)?;
        if !(frequency_hz.is_finite() && frequency_hz >= 0.0) {
            return Err(Error::invalid_parameter(
                "frequency_hz",
                frequency_hz,
                "must be finite and ≥ 0",
            ));
        }
        let omega = 2.0 * std::f64::consts::PI * frequency_hz;
        if !(amplitude.abs() * omega * omega).is_finite() {
            return Err(Error::invalid_parameter(
                "frequency_hz",
                frequency_hz,
                format!(
                    "the acceleration |A|·(2πf)² of this sine (A = {amplitude:e}) is not finite; use a lower frequency"
                ),
            ));
        }
        Ok(Amplitude::Sine {
            amplitude,
            frequency_hz,
            phase,
            start,
        })
    }

    /// Whether a(t) = 1 for all t: data with this amplitude behave as data without one.
    pub fn is_one(&self) -> bool {
        *self == Amplitude::Constant(1.0)
    }

    /// Whether a(t) is the same for all t (then ȧ = ä = 0).
    pub fn is_constant(&self) -> bool {
        match self {
            Amplitude::Constant(_) => true,
            Amplitude::Table { values, .. } => values.iter().all(|v| *v == values[0]),
            Amplitude::Sine {
                amplitude,
                frequency_hz,
                ..
            } => *amplitude == 0.0 || *frequency_hz == 0.0,
            Amplitude::Ramp { .. } | Amplitude::SmoothStep { .. } => false,
        }
    }

    /// Whether a(t) = 0 for every t in [`start`, `end`] (s): the data it scales never act
    /// over a run of those times (a table whose non-zero values lie outside them, a ramp that
    /// starts after them, a sine of amplitude 0, or of 0 Hz or starting after them with
    /// sin φ = 0 to 1e-12). Piecewise linear tables vanish on an interval exactly when they do
    /// at its ends and at their points inside it.
    pub fn vanishes_on(&self, start: f64, end: f64) -> bool {
        match self {
            Amplitude::Constant(c) => *c == 0.0,
            Amplitude::Table { times, values } => {
                self.value(start) == 0.0
                    && self.value(end) == 0.0
                    && times
                        .iter()
                        .zip(values)
                        .all(|(t, v)| *t <= start || *t >= end || *v == 0.0)
            }
            Amplitude::Ramp { start: t0, .. } | Amplitude::SmoothStep { start: t0, .. } => {
                end <= *t0
            }
            Amplitude::Sine {
                amplitude,
                frequency_hz,
                phase,
                start: t0,
            } => {
                let still = *frequency_hz == 0.0 || end <= *t0;
                *amplitude == 0.0 || (still && phase.sin().abs() <= 1e-12)
            }
        }
    }

    /// The frequency (Hz) of a sine amplitude, `None` for the others.
    pub fn frequency_hz(&self) -> Option<f64> {
        match self {
            Amplitude::Sine { frequency_hz, .. } => Some(*frequency_hz),
            _ => None,
        }
    }

    /// [a(t), ȧ(t), ä(t)] (1, 1/s, 1/s²), defined for every t: a NaN time has no value, so it
    /// gives [NaN, NaN, NaN] (as `f64::sin` does; callers that take times from outside check
    /// them, see [`checked_derivatives`](Self::checked_derivatives)); t = ±∞ gives the ends'
    /// values for the amplitudes that hold them (table, ramp, smooth step) and NaN for a sine.
    /// The constructors keep every result of a finite t finite.
    pub fn derivatives(&self, t: f64) -> [f64; 3] {
        if t.is_nan() {
            return [f64::NAN; 3];
        }
        match self {
            Amplitude::Constant(c) => [*c, 0.0, 0.0],
            Amplitude::Table { times, values } => table_at(times, values, t),
            Amplitude::Ramp { start, end } => {
                let width = end - start;
                if t < *start {
                    [0.0, 0.0, 0.0]
                } else if t < *end {
                    [(t - start) / width, 1.0 / width, 0.0]
                } else {
                    [1.0, 0.0, 0.0]
                }
            }
            Amplitude::SmoothStep { start, end } => {
                let width = end - start;
                if t <= *start {
                    [0.0, 0.0, 0.0]
                } else if t >= *end {
                    [1.0, 0.0, 0.0]
                } else {
                    let s = (t - start) / width;
                    let s2 = s * s;
                    [
                        s2 * s * (10.0 - 15.0 * s + 6.0 * s2),
                        30.0 * s2 * (1.0 - s) * (1.0 - s) / width,
                        60.0 * s * (1.0 - s) * (1.0 - 2.0 * s) / (width * width),
                    ]
                }
            }
            Amplitude::Sine {
                amplitude,
                frequency_hz,
                phase,
                start,
            } => {
                if t < *start {
                    return [amplitude * phase.sin(), 0.0, 0.0];
                }
                let omega = 2.0 * std::f64::consts::PI * frequency_hz;
                let angle = omega * (t - start) + phase;
                [
                    amplitude * angle.sin(),
                    amplitude * omega * angle.cos(),
                    -amplitude * omega * omega * angle.sin(),
                ]
            }
        }
    }

    /// [`derivatives`](Self::derivatives) at a time from outside: [`Error::InvalidParameter`]
    /// naming the time unless it is finite.
    pub fn checked_derivatives(&self, t: f64) -> Result<[f64; 3]> {
        Ok(self.derivatives(finite("time", t)?))
    }

    /// a(t) (NaN for a NaN t, see [`derivatives`](Self::derivatives)).
    pub fn value(&self, t: f64) -> f64 {
        self.derivatives(t)[0]
    }

    /// ȧ(t) (1/s).
    pub fn rate(&self, t: f64) -> f64 {
        self.derivatives(t)[1]
    }

    /// ä(t) (1/s²).
    pub fn acceleration(&self, t: f64) -> f64 {
        self.derivatives(t)[2]
    }
}

/// Linear interpolation of a checked table, constant beyond the ends.
fn table_at(times: &[f64], values: &[f64], t: f64) -> [f64; 3] {
    let last = times.len() - 1;
    if t <= times[0] {
        let rate = match last > 0 && t == times[0] {
            true => (values[1] - values[0]) / (times[1] - times[0]),
            false => 0.0,
        };
        return [values[0], rate, 0.0];
    }
    if t >= times[last] {
        return [values[last], 0.0, 0.0];
    }
    // The segment [tᵢ, tᵢ₊₁) holding t: t > t₀ here (a NaN t never gets here), so at least one
    // time is ≤ t and the index does not underflow.
    let i = times.partition_point(|&ti| ti <= t).saturating_sub(1);
    let (width, rise) = (times[i + 1] - times[i], values[i + 1] - values[i]);
    // The fraction of the segment, in [0, 1], rather than slope·(t − tᵢ): the product of a huge
    // slope and a tiny offset can overflow where the value itself is between two finite ones.
    let fraction = (t - times[i]) / width;
    [values[i] + rise * fraction, rise / width, 0.0]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_interpolates_and_holds_its_ends() {
        let a = Amplitude::table(vec![0.0, 1.0, 3.0], vec![0.0, 2.0, 1.0]).unwrap();
        assert_eq!(a.derivatives(-1.0), [0.0, 0.0, 0.0]);
        assert_eq!(a.derivatives(0.5), [1.0, 2.0, 0.0]);
        assert_eq!(a.derivatives(2.0), [1.5, -0.5, 0.0]);
        assert_eq!(a.derivatives(1.0), [2.0, -0.5, 0.0]);
        assert_eq!(a.derivatives(5.0), [1.0, 0.0, 0.0]);
    }

    #[test]
    fn bad_tables_name_the_point() {
        let e = Amplitude::table(vec![0.0, 1.0, 1.0], vec![0.0; 3]).unwrap_err();
        assert!(e.to_string().contains("point 2"), "{e}");
        let e = Amplitude::table(vec![0.0, 1.0], vec![0.0, f64::NAN]).unwrap_err();
        assert!(e.to_string().contains("value of point 1"), "{e}");
        assert!(Amplitude::ramp(1.0, 1.0).is_err());
        assert!(Amplitude::sine(1.0, -1.0, 0.0, 0.0).is_err());
    }

    /// A NaN time (a damaged checkpoint's, a caller's) gives NaN for every kind, never a panic
    /// (the table's segment search underflowed) nor a number (a ramp answered 1); the checked
    /// entry point refuses it naming the time. The ends hold at ±∞.
    #[test]
    fn a_nan_time_has_no_value() {
        let kinds = [
            Amplitude::Constant(2.0),
            Amplitude::table(vec![0.0, 1.0, 3.0], vec![0.0, 2.0, 1.0]).unwrap(),
            Amplitude::table(vec![0.5], vec![3.0]).unwrap(),
            Amplitude::ramp(0.0, 1.0).unwrap(),
            Amplitude::smooth_step(0.0, 1.0).unwrap(),
            Amplitude::sine(1.0, 2.0, 0.3, 0.0).unwrap(),
        ];
        for a in &kinds {
            assert!(a.derivatives(f64::NAN).iter().all(|v| v.is_nan()), "{a:?}");
            assert!(
                a.value(f64::NAN).is_nan() && a.rate(f64::NAN).is_nan(),
                "{a:?}"
            );
            assert!(a.acceleration(f64::NAN).is_nan(), "{a:?}");
            let e = a.checked_derivatives(f64::NAN).unwrap_err();
            assert!(e.to_string().contains("time"), "{e}");
            assert_eq!(a.checked_derivatives(0.25).unwrap(), a.derivatives(0.25));
        }
        assert_eq!(kinds[1].derivatives(f64::INFINITY), [1.0, 0.0, 0.0]);
        assert_eq!(kinds[1].derivatives(f64::NEG_INFINITY), [0.0, 0.0, 0.0]);
        assert_eq!(kinds[3].derivatives(f64::INFINITY), [1.0, 0.0, 0.0]);
    }

    /// Intervals too short for a finite rate (a denormal table segment gave a(t) = ∞) are
    /// refused at construction, naming the point; short but representable ones interpolate
    /// exactly (the fraction of the segment is 1/2 exactly here).
    #[test]
    fn intervals_too_short_for_a_finite_rate_are_refused() {
        let e = Amplitude::table(vec![0.0, 1e-320], vec![0.0, 1.0]).unwrap_err();
        assert!(e.to_string().contains("time of point 1"), "{e}");
        assert!(e.to_string().contains("slope"), "{e}");
        let e = Amplitude::table(vec![0.0, 1.0], vec![-1e308, 1e308]).unwrap_err();
        assert!(e.to_string().contains("not finite"), "{e}");
        assert!(Amplitude::ramp(0.0, 1e-320).is_err());
        assert!(Amplitude::ramp(-1e308, 1e308).is_err());
        // The smooth step's ä scales as 1/width²: 1e-160² underflows.
        assert!(Amplitude::smooth_step(0.0, 1e-160).is_err());
        assert!(Amplitude::smooth_step(0.0, 1e-150).is_ok());
        let e = Amplitude::sine(1.0, 1e160, 0.0, 0.0).unwrap_err();
        assert!(e.to_string().contains("frequency_hz"), "{e}");

        let short = Amplitude::table(vec![0.0, 1e-300], vec![0.0, 1e8]).unwrap();
        assert_eq!(short.derivatives(5e-301), [5e7, 1e308, 0.0]);
        for t in [1e-310, 3e-301, 9.9e-301] {
            let a = short.value(t);
            assert!(a.is_finite() && (0.0..=1e8).contains(&a), "{t}: {a}");
        }
    }

    /// An amplitude zero over a run's whole time span is recognised (issue 33: a table after
    /// the run, a 0 Hz sine of phase 0, a ramp starting after it), one non-zero anywhere in it
    /// is not.
    #[test]
    fn amplitudes_that_vanish_over_a_run() {
        let late = Amplitude::table(vec![2.0, 3.0], vec![0.0, 1.0]).unwrap();
        assert!(late.vanishes_on(0.0, 1.0) && late.vanishes_on(0.0, 2.0));
        assert!(!late.vanishes_on(0.0, 2.5));
        let early = Amplitude::table(vec![-3.0, -2.0], vec![1.0, 0.0]).unwrap();
        assert!(early.vanishes_on(0.0, 1.0) && !early.vanishes_on(-2.5, 1.0));
        // Zero at both ends of the run, not in between.
        let bump = Amplitude::table(vec![0.0, 0.5, 1.0], vec![0.0, 1.0, 0.0]).unwrap();
        assert!(!bump.vanishes_on(0.0, 1.0));
        assert!(
            Amplitude::sine(1.0, 0.0, 0.0, 0.0)
                .unwrap()
                .vanishes_on(0.0, 1.0)
        );
        assert!(
            !Amplitude::sine(1.0, 0.0, 0.5, 0.0)
                .unwrap()
                .vanishes_on(0.0, 1.0)
        );
        assert!(
            !Amplitude::sine(1.0, 5.0, 0.0, 0.0)
                .unwrap()
                .vanishes_on(0.0, 1.0)
        );
        assert!(
            Amplitude::sine(0.0, 5.0, 0.3, 0.0)
                .unwrap()
                .vanishes_on(0.0, 1.0)
        );
        assert!(Amplitude::ramp(2.0, 3.0).unwrap().vanishes_on(0.0, 1.0));
        assert!(!Amplitude::ramp(0.5, 3.0).unwrap().vanishes_on(0.0, 1.0));
        assert!(Amplitude::Constant(0.0).vanishes_on(0.0, 1.0));
        assert!(!Amplitude::default().vanishes_on(0.0, 1.0));
    }

    /// The rates are the derivatives of the values: central differences agree to
    /// O(h²)·|a'''| with h = 1e-5 (1e-6 leaves room for round-off ~1e-16/h²·|a|).
    #[test]
    fn rates_are_derivatives() {
        let h = 1e-5;
        for a in [
            Amplitude::smooth_step(0.2, 1.2).unwrap(),
            Amplitude::sine(0.3, 2.0, 0.4, 0.1).unwrap(),
        ] {
            for t in [0.3, 0.55, 0.9, 1.1] {
                let d = a.derivatives(t);
                let rate = (a.value(t + h) - a.value(t - h)) / (2.0 * h);
                let acc = (a.rate(t + h) - a.rate(t - h)) / (2.0 * h);
                assert!((rate - d[1]).abs() < 1e-6 * (1.0 + d[1].abs()), "{a:?} {t}");
                assert!((acc - d[2]).abs() < 1e-5 * (1.0 + d[2].abs()), "{a:?} {t}");
            }
        }
        let step = Amplitude::smooth_step(0.0, 2.0).unwrap();
        // C²: value, rate and acceleration meet the constant pieces at both ends.
        assert_eq!(step.derivatives(0.0), [0.0, 0.0, 0.0]);
        assert_eq!(step.value(1.0), 0.5);
        assert_eq!(step.derivatives(2.0), [1.0, 0.0, 0.0]);
        assert_eq!(Amplitude::ramp(0.0, 2.0).unwrap().value(1.5), 0.75);
    }
}
