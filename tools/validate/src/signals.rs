//! Signal conditioning for equation-error identification: zero-phase Savitzky-Golay smoothing
//! and differentiation, model-free noise estimates, resampling to a uniform grid and
//! fractional time shifts.
//!
//! Savitzky-Golay filters fit a polynomial over a symmetric window, so they have no phase lag
//! and no delay: an acceleration from them lines up in time with the torque, which matters
//! because a lag would look like a time delay in the residual. They are exact for polynomials
//! up to their order, so slow motion passes undistorted.
// TODO(lead): move the generic parts (Savitzky-Golay, noise estimate) to dsp once it lands.

use antenna_dsp::weighted_least_squares;
use nalgebra::DMatrix;

/// Savitzky-Golay coefficients for the smoothed value, first and second derivative at the
/// window centre, for a polynomial of `order` over `2 half_width + 1` samples spaced `dt`.
#[derive(Debug, Clone)]
pub struct SavitzkyGolay {
    pub half_width: usize,
    pub smooth: Vec<f64>,
    pub first: Vec<f64>,
    pub second: Vec<f64>,
}

impl SavitzkyGolay {
    pub fn new(order: usize, half_width: usize, dt: f64) -> SavitzkyGolay {
        let m = 2 * half_width + 1;
        let order = order.min(m - 1);
        // Least-squares polynomial fit in units of samples: the pseudo-inverse rows give the
        // coefficients of the constant, linear and quadratic terms at the centre.
        let vandermonde = DMatrix::from_fn(m, order + 1, |i, j| (i as f64 - half_width as f64).powi(j as i32));
        let gram = vandermonde.transpose() * &vandermonde;
        let inverse = gram.try_inverse().unwrap_or_else(|| DMatrix::identity(order + 1, order + 1));
        let pinv = inverse * vandermonde.transpose();
        let row = |k: usize, scale: f64| -> Vec<f64> {
            if k > order {
                return vec![0.0; m];
            }
            (0..m).map(|i| pinv[(k, i)] * scale).collect()
        };
        SavitzkyGolay { half_width, smooth: row(0, 1.0), first: row(1, 1.0 / dt), second: row(2, 2.0 / (dt * dt)) }
    }

    /// Applies coefficients in "valid" mode: output i is centred on input i + half_width.
    pub fn apply(coefficients: &[f64], x: &[f64]) -> Vec<f64> {
        let m = coefficients.len();
        if x.len() < m {
            return Vec::new();
        }
        (0..=x.len() - m).map(|i| coefficients.iter().zip(&x[i..i + m]).map(|(c, v)| c * v).sum()).collect()
    }

    /// Noise gain: the output standard deviation for unit white input.
    pub fn gain(coefficients: &[f64]) -> f64 {
        coefficients.iter().map(|c| c * c).sum::<f64>().sqrt()
    }
}

/// A Gaussian smoothing kernel with standard deviation `sigma` samples, truncated at 4 sigma
/// and normalised to unit sum. Zero phase; its frequency response exp(-(w sigma)^2/2) has no
/// side lobes, so a derivative taken after it does not amplify the noise the kernel leaks.
/// The -3 dB frequency is 0.1325 / (sigma dt).
pub fn gaussian_kernel(sigma: f64) -> Vec<f64> {
    let half = (4.0 * sigma).ceil().max(1.0) as isize;
    let raw: Vec<f64> = (-half..=half).map(|k| (-0.5 * (k as f64 / sigma).powi(2)).exp()).collect();
    let sum: f64 = raw.iter().sum();
    raw.iter().map(|v| v / sum).collect()
}

/// Model-free estimate of the white-noise standard deviation of a sampled signal.
///
/// The fourth difference removes any smooth signal (cubics exactly) and multiplies white noise
/// variance by 70; the median absolute deviation makes it robust to the rare jumps where the
/// signal is not smooth. A quantised signal that sits still for long stretches has zero
/// differences there; the estimate is then floored at the resolution seen in the data,
/// step / sqrt(12).
pub fn noise_sigma(x: &[f64]) -> f64 {
    if x.len() < 8 {
        return 0.0;
    }
    let mut d: Vec<f64> = x.windows(5).map(|w| (w[0] - 4.0 * w[1] + 6.0 * w[2] - 4.0 * w[3] + w[4]).abs()).collect();
    d.sort_by(|a, b| a.total_cmp(b));
    let mad = d[d.len() / 2];
    let sigma = mad / 0.674_489_75 / 70f64.sqrt();
    let step = resolution(x);
    sigma.max(step / 12f64.sqrt())
}

/// Samples on each side of the present that the torque noise estimate's position filter spans.
pub const TORQUE_NOISE_FILTER_LAGS: usize = 4;

/// Sensor-noise estimate of a logged torque or current whose drive's motion is measured: the
/// smaller of [`noise_sigma`] of the torque itself and of what is left of it after the part a
/// linear filter of the measured positions predicts is removed.
///
/// At a low log rate the logged current has real content up to the Nyquist frequency (the
/// speed loop's response to encoder noise, passed by a current loop of about the same
/// bandwidth), which the fourth difference cannot tell from white noise: on a 250 Hz truth log
/// it reads 91 N m against a sensor noise of 15 N m. That content moves the motor, so a linear
/// filter of the measured positions over a few samples each side (it contains the inverse
/// dynamics J a + K tw + D dtw) predicts it, while the sensor noise, which moves nothing, stays
/// in the remainder. The remainder also holds what no linear filter predicts (friction's
/// switching, the encoders' noise through the filter), so the estimate remains an upper bound
/// of the noise, only a tighter one; where the positions predict nothing the torque's own
/// estimate stands.
pub fn torque_noise_sigma(torque: &[f64], positions: &[&[f64]]) -> f64 {
    torque_noise_unfloored(torque, positions).max(torque_noise_floor(torque))
}

/// The effective resolution of a torque or current measurement, as bits over its range: a
/// drive's current sensing through a 12- to 16-bit converter (estimate; the 16-bit end is
/// taken, so the floor is the smallest noise a real drive's current can have).
pub const TORQUE_SENSOR_BITS: i32 = 16;

/// The least noise a logged torque can be said to have: the rounding it was logged with (the
/// smallest step between its samples, over sqrt(12)) and the resolution of a
/// [`TORQUE_SENSOR_BITS`] converter over the logged range, whichever is larger.
///
/// A current without sensor noise (a simulated log, a logged command) is a fact to use, not a
/// zero to divide by: the noise estimate then falls to what no filter can tell from zero, and
/// every size judged against it (practical significance) and the smoothing chosen from it (the
/// narrowest kernel whose acceleration noise stays below the torque noise) would collapse (a
/// 10.6 Hz cut-off that hid a 51 Hz cogging on a hidden log).
pub fn torque_noise_floor(torque: &[f64]) -> f64 {
    let (low, high) = torque.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| (l.min(*v), h.max(*v)));
    let range = if high > low { high - low } else { 0.0 };
    let converter = range / 2f64.powi(TORQUE_SENSOR_BITS);
    resolution(torque).max(converter) / 12f64.sqrt()
}

/// [`torque_noise_sigma`] without its floor.
fn torque_noise_unfloored(torque: &[f64], positions: &[&[f64]]) -> f64 {
    let own = noise_sigma(torque);
    let m = TORQUE_NOISE_FILTER_LAGS;
    let n = torque.len();
    if n < 20 * (2 * m + 1) || positions.iter().any(|p| p.len() != n) {
        return own;
    }
    // The filter's span is written as the position at the centre plus the 2m sample-to-sample
    // differences around it: the same space of filters as the 2m + 1 positions themselves, but
    // the columns are nearly orthogonal, so the normal equations stay well conditioned.
    let rows = m..n - m;
    let mut columns: Vec<Vec<f64>> = vec![vec![1.0; rows.len()]];
    for position in positions {
        let mean = position.iter().sum::<f64>() / n as f64;
        columns.push(rows.clone().map(|k| position[k] - mean).collect());
        for j in 0..2 * m {
            columns.push(rows.clone().map(|k| position[k - m + j + 1] - position[k - m + j]).collect());
        }
    }
    let target: Vec<f64> = torque[rows.clone()].to_vec();
    let (beta, _) = weighted_least_squares(&columns, &target, &vec![1.0; target.len()]);
    let remainder: Vec<f64> =
        (0..target.len()).map(|i| target[i] - columns.iter().zip(&beta).map(|(c, b)| b * c[i]).sum::<f64>()).collect();
    if remainder.iter().all(|r| r.is_finite()) {
        own.min(noise_sigma(&remainder))
    } else {
        own
    }
}

/// The smallest non-zero difference between consecutive samples: the quantisation step or the
/// resolution the file was written with.
pub fn resolution(x: &[f64]) -> f64 {
    let smallest = x.windows(2).map(|w| (w[1] - w[0]).abs()).filter(|d| *d > 0.0).fold(f64::INFINITY, f64::min);
    if smallest.is_finite() {
        smallest
    } else {
        0.0
    }
}

/// Linear interpolation of `(t, x)` at `at` (clamped at the ends).
pub fn interpolate(t: &[f64], x: &[f64], at: f64) -> f64 {
    if at <= t[0] {
        return x[0];
    }
    if at >= t[t.len() - 1] {
        return x[x.len() - 1];
    }
    let i = t.partition_point(|&v| v <= at).saturating_sub(1);
    let f = (at - t[i]) / (t[i + 1] - t[i]);
    x[i] + f * (x[i + 1] - x[i])
}

/// The signal shifted by `shift` samples (positive: the value from later, x(i + shift)), with
/// cubic (Catmull-Rom) interpolation between samples and the ends held.
pub fn shift_samples(x: &[f64], shift: f64) -> Vec<f64> {
    let n = x.len() as isize;
    let at = |i: isize| x[i.clamp(0, n - 1) as usize];
    (0..n)
        .map(|i| {
            let s = i as f64 + shift;
            let k = s.floor() as isize;
            let f = s - k as f64;
            let (p0, p1, p2, p3) = (at(k - 1), at(k), at(k + 1), at(k + 2));
            p1 + 0.5 * f * (p2 - p0 + f * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 + f * (3.0 * (p1 - p2) + p3 - p0)))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn savitzky_golay_differentiates_polynomials_exactly() {
        let dt = 0.01;
        let sg = SavitzkyGolay::new(4, 6, dt);
        let t: Vec<f64> = (0..50).map(|i| i as f64 * dt).collect();
        let x: Vec<f64> = t.iter().map(|t| 1.0 + 2.0 * t - 3.0 * t * t + 0.5 * t.powi(4)).collect();
        let v = SavitzkyGolay::apply(&sg.first, &x);
        let a = SavitzkyGolay::apply(&sg.second, &x);
        for (i, (v, a)) in v.iter().zip(&a).enumerate() {
            let tc = t[i + 6];
            assert!((v - (2.0 - 6.0 * tc + 2.0 * tc.powi(3))).abs() < 1e-8);
            assert!((a - (-6.0 + 6.0 * tc * tc)).abs() < 1e-6);
        }
    }

    #[test]
    fn noise_estimate_ignores_a_smooth_signal() {
        let sigma = 0.3;
        use rand::SeedableRng;
        use rand_distr::Distribution;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let normal = rand_distr::Normal::new(0.0, 1.0).unwrap();
        let noise: Vec<f64> = (0..20_000).map(|_| normal.sample(&mut rng)).collect();
        let x: Vec<f64> = noise.iter().enumerate().map(|(i, e)| 100.0 * (i as f64 * 0.001).sin() + sigma * e).collect();
        let estimate = noise_sigma(&x);
        assert!((estimate / sigma - 1.0).abs() < 0.05, "{estimate}");
    }

    #[test]
    fn torque_noise_estimate_removes_content_the_motion_explains() {
        use rand::SeedableRng;
        use rand_distr::Distribution;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let normal = rand_distr::Normal::new(0.0, 1.0).unwrap();
        // A motion with content up to the Nyquist frequency (a ramp, a random walk of the speed
        // and a jitter of alternating sign), a torque that is exactly the inertia times its
        // second difference, and white sensor noise on the torque.
        let (dt, inertia, sigma) = (0.004, 3.0e4, 15.0);
        let n = 15_000;
        let mut position = vec![0.0; n];
        let mut speed: f64 = 0.01;
        for k in 1..n {
            let alternating: f64 = if k % 2 == 0 { 1.0 } else { -1.0 };
            let jitter: f64 = normal.sample(&mut rng);
            speed += 2e-3 * dt * normal.sample(&mut rng) + 1e-5 * alternating * jitter.abs();
            position[k] = position[k - 1] + speed * dt;
        }
        let torque: Vec<f64> = (0..n)
            .map(|k| {
                let (a, b, c) = (position[k.saturating_sub(1)], position[k], position[(k + 1).min(n - 1)]);
                inertia * (a - 2.0 * b + c) / (dt * dt) + sigma * normal.sample(&mut rng)
            })
            .collect();
        let own = noise_sigma(&torque);
        assert!(own > 3.0 * sigma, "the motion's own content should inflate the plain estimate: {own}");
        let estimate = torque_noise_sigma(&torque, &[&position]);
        assert!((estimate / sigma - 1.0).abs() < 0.1, "{estimate} against {sigma}");
        // Positions that predict nothing leave the torque's own estimate: it is never raised.
        let unrelated: Vec<f64> = (0..n).map(|k| (k as f64 * 0.37).sin()).collect();
        let alone = torque_noise_sigma(&torque, &[&unrelated]);
        assert!(alone <= own && alone > 0.9 * own, "{alone} against {own}");
    }

    #[test]
    fn a_noiseless_torque_is_floored_at_its_rounding_and_converter_resolution() {
        // A smooth torque written with 1e-3 resolution and no noise: the fourth difference and
        // the position filter see almost nothing, the floor is the rounding.
        let n = 5_000;
        let position: Vec<f64> = (0..n).map(|k| (k as f64 * 0.002).sin()).collect();
        let rounded: Vec<f64> = (0..n).map(|k| ((100.0 * (k as f64 * 0.002).sin()) / 1e-3).round() * 1e-3).collect();
        let estimate = torque_noise_sigma(&rounded, &[&position]);
        let converter = 200.0 / 2f64.powi(TORQUE_SENSOR_BITS);
        assert!(estimate >= converter.max(1e-3) / 12f64.sqrt() * 0.999, "{estimate}");
        // Written at full precision, the converter's resolution over the range remains.
        let exact: Vec<f64> = (0..n).map(|k| 100.0 * (k as f64 * 0.002).sin()).collect();
        let floor = torque_noise_sigma(&exact, &[&position]);
        assert!(floor >= 0.999 * converter / 12f64.sqrt() && floor.is_finite(), "{floor}");
    }

    #[test]
    fn fractional_shift_moves_a_smooth_signal() {
        let x: Vec<f64> = (0..200).map(|i| (i as f64 * 0.05).sin()).collect();
        let shifted = shift_samples(&x, 2.5);
        for (i, value) in shifted.iter().enumerate().take(190).skip(10) {
            assert!((value - ((i as f64 + 2.5) * 0.05).sin()).abs() < 1e-4);
        }
    }
}
