//! Dense vector arithmetic on plain slices, each a single serial loop in index order (so a
//! result's bits do not depend on the caller or the thread count): what the Newton, L-BFGS,
//! modal and step-size code share.

/// aᵀb = Σᵢ aᵢ·bᵢ, summed in index order over the shorter length.
#[inline]
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The Euclidean norm ‖v‖ = √(vᵀv).
#[inline]
pub(crate) fn norm(v: &[f64]) -> f64 {
    dot(v, v).sqrt()
}

/// The largest magnitude ‖v‖∞ = maxᵢ |vᵢ| (0 for an empty v).
#[inline]
pub(crate) fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// y ← y + a·x, over the shorter length.
#[inline]
pub(crate) fn axpy(a: f64, x: &[f64], y: &mut [f64]) {
    y.iter_mut().zip(x).for_each(|(y, x)| *y += a * x);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Small integers: every product and partial sum is exact, so the values are too.
    #[test]
    fn the_helpers_give_exact_values_on_integers() {
        let (a, b) = ([1.0, -2.0, 3.0], [4.0, 5.0, -6.0]);
        assert_eq!(dot(&a, &b), 4.0 - 10.0 - 18.0);
        assert_eq!(norm(&[3.0, 4.0]), 5.0);
        assert_eq!(max_abs(&b), 6.0);
        assert_eq!(max_abs(&[]), 0.0);
        let mut y = [1.0, 1.0, 1.0];
        axpy(2.0, &a, &mut y);
        assert_eq!(y, [3.0, -3.0, 7.0]);
    }
}
