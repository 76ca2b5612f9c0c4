//! The Davenport spectrum of the paper's Eq. 2 in the form the fits need (parametrised by
//! kappa), with its closed-form variance, peaks and inertial-subrange level. Eq. 2 itself is
//! written once, in `fmu_wind::davenport`; this is a view of it.

use fmu_wind::davenport::{kappa_for_roughness, spectrum_per_hz};

/// Davenport's length scale in Eq. 2 (x = L n / v_m), m.
pub const DAVENPORT_LENGTH_M: f64 = fmu_wind::davenport::LENGTH_SCALE_M;

/// The Davenport spectrum of the paper's Eq. 2, one-sided per Hz:
/// S(n) = 4 kappa v_m^2 x^2 / (n (1 + x^2)^(4/3)), x = L n / v_m, L = 1200 m.
///
/// The fits work with kappa directly, where `fmu_wind::davenport::Davenport` is parametrised by
/// z and z0; both evaluate `fmu_wind::davenport::spectrum_per_hz`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DavenportSpectrum {
    /// Mean wind speed, m/s.
    pub v_mean_m_s: f64,
    /// Surface drag coefficient kappa = 1 / (2.5 ln(z / z0))^2.
    pub kappa: f64,
}

impl DavenportSpectrum {
    /// kappa for height `z_m` and roughness length `z0_m`.
    pub fn kappa_for_roughness(z_m: f64, z0_m: f64) -> f64 {
        kappa_for_roughness(z_m, z0_m)
    }

    /// The roughness length z0 that gives `kappa` at height `z_m` (inverse of
    /// [`DavenportSpectrum::kappa_for_roughness`]).
    pub fn roughness_for_kappa(z_m: f64, kappa: f64) -> f64 {
        z_m * (-1.0 / (2.5 * kappa.sqrt())).exp()
    }

    /// The spectrum for mean speed `v_mean_m_s` at height `z_m` over roughness `z0_m`.
    pub fn from_roughness(v_mean_m_s: f64, z_m: f64, z0_m: f64) -> Self {
        Self { v_mean_m_s, kappa: Self::kappa_for_roughness(z_m, z0_m) }
    }

    /// The spectrum whose inertial-subrange asymptote is `level * n^(-5/3)` (see
    /// [`DavenportSpectrum::inertial_level`]).
    pub fn from_inertial_level(v_mean_m_s: f64, level: f64) -> Self {
        let kappa = level * DAVENPORT_LENGTH_M.powf(2.0 / 3.0) / (4.0 * v_mean_m_s.powf(8.0 / 3.0));
        Self { v_mean_m_s, kappa }
    }

    /// One-sided PSD per Hz at frequency `n_hz` ((m/s)^2/Hz).
    pub fn psd(&self, n_hz: f64) -> f64 {
        spectrum_per_hz(self.v_mean_m_s, self.kappa, n_hz)
    }

    /// Total variance, the integral of the PSD: 6 kappa v_m^2.
    pub fn variance(&self) -> f64 {
        6.0 * self.kappa * self.v_mean_m_s.powi(2)
    }

    /// Variance below frequency `n_hz`: 6 kappa v_m^2 (1 - (1 + x^2)^(-1/3)).
    pub fn variance_below(&self, n_hz: f64) -> f64 {
        let x = DAVENPORT_LENGTH_M * n_hz.max(0.0) / self.v_mean_m_s;
        self.variance() * (1.0 - (1.0 + x * x).powf(-1.0 / 3.0))
    }

    /// Frequency of the maximum of S(n): dS/dn = 0 at x^2 = 3/5, so n = sqrt(3/5) v_m / L.
    pub fn peak_frequency_hz(&self) -> f64 {
        (3.0f64 / 5.0).sqrt() * self.v_mean_m_s / DAVENPORT_LENGTH_M
    }

    /// Frequency of the maximum of n S(n), the peak on a log-frequency axis (where most
    /// variance lives per decade): x^2 = 3, n = sqrt(3) v_m / L.
    pub fn premultiplied_peak_frequency_hz(&self) -> f64 {
        3.0f64.sqrt() * self.v_mean_m_s / DAVENPORT_LENGTH_M
    }

    /// Coefficient A of the high-frequency asymptote S(n) ~ A n^(-5/3) (x >> 1):
    /// A = 4 kappa v_m^(8/3) / L^(2/3).
    pub fn inertial_level(&self) -> f64 {
        4.0 * self.kappa * self.v_mean_m_s.powf(8.0 / 3.0) / DAVENPORT_LENGTH_M.powf(2.0 / 3.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::generator::log_grid;

    #[test]
    fn davenport_closed_forms_match_numerical_integration_and_maxima() {
        let model = DavenportSpectrum::from_roughness(3.0, 10.0, 0.4);
        // PHYSICS-NOTES item 4: kappa = 0.01544 and sigma = 0.304 v_m for z = 10 m, z0 = 0.4 m.
        assert!((model.kappa - 0.01544).abs() < 5e-6, "kappa {}", model.kappa);
        assert!(((model.variance().sqrt() / 3.0) - 0.304).abs() < 5e-4);
        // Integral of the PSD over a log grid (trapezoid in ln n).
        let grid = log_grid(1e-7, 1e5, 2000);
        let integral = |upper: f64| -> f64 {
            grid.windows(2)
                .filter(|w| w[1] <= upper)
                .map(|w| 0.5 * (model.psd(w[0]) * w[0] + model.psd(w[1]) * w[1]) * (w[1] / w[0]).ln())
                .sum()
        };
        assert!((integral(1e5) / model.variance() - 1.0).abs() < 1e-3);
        let n = grid.iter().copied().find(|n| *n >= 0.01).unwrap();
        assert!((integral(n) / model.variance_below(n) - 1.0).abs() < 2e-3);
        // The stated peaks are the maxima of S(n) and n S(n) on a dense grid.
        let argmax = |f: &dyn Fn(f64) -> f64| grid.iter().copied().max_by(|a, b| f(*a).total_cmp(&f(*b))).unwrap();
        let peak = argmax(&|n| model.psd(n));
        let premultiplied = argmax(&|n| n * model.psd(n));
        assert!((peak / model.peak_frequency_hz() - 1.0).abs() < 0.01);
        assert!((premultiplied / model.premultiplied_peak_frequency_hz() - 1.0).abs() < 0.01);
        // The inertial asymptote and its inverse.
        let far = 100.0;
        assert!((model.psd(far) * far.powf(5.0 / 3.0) / model.inertial_level() - 1.0).abs() < 1e-4);
        let back = DavenportSpectrum::from_inertial_level(3.0, model.inertial_level());
        assert!((back.kappa / model.kappa - 1.0).abs() < 1e-12);
        assert!((DavenportSpectrum::roughness_for_kappa(10.0, model.kappa) - 0.4).abs() < 1e-12);
    }
}
