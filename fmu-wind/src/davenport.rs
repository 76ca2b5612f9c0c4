//! Davenport's wind spectrum (the seed paper's Eq. 2) and what follows from it: turbulence
//! intensity, the expected 3-s gust and the roughness length that matches a given gust factor.
//!
//! Convention (see `docs/wind-model.md`): Eq. 2 is the one-sided spectrum of the along-wind
//! gust per hertz, evaluated at `n = omega / 2 pi`; `x = beta omega = 1200 n / v_m`. Its
//! integral over `n` from 0 to infinity is Davenport's variance `6 kappa v_m^2`. Read as a
//! density per rad/s it would be wrong by `2 pi`.

use crate::error::WindError;
use std::f64::consts::PI;

/// Davenport's length scale in Eq. 2, `x = L n / v_m` with `L = 1200 m`.
pub const LENGTH_SCALE_M: f64 = 1200.0;

/// The surface drag coefficient `kappa = 1 / (2.5 ln(z / z0))^2` at height `z` over roughness
/// length `z0` (both m).
pub fn kappa_for_roughness(z: f64, z0: f64) -> f64 {
    1.0 / (2.5 * (z / z0).ln()).powi(2)
}

/// Eq. 2, the one place it is written: the one-sided spectrum of the along-wind gust per hertz
/// at `n_hz`, `S(n) = 4 kappa v_m^2 x^2 / (n (1 + x^2)^(4/3))`, `x = L n / v_m`, for the mean
/// speed `v_mean` (m/s) and surface drag coefficient `kappa`; zero at and below 0 Hz.
pub fn spectrum_per_hz(v_mean: f64, kappa: f64, n_hz: f64) -> f64 {
    if n_hz <= 0.0 {
        return 0.0;
    }
    let x = LENGTH_SCALE_M * n_hz / v_mean;
    // 4 kappa v^2 x^2 / n = 4 L kappa v x, so S = 4 L kappa v F(x) with F the normalised shape.
    4.0 * LENGTH_SCALE_M * v_mean * kappa * crate::prototype::davenport_shape(x)
}

/// Spectral moments of a wind speed averaged over a gust window within an averaging period, the
/// one place the gust integral is computed.
///
/// Within one averaging period `T0` the period's own mean removes the eddies slower than it (the
/// high-pass `1 - sinc^2(pi n T0)`), and the moving average of length `tau` adds the low-pass
/// `sinc^2(pi n tau)`. The integrals run by composite Simpson in `u = ln n` from `1e-4 / T0` to
/// `upper_hz`, dense enough to follow the sinc oscillations (60,000 intervals).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GustMoments {
    /// Variance of the speed about the period mean, `int S (1 - sinc^2(pi n T0)) dn`, (m/s)^2.
    pub record_variance: f64,
    /// Variance of the gust-window average about the period mean (its zeroth moment), (m/s)^2.
    pub m0: f64,
    /// Second spectral moment of the gust-window average, (m/s)^2 Hz^2.
    pub m2: f64,
}

impl GustMoments {
    /// The moments of the one-sided spectrum `psd` (per Hz) for gusts of `gust_duration` within
    /// `averaging_period` (both s), integrated up to `upper_hz`.
    pub fn of_spectrum(psd: &dyn Fn(f64) -> f64, gust_duration: f64, averaging_period: f64, upper_hz: f64) -> Self {
        let (tau, t0) = (gust_duration, averaging_period);
        let sinc2 = |a: f64| if a.abs() < 1e-8 { 1.0 } else { (a.sin() / a).powi(2) };
        let (u_lo, u_hi) = ((1e-4 / t0).ln(), upper_hz.ln());
        let intervals = 60_000usize;
        let du = (u_hi - u_lo) / intervals as f64;
        let (mut record, mut m0, mut m2) = (0.0, 0.0, 0.0);
        for k in 0..=intervals {
            let n = (u_lo + k as f64 * du).exp();
            let simpson = if k == 0 || k == intervals {
                1.0
            } else if k % 2 == 1 {
                4.0
            } else {
                2.0
            };
            let in_record = psd(n) * (1.0 - sinc2(PI * n * t0)) * n;
            let averaged = in_record * sinc2(PI * n * tau);
            record += simpson * in_record;
            m0 += simpson * averaged;
            m2 += simpson * averaged * n * n;
        }
        let scale = du / 3.0;
        Self { record_variance: record * scale, m0: m0 * scale, m2: m2 * scale }
    }

    /// The zero up-crossing rate `sqrt(m2 / m0)` of the gust-window average, Hz.
    pub fn crossing_rate_hz(&self) -> f64 {
        (self.m2 / self.m0).sqrt()
    }
}

/// Davenport's (1964) peak factor `g = sqrt(2 ln(nu T0)) + 0.5772 / sqrt(2 ln(nu T0))` for a
/// Gaussian process of zero up-crossing rate `nu` over a period `T0`. It assumes `nu T0` well
/// above 1 and is clamped at `nu T0 = e` (g = 1.73) below that.
pub fn peak_factor(crossing_rate_hz: f64, averaging_period: f64) -> f64 {
    let a = (2.0 * (crossing_rate_hz * averaging_period).max(std::f64::consts::E).ln()).sqrt();
    a + 0.5772 / a
}

/// Davenport's spectrum for a mean wind speed `v_mean` (m/s) at height `z` (m) over terrain of
/// roughness length `z0` (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Davenport {
    pub v_mean: f64,
    pub z: f64,
    pub z0: f64,
}

impl Davenport {
    /// Checks the parameters: a positive mean speed, and `0 < z0 < z`.
    pub fn new(v_mean: f64, z: f64, z0: f64) -> Result<Self, WindError> {
        let d = Self { v_mean, z, z0 };
        d.validate()?;
        Ok(d)
    }

    /// The checks of [`Davenport::new`], for values built with a struct literal.
    pub fn validate(&self) -> Result<(), WindError> {
        if !(self.v_mean.is_finite() && self.v_mean > 0.0) {
            return Err(WindError::MeanSpeed { v_mean: self.v_mean });
        }
        if !(self.z.is_finite() && self.z > 0.0) {
            return Err(WindError::ReferenceHeight { z: self.z });
        }
        if !(self.z0.is_finite() && self.z0 > 0.0 && self.z0 < self.z) {
            return Err(WindError::RoughnessLength { z: self.z, z0: self.z0 });
        }
        Ok(())
    }

    /// The surface drag coefficient `kappa = 1 / (2.5 ln(z / z0))^2`.
    pub fn kappa(&self) -> f64 {
        kappa_for_roughness(self.z, self.z0)
    }

    /// Davenport's gust variance `6 kappa v_m^2`, the integral of Eq. 2 over `n`.
    pub fn variance(&self) -> f64 {
        6.0 * self.kappa() * self.v_mean * self.v_mean
    }

    /// The gust standard deviation `sqrt(6 kappa) v_m`.
    pub fn sigma(&self) -> f64 {
        self.variance().sqrt()
    }

    /// The turbulence intensity `sigma / v_m = sqrt(6 kappa)`.
    pub fn turbulence_intensity(&self) -> f64 {
        (6.0 * self.kappa()).sqrt()
    }

    /// `beta = 600 / (pi v_m)` in seconds: Eq. 2 depends on `omega` only through `beta omega`.
    pub fn beta(&self) -> f64 {
        600.0 / (PI * self.v_mean)
    }

    /// One-sided spectrum per hertz at frequency `n_hz`, in (m/s)^2/Hz.
    pub fn psd_one_sided_per_hz(&self, n_hz: f64) -> f64 {
        spectrum_per_hz(self.v_mean, self.kappa(), n_hz)
    }

    /// Eq. 2 as written in the paper, at angular frequency `omega` (rad/s).
    ///
    /// It is the same number as [`Davenport::psd_one_sided_per_hz`] at `n = omega / 2 pi`: a
    /// density per hertz indexed by angular frequency.
    pub fn psd_at_omega(&self, omega: f64) -> f64 {
        spectrum_per_hz(self.v_mean, self.kappa(), omega / (2.0 * PI))
    }
}

/// The expected peak of a short-duration gust within an averaging period, from the spectrum.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GustEstimate {
    /// Expected largest `gust_duration` moving average within one `averaging_period`, m/s.
    pub gust_speed: f64,
    /// `gust_speed / v_mean`.
    pub gust_factor: f64,
    /// Davenport's peak factor `g`.
    pub peak_factor: f64,
    /// Standard deviation of the moving average about the period mean, m/s.
    pub sigma_band: f64,
    /// Mean zero up-crossing rate of that band-limited process, Hz.
    pub crossing_rate_hz: f64,
}

/// The expected `gust_duration` gust within an `averaging_period` (both in s).
///
/// The gust is the largest moving average of length `tau = gust_duration` of the wind speed
/// within one averaging period `T0`, measured against the mean over that period. Its
/// fluctuation is the Davenport process passed through the moving-average low-pass
/// `sinc^2(pi n tau)` and the high-pass `1 - sinc^2(pi n T0)` (the period mean moves too), so
/// `sigma_band^2 = integral S(n) sinc^2(pi n tau) (1 - sinc^2(pi n T0)) dn`. The expected
/// maximum over `T0` is `v_m + g sigma_band` with Davenport's (1964) peak factor
/// `g = sqrt(2 ln(nu T0)) + 0.5772 / sqrt(2 ln(nu T0))`, where `nu` is the band-limited
/// process's zero up-crossing rate `sqrt(m2 / m0)` from the spectral moments. The peak factor
/// assumes `nu T0` well above 1; it is clamped at `nu T0 = e` (g = 1.73) below that.
pub fn expected_gust(d: &Davenport, gust_duration: f64, averaging_period: f64) -> GustEstimate {
    let (tau, t0) = (gust_duration, averaging_period);
    // Up to 10 / tau's hundredfold (1e3 / tau), about 30 points per sinc period at 10 / tau.
    let upper_hz = 1e3 / tau;
    let mut moments = GustMoments::of_spectrum(&|n| d.psd_one_sided_per_hz(n), tau, t0, upper_hz);
    // Beyond the upper limit n_max, S ~ 4800 v kappa (1200 n / v)^(-5/3) and sinc^2 averages to
    // 1 / (2 pi^2 n^2 tau^2); m2's tail decays only as n_max^(-2/3), so add it analytically.
    let amplitude = 4.0 * LENGTH_SCALE_M * d.v_mean * d.kappa() * (LENGTH_SCALE_M / d.v_mean).powf(-5.0 / 3.0)
        / (2.0 * PI * PI * tau * tau);
    moments.m2 += amplitude * 1.5 * upper_hz.powf(-2.0 / 3.0);
    let nu = moments.crossing_rate_hz();
    let g = peak_factor(nu, t0);
    let sigma_band = moments.m0.sqrt();
    let gust_speed = d.v_mean + g * sigma_band;
    GustEstimate { gust_speed, gust_factor: gust_speed / d.v_mean, peak_factor: g, sigma_band, crossing_rate_hz: nu }
}

/// The roughness length `z0` for which [`expected_gust`] gives `target_gust_factor`.
///
/// The gust factor grows monotonically with `z0` (through `kappa`), so bisection in `ln z0`
/// over `[1e-6 m, z / e]` finds it; an error says when the target lies outside that range.
pub fn roughness_for_gust_factor(
    v_mean: f64,
    z: f64,
    target_gust_factor: f64,
    gust_duration: f64,
    averaging_period: f64,
) -> Result<f64, WindError> {
    let factor = |z0: f64| -> Result<f64, WindError> {
        let d = Davenport::new(v_mean, z, z0)?;
        Ok(expected_gust(&d, gust_duration, averaging_period).gust_factor)
    };
    let (mut lo, mut hi) = (1e-6f64.ln(), (z / std::f64::consts::E).ln());
    let (f_lo, f_hi) = (factor(lo.exp())?, factor(hi.exp())?);
    if !(f_lo..=f_hi).contains(&target_gust_factor) {
        return Err(WindError::GustFactorOutOfRange {
            target: target_gust_factor,
            reachable_lo: f_lo,
            reachable_hi: f_hi,
            v_mean,
        });
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if factor(mid.exp())? < target_gust_factor {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok((0.5 * (lo + hi)).exp())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kappa_and_sigma_match_the_physics_notes_for_the_paper_site() {
        // PHYSICS-NOTES point 4: kappa = 0.01544 and sigma = 0.304 v_m at z = 10 m, z0 = 0.4 m.
        let d = Davenport::new(3.0, 10.0, 0.4).unwrap();
        let expected_kappa = 1.0 / (2.5 * 25f64.ln()).powi(2);
        assert!((d.kappa() - expected_kappa).abs() < 1e-15);
        assert!((d.kappa() - 0.01544).abs() < 5e-6);
        assert!((d.sigma() / 3.0 - 0.304).abs() < 5e-4);
    }

    #[test]
    fn eq2_per_hz_integrates_to_davenports_variance() {
        // Trapezoid in ln n over 16 decades around the peak.
        for v in [0.5, 3.0, 9.5, 25.0] {
            let d = Davenport::new(v, 10.0, 0.4).unwrap();
            let (lo, hi, k) = ((1e-9f64).ln(), (1e7f64).ln(), 400_000);
            let du = (hi - lo) / k as f64;
            let integral: f64 = (0..=k)
                .map(|i| {
                    let n = (lo + i as f64 * du).exp();
                    let w = if i == 0 || i == k { 0.5 } else { 1.0 };
                    w * d.psd_one_sided_per_hz(n) * n * du
                })
                .sum();
            // The tail above 1e7 Hz holds (1200e7 / v)^(-2/3) of the variance: far below 1e-5.
            assert!((integral / d.variance() - 1.0).abs() < 1e-5, "v = {v}: {integral} vs {}", d.variance());
        }
    }

    #[test]
    fn eq2_in_omega_is_the_per_hz_density_at_omega_over_two_pi() {
        let d = Davenport::new(9.5, 10.0, 0.4).unwrap();
        for omega in [1e-3, 0.05, 1.0, 30.0] {
            let a = d.psd_at_omega(omega);
            let b = d.psd_one_sided_per_hz(omega / (2.0 * PI));
            assert!((a / b - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn invalid_parameters_are_reported_not_accepted() {
        assert!(Davenport::new(0.0, 10.0, 0.4).is_err());
        assert!(Davenport::new(3.0, 10.0, 10.0).is_err());
        assert!(Davenport::new(3.0, 10.0, -0.1).is_err());
        assert!(Davenport::new(f64::NAN, 10.0, 0.4).is_err());
    }

    #[test]
    fn gust_factor_grows_with_roughness_and_averaging_period() {
        let g = |z0: f64, t0: f64| expected_gust(&Davenport::new(9.8, 10.0, z0).unwrap(), 3.0, t0).gust_factor;
        assert!(g(0.01, 600.0) < g(0.03, 600.0));
        assert!(g(0.03, 600.0) < g(0.4, 600.0));
        assert!(g(0.03, 60.0) < g(0.03, 600.0));
        assert!(g(0.03, 600.0) < g(0.03, 3600.0));
    }

    #[test]
    fn band_variance_is_below_the_full_davenport_variance() {
        let d = Davenport::new(2.9, 10.0, 0.03).unwrap();
        let e = expected_gust(&d, 3.0, 600.0);
        assert!(e.sigma_band < d.sigma());
        assert!(e.sigma_band > 0.3 * d.sigma());
    }

    #[test]
    fn roughness_for_gust_factor_inverts_expected_gust() {
        let z0 = roughness_for_gust_factor(2.9, 10.0, 4.1 / 2.9, 3.0, 600.0).unwrap();
        let back = expected_gust(&Davenport::new(2.9, 10.0, z0).unwrap(), 3.0, 600.0);
        assert!((back.gust_speed - 4.1).abs() < 1e-6, "{back:?}");
        assert!(roughness_for_gust_factor(2.9, 10.0, 5.0, 3.0, 600.0).is_err());
    }
}
