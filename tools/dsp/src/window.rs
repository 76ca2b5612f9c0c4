//! Data windows for spectral estimation.
//!
//! All windows are the periodic ("DFT-even") form, `w[t]` for `t = 0..len` of a window of period
//! len, which is the right form for segment-averaged spectra: its DFT has the exact sidelobe
//! structure the window is designed for and consecutive 50 %-overlapped Hann windows sum to a
//! constant.

use std::f64::consts::PI;

/// The taper applied to each segment before its FFT.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Window {
    /// No taper: best resolution, worst leakage (sidelobes at -13 dB).
    Rectangular,
    /// Hann (raised cosine): the usual choice, sidelobes at -31 dB falling 18 dB/octave.
    #[default]
    Hann,
    /// Hamming: lower first sidelobe (-43 dB) than Hann but slow sidelobe decay.
    Hamming,
    /// Blackman: sidelobes at -58 dB, for spectra with a large dynamic range.
    Blackman,
}

impl Window {
    /// The window coefficients for a segment of `len` samples (periodic form).
    pub fn coefficients(self, len: usize) -> Vec<f64> {
        let n = len as f64;
        (0..len)
            .map(|t| {
                let phase = 2.0 * PI * t as f64 / n;
                match self {
                    Window::Rectangular => 1.0,
                    Window::Hann => 0.5 - 0.5 * phase.cos(),
                    Window::Hamming => 0.54 - 0.46 * phase.cos(),
                    Window::Blackman => 0.42 - 0.5 * phase.cos() + 0.08 * (2.0 * phase).cos(),
                }
            })
            .collect()
    }

    /// Equivalent noise bandwidth in bins: len * sum(w^2) / (sum w)^2 (1.5 for Hann, 1 for
    /// rectangular). Multiply by the bin spacing to get the bandwidth in Hz.
    pub fn equivalent_noise_bandwidth_bins(self, len: usize) -> f64 {
        let w = self.coefficients(len);
        let sum: f64 = w.iter().sum();
        let sum_sq: f64 = w.iter().map(|v| v * v).sum();
        len as f64 * sum_sq / (sum * sum)
    }

    /// Short lower-case name for reports.
    pub fn name(self) -> &'static str {
        match self {
            Window::Rectangular => "rectangular",
            Window::Hann => "Hann",
            Window::Hamming => "Hamming",
            Window::Blackman => "Blackman",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hann_has_its_textbook_noise_bandwidth_and_is_periodic() {
        let enbw = Window::Hann.equivalent_noise_bandwidth_bins(1024);
        assert!((enbw - 1.5).abs() < 1e-12, "Hann ENBW {enbw}");
        assert!((Window::Rectangular.equivalent_noise_bandwidth_bins(64) - 1.0).abs() < 1e-12);
        let w = Window::Hann.coefficients(8);
        assert_eq!(w[0], 0.0);
        assert!((w[4] - 1.0).abs() < 1e-15, "periodic Hann peaks at len/2");
        // Periodic Hann windows overlapped by half sum to exactly 1.
        for t in 0..4 {
            assert!((w[t] + w[t + 4] - 1.0).abs() < 1e-15);
        }
    }

    #[test]
    fn blackman_noise_bandwidth_matches_harris() {
        // Harris (1978), table 1: Blackman ENBW 1.73 bins.
        let enbw = Window::Blackman.equivalent_noise_bandwidth_bins(4096);
        assert!((enbw - 1.73).abs() < 0.01, "Blackman ENBW {enbw}");
        let hamming = Window::Hamming.equivalent_noise_bandwidth_bins(4096);
        assert!((hamming - 1.36).abs() < 0.01, "Hamming ENBW {hamming}");
    }
}
