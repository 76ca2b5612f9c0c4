//! Conditioning of sampled signals before they are fitted: zero-phase Savitzky-Golay smoothing
//! and differentiation, a Gaussian smoothing kernel, model-free white-noise estimates, the
//! resolution a record was written with, linear interpolation onto another grid and fractional
//! sample shifts.
//!
//! Savitzky-Golay filters fit a polynomial over a symmetric window, so they have no phase lag
//! and no delay: an acceleration from them lines up in time with the torque it is compared with,
//! which matters because a lag would look like a time delay in a residual. They are exact for
//! polynomials up to their order, so slow motion passes undistorted.

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
    ///
    /// Each output is the sum of its products in coefficient order, started from the value an
    /// empty `f64` sum has, so it equals `coefficients.iter().zip(window).map(|(c, v)| c * v).sum()`
    /// bit for bit. The outputs are computed eight at a time: one sum alone waits for
    /// each addition before the next, while independent sums side by side fill the vector lanes.
    pub fn apply(coefficients: &[f64], x: &[f64]) -> Vec<f64> {
        let m = coefficients.len();
        if x.len() < m {
            return Vec::new();
        }
        let count = x.len() - m + 1;
        let empty_sum: f64 = std::iter::empty::<f64>().sum();
        let mut out = Vec::with_capacity(count);
        let blocked = count - count % APPLY_LANES;
        for first in (0..blocked).step_by(APPLY_LANES) {
            let mut sums = [empty_sum; APPLY_LANES];
            for (k, c) in coefficients.iter().enumerate() {
                let inputs = &x[first + k..first + k + APPLY_LANES];
                for (sum, v) in sums.iter_mut().zip(inputs) {
                    *sum += c * v;
                }
            }
            out.extend_from_slice(&sums);
        }
        out.extend((blocked..count).map(|i| coefficients.iter().zip(&x[i..i + m]).map(|(c, v)| c * v).sum::<f64>()));
        out
    }

    /// Noise gain: the output standard deviation for unit white input.
    pub fn gain(coefficients: &[f64]) -> f64 {
        coefficients.iter().map(|c| c * c).sum::<f64>().sqrt()
    }
}

/// How many outputs [`SavitzkyGolay::apply`] computes side by side.
const APPLY_LANES: usize = 8;

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
    let mut out = Vec::with_capacity(x.len());
    shift_samples_into(x, shift, 0..x.len(), &mut out);
    out
}

/// The samples `range` of [`shift_samples`] written into `out` (cleared first), the same
/// values without the rest of the record or a new allocation: a search over many shifts
/// reuses one buffer.
pub fn shift_samples_into(x: &[f64], shift: f64, range: std::ops::Range<usize>, out: &mut Vec<f64>) {
    let n = x.len() as isize;
    let at = |i: isize| x[i.clamp(0, n - 1) as usize];
    out.clear();
    out.extend(range.map(|i| {
        let s = i as f64 + shift;
        let k = s.floor() as isize;
        let f = s - k as f64;
        let (p0, p1, p2, p3) = (at(k - 1), at(k), at(k + 1), at(k + 2));
        p1 + 0.5 * f * (p2 - p0 + f * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 + f * (3.0 * (p1 - p2) + p3 - p0)))
    }));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_shifted_range_reuses_its_buffer_and_equals_the_whole_shift() {
        let x: Vec<f64> = (0..200).map(|i| (0.07 * i as f64).sin() + 0.01 * i as f64).collect();
        let mut out = vec![9.0; 7];
        for shift in [-3.3, -0.5, 0.0, 0.25, 4.75] {
            let whole = shift_samples(&x, shift);
            shift_samples_into(&x, shift, 20..180, &mut out);
            assert_eq!(out.as_slice(), &whole[20..180], "shift {shift}");
        }
    }

    #[test]
    fn smoothing_side_by_side_equals_each_output_summed_alone_bit_for_bit() {
        let kernel = gaussian_kernel(2.7);
        let m = kernel.len();
        for len in [m - 1, m, m + 1, m + APPLY_LANES - 1, m + APPLY_LANES, m + 3 * APPLY_LANES + 5] {
            // Signed zeros and values of very different size: any change of the order of the
            // additions or of the starting value would show in some output's bits.
            let x: Vec<f64> = (0..len)
                .map(|i| match i % 5 {
                    0 => -0.0,
                    1 => 1e12 * (0.3 * i as f64).sin(),
                    _ => (1.7 * i as f64).cos() / 3.0,
                })
                .collect();
            let alone: Vec<f64> = if len < m {
                Vec::new()
            } else {
                (0..=len - m).map(|i| kernel.iter().zip(&x[i..i + m]).map(|(c, v)| c * v).sum()).collect()
            };
            let side_by_side = SavitzkyGolay::apply(&kernel, &x);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&side_by_side), bits(&alone), "length {len}");
        }
        let zeros = SavitzkyGolay::apply(&kernel, &vec![-0.0; m + APPLY_LANES]);
        let empty_sum: f64 = std::iter::empty::<f64>().sum();
        assert!(zeros.iter().all(|z| z.to_bits() == (empty_sum + kernel[0] * -0.0).to_bits()));
    }

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
    fn fractional_shift_moves_a_smooth_signal() {
        let x: Vec<f64> = (0..200).map(|i| (i as f64 * 0.05).sin()).collect();
        let shifted = shift_samples(&x, 2.5);
        for (i, value) in shifted.iter().enumerate().take(190).skip(10) {
            assert!((value - ((i as f64 + 2.5) * 0.05).sin()).abs() < 1e-4);
        }
    }
}
