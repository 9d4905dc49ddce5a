//! The static Newton step with the surface barrier's off-pattern Hessian entries: the factored
//! tangent P holds each as |v| on its row's diagonal (PSD, above the exact J); the step solves
//! the exact J·δ = r by conjugate gradients preconditioned by P's factor, as the implicit
//! dynamic step does (the lumped P alone converged linearly: 5.7e-6 of the reference after 200
//! iterations of one load step of a block resting on another). [`solve_with_lumped`] is that
//! solve for both.

use crate::base::error::Result;
use crate::bc::constraints::DofMap;
use crate::contact::surface::SurfaceContact;
use crate::linear_solver::LinearSolver;
use crate::sparse::CscMatrix;

/// Most CG iterations: a few low modes (the bodies' common motion that the lumped coupling
/// resists) hold the preconditioned spectrum's spread.
const LUMPED_CG_ITERATIONS: usize = 100;

/// The last tangent's lumped entries of `surface` ([`SurfaceContact::lumped_entries`]) on the
/// free DOFs of `dofs`: (row, column or `None` where the column is supported, v); rows on
/// supported DOFs are dropped.
pub(super) fn free_lumped_entries(
    surface: &SurfaceContact,
    dofs: &DofMap,
) -> Vec<(usize, Option<usize>, f64)> {
    surface
        .lumped_entries()
        .into_iter()
        .filter_map(|(r, c, v)| Some((dofs.free_index(r)?, dofs.free_index(c), v)))
        .collect()
}

/// Solves J·δ = b (`delta` holding b on entry) for J = P + Σ (v at (r, c) − |v| at (r, r))
/// over `lumped`, P the factored `matrix`: conjugate gradients preconditioned by P's factor.
/// P − J is PSD, so P⁻¹J has its spectrum in (0, 1]. Stops at 1e-12 of ‖b‖ in the
/// preconditioned norm, or at non-positive curvature (keeping the iterate reached, which
/// started from P⁻¹b: a descent direction either way); a non-finite or zero iterate falls
/// back to P⁻¹b.
pub(crate) fn solve_with_lumped(
    solver: &mut LinearSolver,
    matrix: &CscMatrix,
    lumped: &[(usize, Option<usize>, f64)],
    delta: &mut [f64],
) -> Result<()> {
    let n = delta.len();
    let b = delta.to_vec();
    let apply = |x: &[f64], out: &mut [f64]| {
        matrix.product_into(x, out);
        for &(r, c, v) in lumped {
            out[r] -= v.abs() * x[r];
            if let Some(c) = c {
                out[r] += v * x[c];
            }
        }
    };
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let mut x = vec![0.0; n];
    let mut r = b.clone();
    let mut z = r.clone();
    solver.solve(matrix, &mut z)?;
    let mut p = z.clone();
    let mut rz = dot(&r, &z);
    let stop = 1e-24 * rz;
    let mut ap = vec![0.0; n];
    for _ in 0..LUMPED_CG_ITERATIONS {
        apply(&p, &mut ap);
        let curvature = dot(&p, &ap);
        if curvature.is_nan() || curvature <= 0.0 {
            break;
        }
        let alpha = rz / curvature;
        x.iter_mut().zip(&p).for_each(|(x, p)| *x += alpha * p);
        r.iter_mut().zip(&ap).for_each(|(r, a)| *r -= alpha * a);
        z.copy_from_slice(&r);
        solver.solve(matrix, &mut z)?;
        let next = dot(&r, &z);
        if next <= stop {
            break;
        }
        let beta = next / rz;
        rz = next;
        p.iter_mut().zip(&z).for_each(|(p, z)| *p = z + beta * *p);
    }
    if x.iter().all(|v| v.is_finite()) && x.iter().any(|&v| v != 0.0) {
        delta.copy_from_slice(&x);
    } else {
        delta.copy_from_slice(&b);
        solver.solve(matrix, delta)?;
    }
    Ok(())
}
