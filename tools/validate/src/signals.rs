//! The noise of a logged torque or current, the level every effect's size is judged against: its
//! own white-noise estimate, tightened by what a linear filter of the measured positions
//! explains, and floored at the resolution it was logged with. The generic conditioning
//! (Savitzky-Golay filters, noise estimates, interpolation, shifts) is `antenna_dsp::conditioning`.

use antenna_dsp::conditioning::{noise_sigma, resolution};
use antenna_dsp::weighted_least_squares;

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

#[cfg(test)]
mod tests {
    use super::*;

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
}
