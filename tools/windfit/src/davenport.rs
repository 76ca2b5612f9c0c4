//! The Davenport spectrum of the paper's Eq. 2 in the form the fits need (parametrised by
//! kappa), with its closed-form variance, peaks and inertial-subrange level.

use crate::DAVENPORT_LENGTH_M;

/// The Davenport spectrum of the paper's Eq. 2, one-sided per Hz:
/// S(n) = 4 kappa v_m^2 x^2 / (n (1 + x^2)^(4/3)), x = L n / v_m, L = 1200 m.
///
/// Kept local (a few lines) because the fitting works with kappa directly, where
/// `fmu_wind::davenport::Davenport` is parametrised by z and z0; both implement the same
/// formula, and [`compare_generator`] checks the fmu-wind filter against it.
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
        1.0 / (2.5 * (z_m / z0_m).ln()).powi(2)
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
        if n_hz <= 0.0 {
            return 0.0;
        }
        let x = DAVENPORT_LENGTH_M * n_hz / self.v_mean_m_s;
        4.0 * self.kappa * self.v_mean_m_s.powi(2) * x * x / (n_hz * (1.0 + x * x).powf(4.0 / 3.0))
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
