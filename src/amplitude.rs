//! Amplitudes a(t): the dimensionless factor by which a load or a prescribed displacement
//! follows time, with its rate ȧ(t) and acceleration ä(t) (what prescribed velocities and
//! accelerations of moving supports need).
//!
//! A static analysis evaluates amplitudes at one time, [`STATIC_TIME`] (t = 1), so a ramp that
//! ends by then is at its full value.

use crate::error::{Error, Result};

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

fn interval(start: f64, end: f64) -> Result<(f64, f64)> {
    finite("start", start)?;
    finite("end", end)?;
    if end > start {
        Ok((start, end))
    } else {
        Err(Error::invalid_parameter(
            "end",
            end,
            format!("must be after start ({start})"),
        ))
    }
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
        }
        Ok(Amplitude::Table { times, values })
    }

    /// A ramp from 0 at `start` to 1 at `end` (s): both finite, end > start.
    pub fn ramp(start: f64, end: f64) -> Result<Self> {
        let (start, end) = interval(start, end)?;
        Ok(Amplitude::Ramp { start, end })
    }

    /// The quintic smooth step from 0 at `start` to 1 at `end` (s): both finite, end > start.
    pub fn smooth_step(start: f64, end: f64) -> Result<Self> {
        let (start, end) = interval(start, end)?;
        Ok(Amplitude::SmoothStep { start, end })
    }

    /// A·sin(2πf(t − start) + φ): all finite, f ≥ 0 (Hz).
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

    /// [a(t), ȧ(t), ä(t)] (1, 1/s, 1/s²).
    pub fn derivatives(&self, t: f64) -> [f64; 3] {
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

    /// a(t).
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
    // The segment [tᵢ, tᵢ₊₁) holding t.
    let i = times.partition_point(|&ti| ti <= t) - 1;
    let slope = (values[i + 1] - values[i]) / (times[i + 1] - times[i]);
    [values[i] + slope * (t - times[i]), slope, 0.0]
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
