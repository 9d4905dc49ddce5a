//! The IPC barrier (Li et al., "Incremental Potential Contact", 2020): a smooth, convex
//! potential of the gap d that is zero beyond the activation distance d̂ and grows without bound
//! as d → 0⁺, so a state whose energy is finite has every gap positive.

/// b(d) = −(d − d̂)²·ln(d/d̂) for 0 < d < d̂, 0 for d ≥ d̂, +∞ for d ≤ 0 (length² units).
pub fn value(d: f64, d_hat: f64) -> f64 {
    if d >= d_hat {
        0.0
    } else if d > 0.0 {
        -(d - d_hat).powi(2) * (d / d_hat).ln()
    } else {
        f64::INFINITY
    }
}

/// b′(d) = −2(d − d̂)·ln(d/d̂) − (d − d̂)²/d (≤ 0: the barrier pushes the gap open; length
/// units). Zero for d ≥ d̂, −∞ for d ≤ 0.
pub fn derivative(d: f64, d_hat: f64) -> f64 {
    if d >= d_hat {
        0.0
    } else if d > 0.0 {
        let s = d - d_hat;
        -2.0 * s * (d / d_hat).ln() - s * s / d
    } else {
        f64::NEG_INFINITY
    }
}

/// b″(d) = −2·ln(d/d̂) − 2(d − d̂)/d + (d̂² − d²)/d² (> 0 on (0, d̂): the barrier is convex, so
/// its Hessian along the normal needs no projection; dimensionless). Zero for d ≥ d̂.
pub fn second_derivative(d: f64, d_hat: f64) -> f64 {
    if d >= d_hat {
        0.0
    } else if d > 0.0 {
        -2.0 * (d / d_hat).ln() - 2.0 * (d - d_hat) / d + (d_hat * d_hat - d * d) / (d * d)
    } else {
        f64::INFINITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derivatives_match_central_differences() {
        let d_hat = 1e-3;
        for d in [1e-5, 1e-4, 3e-4, 7e-4, 9.9e-4] {
            let h = 1e-9;
            let fd = (value(d + h, d_hat) - value(d - h, d_hat)) / (2.0 * h);
            // Central difference error O(h²·b‴) plus round-off ~1e-16·b/h: 1e-5 relative.
            assert!((fd - derivative(d, d_hat)).abs() <= 1e-5 * derivative(d, d_hat).abs());
            let fd2 = (derivative(d + h, d_hat) - derivative(d - h, d_hat)) / (2.0 * h);
            let exact = second_derivative(d, d_hat);
            assert!(
                (fd2 - exact).abs() <= 1e-5 * exact.abs(),
                "{d}: {fd2} vs {exact}"
            );
            assert!(exact > 0.0);
        }
        assert_eq!(value(2e-3, d_hat), 0.0);
        assert_eq!(value(0.0, d_hat), f64::INFINITY);
    }
}
