//! A measured frequency response beside its model, bin by bin: which bins the coherence lets
//! us trust, and how far apart measurement and model are there. Shared by the plant
//! identification (Figs. 6 and 8) and the closed velocity loop (Figs. 7 and 9).

use rustfft::num_complex::Complex64;

/// Borrowed views of an H1 estimate, its coherence and the model at the same bins.
#[derive(Debug, Clone, Copy)]
pub struct ResponseComparison<'a> {
    pub frequency_hz: &'a [f64],
    pub measured: &'a [Complex64],
    pub analytic: &'a [Complex64],
    pub coherence: &'a [f64],
}

impl ResponseComparison<'_> {
    /// Bins where the coherence exceeds `threshold`, up to `max_frequency_hz`.
    pub fn coherent_bins(&self, threshold: f64, max_frequency_hz: f64) -> Vec<usize> {
        (0..self.frequency_hz.len())
            .filter(|&i| self.coherence[i] > threshold && self.frequency_hz[i] <= max_frequency_hz)
            .collect()
    }

    /// Largest |20 log10 |measured / analytic|| over `bins`, dB, with its frequency (NaN when
    /// `bins` is empty).
    pub fn max_magnitude_error_db(&self, bins: &[usize]) -> (f64, f64) {
        bins.iter()
            .map(|&i| {
                ((20.0 * (self.measured[i].norm() / self.analytic[i].norm()).log10()).abs(), self.frequency_hz[i])
            })
            .fold((0.0, f64::NAN), |best, e| if e.0 > best.0 { e } else { best })
    }

    /// Largest |phase(measured / analytic)| over `bins`, deg (the ratio's phase, so wrapped to
    /// +/-180 and free of unwrapping ambiguities).
    pub fn max_phase_error_deg(&self, bins: &[usize]) -> f64 {
        bins.iter().map(|&i| (self.measured[i] / self.analytic[i]).arg().to_degrees().abs()).fold(0.0, f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_are_taken_only_over_the_coherent_bins() {
        let frequency_hz = [1.0, 2.0, 3.0];
        let analytic = [Complex64::new(1.0, 0.0); 3];
        // 6 dB off at the incoherent bin, 1 dB and 10 deg off at a coherent one.
        let one_db = 10f64.powf(1.0 / 20.0);
        let measured =
            [Complex64::new(2.0, 0.0), Complex64::from_polar(one_db, 10f64.to_radians()), Complex64::new(1.0, 0.0)];
        let coherence = [0.5, 0.95, 0.99];
        let c = ResponseComparison {
            frequency_hz: &frequency_hz,
            measured: &measured,
            analytic: &analytic,
            coherence: &coherence,
        };
        let bins = c.coherent_bins(0.9, 10.0);
        assert_eq!(bins, vec![1, 2]);
        let (db, at) = c.max_magnitude_error_db(&bins);
        assert!((db - 1.0).abs() < 1e-12 && at == 2.0);
        assert!((c.max_phase_error_deg(&bins) - 10.0).abs() < 1e-9);
        assert_eq!(c.coherent_bins(0.9, 2.5), vec![1]);
    }
}
