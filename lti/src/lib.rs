//! Exact discretisation of linear time-invariant systems, shared by every model.
//!
//! Models keep their linear parts in continuous-time state-space form and step them with the
//! zero-order-hold (ZOH) solution, which is exact for inputs held constant over the step. The
//! stochastic parts use Van Loan's method so that the sampled noise has exactly the covariance
//! of the continuous process, whatever the step.

use nalgebra::DMatrix;

/// Largest 1-norm of a matrix whose exponential is computed.
///
/// nalgebra's scaling-and-squaring forms the powers of the unscaled matrix up to the tenth
/// before choosing the scaling: above a norm of about 1.3e30 they overflow, the number of
/// squarings becomes infinite, and `exp` loops for ever (a hang, found with a drive stiffness of
/// 1e50 N m/rad). The models here stay far below: the drives' largest exponent, over a 1 s
/// piece, has a norm of about 1e4.
pub const MAX_EXPONENT_NORM: f64 = 1e30;

/// `exp(m)`, or a matrix of NaN when `m` has a non-finite entry or a norm above
/// [`MAX_EXPONENT_NORM`]: the caller's finiteness check then reports the extreme parameters,
/// where computing the exponential would hang or return rubbish.
fn exp_or_nan(m: DMatrix<f64>) -> DMatrix<f64> {
    let norm = m.column_iter().map(|c| c.iter().map(|v| v.abs()).sum::<f64>()).fold(0.0, f64::max);
    if norm.is_nan() || norm > MAX_EXPONENT_NORM {
        return DMatrix::from_element(m.nrows(), m.ncols(), f64::NAN);
    }
    m.exp()
}

/// Zero-order-hold discretisation of `dx/dt = A x + B u` over a step `h`.
///
/// Returns `(Ad, Bd)` with `x(t+h) = Ad x(t) + Bd u` for `u` held constant over the step. Both
/// come from one matrix exponential of the block matrix `[[A, B], [0, 0]] h`, which is exact
/// (to the accuracy of the Pade approximant, about machine precision) even when `A` is singular,
/// as it is for every drive (the rigid-body mode is a pure integrator). For an exponent too
/// large to compute (norm above [`MAX_EXPONENT_NORM`], or not finite) both are NaN.
pub fn zoh(a: &DMatrix<f64>, b: &DMatrix<f64>, h: f64) -> (DMatrix<f64>, DMatrix<f64>) {
    let n = a.nrows();
    let m = b.ncols();
    assert_eq!(a.ncols(), n, "A must be square");
    assert_eq!(b.nrows(), n, "B must have as many rows as A");
    let mut block = DMatrix::<f64>::zeros(n + m, n + m);
    block.view_mut((0, 0), (n, n)).copy_from(&(a * h));
    block.view_mut((0, n), (n, m)).copy_from(&(b * h));
    let e = exp_or_nan(block);
    (e.view((0, 0), (n, n)).into_owned(), e.view((0, n), (n, m)).into_owned())
}

/// Van Loan's discretisation of `dx = A x dt + G dW`, with `E[dW dW'] = Q dt`, over a step `h`.
///
/// Returns `(Ad, Qd)`: `x(t+h) = Ad x(t) + w` with `w ~ N(0, Qd)` and
/// `Qd = integral_0^h exp(A s) G Q G' exp(A' s) ds`, the exact covariance of the noise that the
/// continuous process accumulates over the step. Sampling with `Qd` reproduces the continuous
/// process at the sample times, so statistics do not depend on the step. NaN, as for [`zoh`],
/// when the exponent is too large to compute.
pub fn van_loan(a: &DMatrix<f64>, g: &DMatrix<f64>, q: &DMatrix<f64>, h: f64) -> (DMatrix<f64>, DMatrix<f64>) {
    let n = a.nrows();
    let gqg = g * q * g.transpose();
    let mut block = DMatrix::<f64>::zeros(2 * n, 2 * n);
    block.view_mut((0, 0), (n, n)).copy_from(&(-a * h));
    block.view_mut((0, n), (n, n)).copy_from(&(&gqg * h));
    block.view_mut((n, n), (n, n)).copy_from(&(a.transpose() * h));
    let e = exp_or_nan(block);
    let ad = e.view((n, n), (n, n)).transpose();
    let qd = &ad * e.view((0, n), (n, n));
    // Symmetrise: the product is symmetric in exact arithmetic only.
    let qd = (&qd + qd.transpose()) * 0.5;
    (ad, qd)
}

/// Solves the continuous Lyapunov equation `A P + P A' + W = 0` for a stable `A`.
///
/// Used to get the exact stationary covariance of a shaping filter driven by white noise. The
/// Kronecker form is solved directly by LU; the filters here have at most a few tens of states.
pub fn lyapunov_continuous(a: &DMatrix<f64>, w: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let n = a.nrows();
    let eye = DMatrix::<f64>::identity(n, n);
    let k = eye.kronecker(a) + a.kronecker(&eye);
    let rhs = -DMatrix::from_column_slice(n * n, 1, w.as_slice());
    let sol = k.lu().solve(&rhs)?;
    let p = DMatrix::from_column_slice(n, n, sol.as_slice());
    Some((&p + p.transpose()) * 0.5)
}

/// Solves the discrete Lyapunov equation `P = A P A' + Q` for a Schur-stable `A`.
///
/// This is the stationary covariance of `x[k+1] = A x[k] + w[k]`, `w ~ N(0, Q)`: the exact
/// variance a discretised noise model settles to, independent of any simulation.
pub fn lyapunov_discrete(a: &DMatrix<f64>, q: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let n = a.nrows();
    let k = DMatrix::<f64>::identity(n * n, n * n) - a.kronecker(a);
    let rhs = DMatrix::from_column_slice(n * n, 1, q.as_slice());
    let sol = k.lu().solve(&rhs)?;
    let p = DMatrix::from_column_slice(n, n, sol.as_slice());
    Some((&p + p.transpose()) * 0.5)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zoh_of_a_double_integrator_matches_the_closed_form() {
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]);
        let b = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
        let h = 0.37;
        let (ad, bd) = zoh(&a, &b, h);
        let expected_ad = DMatrix::from_row_slice(2, 2, &[1.0, h, 0.0, 1.0]);
        let expected_bd = DMatrix::from_row_slice(2, 1, &[h * h / 2.0, h]);
        assert!((ad - expected_ad).abs().max() < 1e-14);
        assert!((bd - expected_bd).abs().max() < 1e-14);
    }

    #[test]
    fn an_exponent_too_large_to_compute_gives_nan_instead_of_hanging() {
        // With these, nalgebra's exp never returned (its squaring count overflowed).
        let b = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
        for huge in [1e40, 1e300, f64::INFINITY, f64::NAN] {
            let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -huge, -1.0]);
            let (ad, bd) = zoh(&a, &b, 1e-3);
            assert!(ad.iter().chain(bd.iter()).all(|v| v.is_nan()), "A entry {huge}: {ad} {bd}");
            let (ad, qd) = van_loan(&a, &b, &DMatrix::from_element(1, 1, 1.0), 1e-3);
            assert!(ad.iter().chain(qd.iter()).all(|v| v.is_nan()), "A entry {huge}");
        }
        // Just inside the bound the exponential is still computed: a fast decay to zero.
        let a = DMatrix::from_element(2, 2, 0.0) - DMatrix::identity(2, 2) * 0.9e30;
        let (ad, _) = zoh(&a, &DMatrix::from_element(2, 1, 0.0), 1.0);
        assert!(ad.iter().all(|v| *v == 0.0), "{ad}");
    }

    #[test]
    fn van_loan_covariance_of_a_first_order_lag_matches_the_closed_form() {
        // dx = -a x dt + dW, E[dW^2] = q dt: Qd = q (1 - exp(-2 a h)) / (2 a).
        let (alpha, q, h) = (3.0, 2.0, 0.05);
        let a = DMatrix::from_element(1, 1, -alpha);
        let g = DMatrix::from_element(1, 1, 1.0);
        let qm = DMatrix::from_element(1, 1, q);
        let (ad, qd) = van_loan(&a, &g, &qm, h);
        assert!((ad[(0, 0)] - (-alpha * h).exp()).abs() < 1e-14);
        let expected = q * (1.0 - (-2.0 * alpha * h).exp()) / (2.0 * alpha);
        assert!((qd[(0, 0)] - expected).abs() < 1e-14 * expected.max(1.0));
    }

    #[test]
    fn discrete_and_continuous_lyapunov_agree_for_an_exactly_sampled_process() {
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -4.0, -0.8]);
        let g = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
        let q = DMatrix::from_element(1, 1, 1.5);
        let p_cont = lyapunov_continuous(&a, &(&g * &q * g.transpose())).unwrap();
        for h in [1e-3, 1e-2, 0.3] {
            let (ad, qd) = van_loan(&a, &g, &q, h);
            let p_disc = lyapunov_discrete(&ad, &qd).unwrap();
            assert!((&p_disc - &p_cont).abs().max() < 1e-9 * p_cont.abs().max(), "h = {h}");
        }
    }
}
