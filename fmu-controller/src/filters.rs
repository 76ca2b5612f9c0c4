//! Discrete filters for the measured motor speed: an optional first-order low-pass and an
//! optional notch, both bilinear (Tustin) designs prewarped at their characteristic
//! frequency, so that the corner or notch lands exactly where asked at any sample rate.
//!
//! Each filter is a biquad in transposed direct form II; its frequency response is available
//! in closed form so that the linear loop model uses exactly the coefficients the controller
//! runs with.

use fmu_runtime::state::StateError;
use nalgebra::Complex;
use serde::{Deserialize, Serialize};

use crate::params::{NotchParams, VelocityLoopParams};

/// A second-order section `(b0 + b1 z^-1 + b2 z^-2) / (1 + a1 z^-1 + a2 z^-2)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Biquad {
    b: [f64; 3],
    a: [f64; 2],
    state: [f64; 2],
}

impl Biquad {
    /// The filter that passes its input unchanged.
    pub fn identity() -> Self {
        Self { b: [1.0, 0.0, 0.0], a: [0.0, 0.0], state: [0.0; 2] }
    }

    /// First-order low-pass `w / (s + w)` with its -3 dB corner at `corner_hz`.
    pub fn low_pass(corner_hz: f64, sample_time_s: f64) -> Self {
        let k = (std::f64::consts::PI * corner_hz * sample_time_s).tan();
        let gain = k / (1.0 + k);
        Self { b: [gain, gain, 0.0], a: [(k - 1.0) / (k + 1.0), 0.0], state: [0.0; 2] }
    }

    /// Notch `(s^2 + 2 d z w s + w^2) / (s^2 + 2 z w s + w^2)` centred at `frequency_hz`.
    pub fn notch(params: &NotchParams, sample_time_s: f64) -> Self {
        let k = (std::f64::consts::PI * params.frequency_hz * sample_time_s).tan();
        let zeta_pole = params.damping;
        let zeta_zero = params.depth * params.damping;
        // Substituting s/w = (z - 1) / (k (z + 1)) and clearing k^2 (z + 1)^2.
        let polynomial = |zeta: f64| [1.0 + 2.0 * zeta * k + k * k, 2.0 * k * k - 2.0, 1.0 - 2.0 * zeta * k + k * k];
        let num = polynomial(zeta_zero);
        let den = polynomial(zeta_pole);
        Self {
            b: [num[0] / den[0], num[1] / den[0], num[2] / den[0]],
            a: [den[1] / den[0], den[2] / den[0]],
            state: [0.0; 2],
        }
    }

    /// Filters one sample.
    pub fn process(&mut self, input: f64) -> f64 {
        let output = self.b[0] * input + self.state[0];
        self.state[0] = self.b[1] * input - self.a[0] * output + self.state[1];
        self.state[1] = self.b[2] * input - self.a[1] * output;
        output
    }

    /// Sets the state to the steady state for a constant input, so that switching the filter
    /// in does not make a transient.
    pub fn settle_at(&mut self, input: f64) {
        let dc_gain = (self.b[0] + self.b[1] + self.b[2]) / (1.0 + self.a[0] + self.a[1]);
        let output = dc_gain * input;
        self.state[1] = self.b[2] * input - self.a[1] * output;
        self.state[0] = self.b[1] * input - self.a[0] * output + self.state[1];
    }

    /// Frequency response at `omega` (rad/s) for the given sample time.
    pub fn response(&self, omega: f64, sample_time_s: f64) -> Complex<f64> {
        let z_inv = Complex::from_polar(1.0, -omega * sample_time_s);
        let num = self.b[0] + z_inv * (self.b[1] + z_inv * self.b[2]);
        let den = 1.0 + z_inv * (self.a[0] + z_inv * self.a[1]);
        num / den
    }

    /// The filter's state, the two delay elements.
    fn saved_state(&self) -> [f64; 2] {
        self.state
    }
}

/// The chain low-pass then notch on the measured motor speed, each present only when its
/// frequency is positive.
#[derive(Debug, Clone, PartialEq)]
pub struct SpeedFilter {
    low_pass: Option<Biquad>,
    notch: Option<Biquad>,
    sample_time_s: f64,
}

impl SpeedFilter {
    pub fn new(params: &VelocityLoopParams, sample_time_s: f64) -> Self {
        let low_pass =
            (params.speed_low_pass_hz > 0.0).then(|| Biquad::low_pass(params.speed_low_pass_hz, sample_time_s));
        let notch = (params.speed_notch.frequency_hz > 0.0).then(|| Biquad::notch(&params.speed_notch, sample_time_s));
        Self { low_pass, notch, sample_time_s }
    }

    pub fn process(&mut self, input: f64) -> f64 {
        let mut y = input;
        if let Some(f) = self.low_pass.as_mut() {
            y = f.process(y);
        }
        if let Some(f) = self.notch.as_mut() {
            y = f.process(y);
        }
        y
    }

    /// Starts the filters in steady state at a constant speed.
    pub fn settle_at(&mut self, input: f64) {
        if let Some(f) = self.low_pass.as_mut() {
            f.settle_at(input);
        }
        if let Some(f) = self.notch.as_mut() {
            f.settle_at(input);
        }
    }

    /// Frequency response of the chain at `omega`, rad/s.
    pub fn response(&self, omega: f64) -> Complex<f64> {
        let mut h = Complex::new(1.0, 0.0);
        for f in [&self.low_pass, &self.notch].into_iter().flatten() {
            h *= f.response(omega, self.sample_time_s);
        }
        h
    }

    pub(crate) fn saved_state(&self) -> SpeedFilterState {
        SpeedFilterState {
            low_pass: self.low_pass.as_ref().map(Biquad::saved_state),
            notch: self.notch.as_ref().map(Biquad::saved_state),
        }
    }

    /// Restores a state of a chain with the same filters; on error nothing changes.
    pub(crate) fn restore(&mut self, state: SpeedFilterState) -> Result<(), StateError> {
        let SpeedFilterState { low_pass, notch } = state;
        if low_pass.is_some() != self.low_pass.is_some() || notch.is_some() != self.notch.is_some() {
            return Err(StateError::Parts { part: "the speed filters" });
        }
        for (filter, saved) in [(&mut self.low_pass, low_pass), (&mut self.notch, notch)] {
            if let (Some(filter), Some(saved)) = (filter, saved) {
                filter.state = saved;
            }
        }
        Ok(())
    }
}

/// What an FMU state holds of a [`SpeedFilter`]: each present filter's two delay elements.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SpeedFilterState {
    pub low_pass: Option<[f64; 2]>,
    pub notch: Option<[f64; 2]>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    const TS: f64 = 1e-3;

    /// Runs a sine through the filter and returns the complex gain by correlation over whole
    /// periods after the transient.
    fn measured_response(filter: &mut Biquad, frequency_hz: f64) -> Complex<f64> {
        let period_samples = (1.0 / (frequency_hz * TS)).round() as usize;
        let f = 1.0 / (period_samples as f64 * TS);
        let settle = 50 * period_samples;
        let mut acc = Complex::new(0.0, 0.0);
        for k in 0..settle + 10 * period_samples {
            let phase = TAU * f * k as f64 * TS;
            let y = filter.process(phase.sin());
            if k >= settle {
                acc += y * Complex::new(phase.sin(), phase.cos());
            }
        }
        acc * 2.0 / (10 * period_samples) as f64
    }

    #[test]
    fn low_pass_is_3_db_down_at_its_corner_and_unity_at_dc() {
        let f = Biquad::low_pass(40.0, TS);
        let corner = f.response(TAU * 40.0, TS).norm();
        assert!((corner - 0.5f64.sqrt()).abs() < 1e-12, "{corner}");
        assert!((f.response(1e-9, TS).norm() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn notch_has_its_depth_at_its_frequency_and_unity_far_away() {
        let params = NotchParams { frequency_hz: 25.0, damping: 0.5, depth: 0.1 };
        let f = Biquad::notch(&params, TS);
        assert!((f.response(TAU * 25.0, TS).norm() - 0.1).abs() < 1e-12);
        assert!((f.response(TAU * 0.01, TS).norm() - 1.0).abs() < 1e-6);
        assert!((f.response(TAU * 499.0, TS).norm() - 1.0).abs() < 1e-2);
    }

    #[test]
    fn simulated_filters_match_their_closed_form_response() {
        for (mut filter, frequency) in [
            (Biquad::low_pass(30.0, TS), 20.0),
            (Biquad::notch(&NotchParams { frequency_hz: 22.0, damping: 0.4, depth: 0.2 }, TS), 25.0),
        ] {
            let expected = filter.response(TAU * 1.0 / ((1.0 / (frequency * TS)).round() * TS), TS);
            let got = measured_response(&mut filter, frequency);
            assert!((got - expected).norm() < 1e-6, "{got} vs {expected}");
        }
    }

    #[test]
    fn settled_filter_passes_a_constant_without_transient() {
        let params = VelocityLoopParams {
            speed_low_pass_hz: 50.0,
            speed_notch: NotchParams { frequency_hz: 20.0, damping: 0.3, depth: 0.05 },
            ..VelocityLoopParams::default()
        };
        let mut chain = SpeedFilter::new(&params, TS);
        chain.settle_at(123.0);
        for _ in 0..100 {
            let y = chain.process(123.0);
            assert!((y - 123.0).abs() < 1e-9, "{y}");
        }
    }
}
