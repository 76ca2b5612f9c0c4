//! Sensor imperfections a log variant can add on top of white noise and quantisation: the load
//! encoder's graduation and eccentricity error, a speed signal's drifting bias, and reading a
//! true signal at instants shifted against the log's time stamps (a time skew between
//! signals).
//!
//! Everything random here is drawn from streams seeded apart from the simulation's own, so
//! that switching a variant on changes nothing else in the log and the default logs stay bit
//! for bit what they were.

use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};

/// The harmonics of the load encoder's error when none are given: the eccentricity (once per
/// revolution) and graduation errors at a few higher orders, as a ring or disc encoder's
/// calibration curve shows them.
pub const DEFAULT_ENCODER_HARMONICS: [u32; 6] = [1, 2, 4, 8, 16, 36];

/// Graduation and eccentricity error of the load encoder: the reading is the true angle q
/// plus the sum over the harmonics k of a_k sin(k q + phi_k), with amplitudes and phases drawn
/// from the log's seed and scaled so that the error's RMS over a revolution is `rms`.
#[derive(Debug, Clone, PartialEq)]
pub struct EncoderError {
    /// RMS of the error over a revolution (rad); 0 is no error.
    pub rms: f64,
    /// The harmonic orders (cycles per revolution of the load).
    pub harmonics: Vec<u32>,
}

impl Default for EncoderError {
    /// No error: a perfect graduation on a centred disc.
    fn default() -> Self {
        EncoderError { rms: 0.0, harmonics: DEFAULT_ENCODER_HARMONICS.to_vec() }
    }
}

/// One harmonic of an encoder error: amplitude (rad) and phase (rad) at `order` cycles per
/// revolution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Harmonic {
    pub order: u32,
    pub amplitude: f64,
    pub phase: f64,
}

impl EncoderError {
    /// Whether the encoder has an error at all.
    pub fn is_on(&self) -> bool {
        self.rms > 0.0 && !self.harmonics.is_empty()
    }

    /// The harmonics of a log with this seed. The relative amplitudes are drawn uniformly
    /// between 0.5 and 1.5 (no order dominates by construction) and the phases uniformly, from
    /// a stream of their own; the amplitudes are then scaled so that the RMS over a revolution,
    /// sqrt(sum a_k^2 / 2), is `rms`. Repeated orders count once.
    pub fn terms(&self, seed: u64) -> Vec<Harmonic> {
        let mut orders = self.harmonics.clone();
        orders.sort_unstable();
        orders.dedup();
        orders.retain(|k| *k > 0);
        if self.rms <= 0.0 || orders.is_empty() {
            return Vec::new();
        }
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0xe4c0_de4e_7707_0001);
        let pi = std::f64::consts::PI;
        let mut terms: Vec<Harmonic> = orders
            .into_iter()
            .map(|order| Harmonic { order, amplitude: rng.random_range(0.5..1.5), phase: rng.random_range(-pi..pi) })
            .collect();
        let scale = self.rms / harmonics_rms(&terms);
        for term in &mut terms {
            term.amplitude *= scale;
        }
        terms
    }
}

/// The error of an encoder with these harmonics at the true angle `q` (rad).
pub fn encoder_error(terms: &[Harmonic], q: f64) -> f64 {
    terms.iter().map(|t| t.amplitude * (f64::from(t.order) * q + t.phase).sin()).sum()
}

/// The RMS over a revolution of a sum of distinct harmonics: sqrt(sum a_k^2 / 2).
pub fn harmonics_rms(terms: &[Harmonic]) -> f64 {
    (terms.iter().map(|t| t.amplitude * t.amplitude).sum::<f64>() / 2.0).sqrt()
}

/// A drifting bias of `len` samples: a random walk (the sum of unit normal steps from a normal
/// start) scaled so that its RMS over the samples is `rms`. Drawn from a stream of its own
/// for each `column`, so two speed signals drift independently.
pub fn random_walk_drift(len: usize, rms: f64, seed: u64, column: u64) -> Vec<f64> {
    if len == 0 || rms <= 0.0 {
        return vec![0.0; len];
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0xd21f_7000_0000_0000 ^ column);
    let unit = Normal::new(0.0, 1.0).expect("unit normal");
    let mut level = unit.sample(&mut rng);
    let mut walk = Vec::with_capacity(len);
    for _ in 0..len {
        walk.push(level);
        level += unit.sample(&mut rng);
    }
    let own = (walk.iter().map(|w| w * w).sum::<f64>() / len as f64).sqrt();
    walk.iter().map(|w| w * rms / own.max(f64::MIN_POSITIVE)).collect()
}

/// The value at time `t` of a signal recorded every `dt` from time 0, linearly interpolated
/// between the internal steps and held at the first and last value outside the record (a
/// skewed reading at the log's ends has nothing else to read).
pub fn sample_linear(values: &[f64], dt: f64, t: f64) -> f64 {
    let Some(&last) = values.last() else { return 0.0 };
    let position = t / dt;
    if position <= 0.0 {
        return values[0];
    }
    let whole = position.floor() as usize;
    if whole + 1 >= values.len() {
        return last;
    }
    let frac = position - whole as f64;
    (1.0 - frac) * values[whole] + frac * values[whole + 1]
}

/// The value at time `t` of a sampled-and-held signal recorded every `dt` from time 0 (the
/// current command, which changes only at controller samples), held outside the record.
/// A tiny tolerance keeps an instant that lands on a step, up to rounding, on that step.
pub fn sample_held(values: &[f64], dt: f64, t: f64) -> f64 {
    let Some(&last) = values.last() else { return 0.0 };
    let position = (t / dt + 1e-9).floor();
    if position <= 0.0 {
        return values[0];
    }
    values.get(position as usize).copied().unwrap_or(last)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encoder_error_terms_have_the_asked_rms_over_a_revolution() {
        let error = EncoderError { rms: 2e-6, harmonics: vec![1, 2, 4, 8, 16, 36] };
        let terms = error.terms(3);
        assert_eq!(terms.len(), 6);
        let n = 100_000;
        let two_pi = 2.0 * std::f64::consts::PI;
        let sampled = ((0..n).map(|i| encoder_error(&terms, two_pi * i as f64 / n as f64).powi(2)).sum::<f64>()
            / n as f64)
            .sqrt();
        assert!((sampled / 2e-6 - 1.0).abs() < 1e-6, "{sampled:e}");
        // Another seed draws other phases.
        assert_ne!(terms, error.terms(4));
        assert!(EncoderError::default().terms(3).is_empty());
    }

    #[test]
    fn random_walk_drift_has_the_asked_rms_and_moves_slowly() {
        let drift = random_walk_drift(30_000, 5e-7, 9, 0);
        let rms = (drift.iter().map(|d| d * d).sum::<f64>() / drift.len() as f64).sqrt();
        assert!((rms / 5e-7 - 1.0).abs() < 1e-9);
        // A walk, not white noise: a step is a small part of the RMS.
        let steps = drift.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum::<f64>() / drift.len() as f64;
        assert!(steps.sqrt() < 0.05 * rms);
        assert_ne!(drift, random_walk_drift(30_000, 5e-7, 9, 1));
    }

    #[test]
    fn sampling_at_shifted_instants_interpolates_and_holds() {
        let values = [0.0, 1.0, 4.0, 9.0];
        assert_eq!(sample_linear(&values, 0.5, 0.75), 2.5);
        assert_eq!(sample_linear(&values, 0.5, -1.0), 0.0);
        assert_eq!(sample_linear(&values, 0.5, 10.0), 9.0);
        assert_eq!(sample_held(&values, 0.5, 0.75), 1.0);
        assert_eq!(sample_held(&values, 0.5, 1.0), 4.0);
        assert_eq!(sample_held(&values, 0.5, 9.0), 9.0);
    }
}
