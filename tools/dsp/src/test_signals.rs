//! Reproducible test signals (seeded Gaussian noise and processes with an exactly known
//! spectrum) shared by the unit tests of this crate.

use rand_chacha::rand_core::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use rustfft::num_complex::Complex64;
use rustfft::FftPlanner;

/// `len` samples of zero-mean Gaussian white noise with standard deviation `sigma`.
pub fn white_noise(len: usize, sigma: f64, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..len)
        .map(|_| {
            let z: f64 = StandardNormal.sample(&mut rng);
            sigma * z
        })
        .collect()
}

/// A stationary Gaussian process whose one-sided PSD per Hz is exactly `psd(f)` at every
/// Fourier frequency of the record (circular spectral synthesis: white noise is shaped in the
/// frequency domain, so the record is one period of a periodic process with that spectrum).
pub fn process_with_psd(len: usize, sample_rate_hz: f64, seed: u64, psd: impl Fn(f64) -> f64) -> Vec<f64> {
    // Unit-variance white noise has a one-sided PSD of 2/fs; scaling bin k by
    // sqrt(psd(f_k) fs / 2) gives the target density.
    let noise = white_noise(len, 1.0, seed);
    let mut spectrum: Vec<Complex64> = noise.iter().map(|&v| Complex64::new(v, 0.0)).collect();
    let mut planner = FftPlanner::<f64>::new();
    planner.plan_fft_forward(len).process(&mut spectrum);
    for (k, value) in spectrum.iter_mut().enumerate() {
        let bin = k.min(len - k);
        let f = bin as f64 * sample_rate_hz / len as f64;
        let gain = if bin == 0 { 0.0 } else { (psd(f) * sample_rate_hz / 2.0).sqrt() };
        *value *= gain;
    }
    planner.plan_fft_inverse(len).process(&mut spectrum);
    spectrum.iter().map(|c| c.re / len as f64).collect()
}
