//! The residual statistics the validate tool needs beyond `antenna_dsp`: the integrated
//! autocorrelation time (the effective number of independent samples of a coloured residual),
//! the sums of a sine-cosine pair's fit that the periodic searches scan with, and the Wald
//! statistic of a block of coefficients.
//! Autocorrelation, cross-correlation, the whiteness test, the fit percentage of a residual,
//! Welch spectra and the chi-squared distribution come from `antenna_dsp`.

/// Integrated autocorrelation time tau = 1 + 2 sum rho_k, summed until the autocorrelation
/// first drops below zero (the initial positive sequence; Geyer 1992). A white residual has
/// tau = 1; a residual correlated over m samples has about m. n / tau is the effective number
/// of independent samples, which keeps tests honest on coloured residuals. A constant record
/// has tau = 1.
pub fn correlation_time(x: &[f64]) -> f64 {
    let max_lag = (x.len() / 4).max(1).min(x.len().saturating_sub(1));
    if max_lag == 0 {
        return 1.0;
    }
    // One transform gives every lag, and a lag's value does not depend on how many are asked
    // for: the sum runs over the lags in order until the first that is not positive.
    let Ok(rho) = antenna_dsp::autocorrelation(x, max_lag) else { return 1.0 };
    let mut tau = 1.0;
    for &r in &rho[1..] {
        if r <= 0.0 {
            break;
        }
        tau += 2.0 * r;
    }
    f64::max(tau, 1.0)
}

/// Weighted sums of a sine-cosine pair's least-squares fit to a residual, accumulated row by
/// row: what the periodic searches (a cogging period, a harmonic of an encoder's error) scan
/// every trial period with, without forming the columns' normal equations.
#[derive(Debug, Clone, Copy, Default)]
pub struct SinCosSums {
    rc: f64,
    rs: f64,
    cc: f64,
    ss: f64,
    cs: f64,
}

impl SinCosSums {
    /// Adds one row: its weight, the residual, and the cosine and sine columns' values.
    pub fn add(&mut self, weight: f64, residual: f64, cos: f64, sin: f64) {
        self.rc += weight * residual * cos;
        self.rs += weight * residual * sin;
        self.cc += weight * cos * cos;
        self.ss += weight * sin * sin;
        self.cs += weight * cos * sin;
    }

    /// Whether the two columns are independent over the rows: their Gram determinant exceeds
    /// `relative` times the product of their squared norms (0: any positive determinant).
    pub fn independent(&self, relative: f64) -> bool {
        self.cc * self.ss - self.cs * self.cs > relative * self.cc * self.ss
    }

    /// The reduction of the residual's weighted sum of squares by the pair's fit; 0 when the
    /// columns are not independent.
    pub fn explained(&self) -> f64 {
        let det = self.cc * self.ss - self.cs * self.cs;
        if det > 0.0 {
            (self.ss * self.rc * self.rc - 2.0 * self.cs * self.rc * self.rs + self.cc * self.rs * self.rs) / det
        } else {
            0.0
        }
    }
}

/// The Wald statistic of the coefficients `range` of a least-squares fit being zero:
/// `beta` the coefficients, `covariance(a, b)` their covariance. The block is scaled to unit
/// variances before its pseudo-inverse, so the tolerance (1e-10) is relative to the
/// coefficients' own precision; a coefficient without variance adds nothing.
pub fn wald(beta: &[f64], covariance: impl Fn(usize, usize) -> f64, range: std::ops::Range<usize>) -> f64 {
    let k = range.len();
    let block = nalgebra::DMatrix::from_fn(k, k, |a, b| covariance(range.start + a, range.start + b));
    let scale: Vec<f64> = (0..k).map(|a| if block[(a, a)] > 0.0 { 1.0 / block[(a, a)].sqrt() } else { 0.0 }).collect();
    let correlation = nalgebra::DMatrix::from_fn(k, k, |a, b| block[(a, b)] * scale[a] * scale[b]);
    let standardised = nalgebra::DVector::from_fn(k, |a, _| beta[range.start + a] * scale[a]);
    correlation.pseudo_inverse(1e-10).map(|inv| (standardised.transpose() * inv * &standardised)[(0, 0)]).unwrap_or(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn correlation_time_is_one_for_white_and_longer_for_smoothed_noise() {
        use rand::SeedableRng;
        use rand_distr::Distribution;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let normal = rand_distr::Normal::new(0.0, 1.0).unwrap();
        let white: Vec<f64> = (0..20_000).map(|_| normal.sample(&mut rng)).collect();
        assert!((correlation_time(&white) - 1.0).abs() < 0.2, "{}", correlation_time(&white));
        // A 9-sample moving average has tau = 9 exactly (triangular autocorrelation).
        let smoothed: Vec<f64> = white.windows(9).map(|w| w.iter().sum::<f64>()).collect();
        let tau = correlation_time(&smoothed);
        assert!((tau - 9.0).abs() < 1.5, "{tau}");
        assert_eq!(correlation_time(&[2.0; 100]), 1.0);
    }

    #[test]
    fn a_sine_cosine_pair_explains_what_its_least_squares_fit_removes() {
        // Rows of an uneven angle grid, uneven weights, and a residual holding the pair plus
        // a part no pair at this period explains.
        let angles: Vec<f64> = (0..400).map(|i| 0.013 * i as f64 + 0.2 * (0.07 * i as f64).sin()).collect();
        let weights: Vec<f64> = (0..400).map(|i| 1.0 + 0.5 * ((i % 7) as f64)).collect();
        let residual: Vec<f64> = angles.iter().map(|q| 3.0 * (5.0 * q).sin() - 2.0 * (5.0 * q).cos() + q * q).collect();
        let (sin, cos): (Vec<f64>, Vec<f64>) = angles.iter().map(|q| (5.0 * q).sin_cos()).unzip();
        let mut sums = SinCosSums::default();
        for i in 0..angles.len() {
            sums.add(weights[i], residual[i], cos[i], sin[i]);
        }
        let (beta, _) = antenna_dsp::weighted_least_squares(&[cos.clone(), sin.clone()], &residual, &weights);
        let sum_of_squares =
            |r: &dyn Fn(usize) -> f64| (0..angles.len()).map(|i| weights[i] * r(i) * r(i)).sum::<f64>();
        let removed =
            sum_of_squares(&|i| residual[i]) - sum_of_squares(&|i| residual[i] - beta[0] * cos[i] - beta[1] * sin[i]);
        assert!(sums.independent(1e-12));
        assert!((sums.explained() - removed).abs() < 1e-9 * removed, "{} vs {removed}", sums.explained());
        // Two equal columns are not independent and explain nothing.
        let mut collinear = SinCosSums::default();
        for i in 0..angles.len() {
            collinear.add(1.0, residual[i], cos[i], cos[i]);
        }
        assert!(!collinear.independent(1e-12));
        assert_eq!(collinear.explained(), 0.0);
    }

    #[test]
    fn the_wald_statistic_is_the_squared_z_of_one_coefficient_and_ignores_the_others_scale() {
        let beta = [2.0, 3e-9, -1e6];
        let covariance = |a: usize, b: usize| match (a, b) {
            (0, 0) => 0.25,
            (1, 1) => 1e-18,
            (2, 2) => 4e10,
            (1, 2) | (2, 1) => 0.5 * 1e-9 * 2e5,
            _ => 0.0,
        };
        assert!((wald(&beta, covariance, 0..1) - 16.0).abs() < 1e-12);
        // Two correlated coefficients of very different sizes: z = (3, -5), correlation 0.5,
        // so W = (9 + 25 + 2 * 0.5 * 15) / (1 - 0.25).
        let expected = (9.0 + 25.0 + 15.0) / 0.75;
        assert!(
            (wald(&beta, covariance, 1..3) - expected).abs() < 1e-9 * expected,
            "{}",
            wald(&beta, covariance, 1..3)
        );
    }
}
