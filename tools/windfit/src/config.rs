//! The settings of the analysis, their defaults and their checks.

use crate::error::WindFitError;
use antenna_dsp::{self, window_samples};

/// The seed paper's roughness length for the MeerKAT site (sparse shrubs), m.
pub const PAPER_Z0_M: f64 = 0.4;

/// Settings of the analysis.
#[derive(Debug, Clone, PartialEq)]
pub struct WindFitConfig {
    /// Instrument height above ground, m.
    pub height_m: f64,
    /// Zero-plane displacement (about 2/3 of a canopy's height), m; Eq. 2 as printed uses
    /// z itself (displacement 0), over a canopy z - d is the usual effective height.
    pub displacement_m: f64,
    /// Roughness length of the reference curve (the paper's 0.4 m by default), m.
    pub reference_z0_m: f64,
    /// Welch segment length, s (at most a third of the record is used, see
    /// [`WindFitConfig::segment_samples`]).
    pub segment_s: f64,
    /// Log-frequency bands per decade for plotting and fitting.
    pub bands_per_decade: f64,
    /// Inertial-subrange fit range, Hz; `None` chooses it from the record (see
    /// [`WindFitConfig::fit_band`]).
    pub fit_band_hz: Option<(f64, f64)>,
    /// Gust averaging time, s (3 s for the 3-second gust).
    pub gust_window_s: f64,
    /// Confidence level of intervals (0.95).
    pub confidence: f64,
    /// Averaging periods for the turbulence-intensity and gust-factor summary, s.
    pub averaging_periods_s: Vec<f64>,
}

impl WindFitConfig {
    /// Defaults for an instrument at `height_m`: no displacement, the paper's z0 = 0.4 m as
    /// reference, 600-s Welch segments, 10 bands per decade, automatic fit range, 3-s gusts,
    /// 95 % confidence, summary over 1, 5, 10 and 30 min.
    pub fn new(height_m: f64) -> Self {
        Self {
            height_m,
            displacement_m: 0.0,
            reference_z0_m: PAPER_Z0_M,
            segment_s: 600.0,
            bands_per_decade: 10.0,
            fit_band_hz: None,
            gust_window_s: 3.0,
            confidence: 0.95,
            averaging_periods_s: vec![60.0, 300.0, 600.0, 1800.0],
        }
    }

    /// Height used in kappa = 1 / (2.5 ln((z - d) / z0))^2.
    pub fn effective_height_m(&self) -> f64 {
        self.height_m - self.displacement_m
    }

    /// Welch segment length in samples: `segment_s`, but at most a third of the record so that
    /// at least five half-overlapping segments are averaged.
    pub fn segment_samples(&self, record_len: usize, sample_rate_hz: f64) -> usize {
        window_samples(self.segment_s, sample_rate_hz).min(record_len / 3)
    }

    /// The inertial-subrange fit range: the configured one, or from `v_mean / (z - d)` (where
    /// the inertial subrange of the longitudinal spectrum starts, n (z - d) / v_m near 1 in
    /// Kaimal et al. 1972) up to an eighth of the sample rate (aliasing of a -5/3 tail adds
    /// less than 4 % there, 7^(-5/3); sonic path averaging also starts to act near the top).
    pub fn fit_band(&self, v_mean_m_s: f64, sample_rate_hz: f64) -> (f64, f64) {
        self.fit_band_hz.unwrap_or((v_mean_m_s / self.effective_height_m(), sample_rate_hz / 8.0))
    }

    pub(crate) fn validate(&self) -> Result<(), WindFitError> {
        let positive = |setting: &'static str, value: f64| {
            if value > 0.0 && value.is_finite() {
                Ok(())
            } else {
                Err(WindFitError::NotPositive { setting, value })
            }
        };
        positive("height", self.height_m)?;
        positive("effective height (height - displacement)", self.effective_height_m())?;
        positive("reference z0", self.reference_z0_m)?;
        positive("segment length", self.segment_s)?;
        positive("bands per decade", self.bands_per_decade)?;
        positive("gust window", self.gust_window_s)?;
        if self.reference_z0_m >= self.effective_height_m() {
            return Err(WindFitError::RoughnessAboveHeight {
                z0_m: self.reference_z0_m,
                effective_height_m: self.effective_height_m(),
            });
        }
        if !(self.confidence > 0.0 && self.confidence < 1.0) {
            return Err(WindFitError::Confidence(self.confidence));
        }
        if let Some((low, high)) = self.fit_band_hz {
            if !(low > 0.0 && high > low) {
                return Err(WindFitError::FitBand { low_hz: low, high_hz: high });
            }
        }
        Ok(())
    }
}
