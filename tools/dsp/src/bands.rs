//! Log-frequency band averaging of a spectrum, for plots and comparisons over decades.
//!
//! A Welch spectrum has equally spaced bins, so on a log axis the top decade holds 90 % of
//! them: the high end is an unreadable smear with tight confidence and the low end a few noisy
//! points. Averaging the bins that fall into bands of equal width in log frequency gives
//! evenly spaced points whose confidence improves with frequency, and the number of bins per
//! band (and the correlation between neighbouring bins) says by how much.

use crate::distributions::ChiSquaredInterval;
use crate::error::DspError;
use crate::spectral::Spectrum;

/// A spectrum averaged over bands of equal width in log frequency.
///
/// Band j covers `[10^(j/b), 10^((j+1)/b))` Hz for `b` bands per decade, so band edges are the
/// same for every spectrum and bands from different records line up. Bands without any bin are
/// left out; at low frequencies a band often holds a single bin and then equals it.
#[derive(Debug, Clone, PartialEq)]
pub struct BandSpectrum {
    /// Geometric mean of the frequencies of the bins in the band (the band's position on a log
    /// axis).
    pub frequency_hz: Vec<f64>,
    /// Lower edge of each band.
    pub lower_edge_hz: Vec<f64>,
    /// Upper edge of each band.
    pub upper_edge_hz: Vec<f64>,
    /// Mean PSD of the bins in the band.
    pub psd: Vec<f64>,
    /// Number of raw bins averaged into the band.
    pub bins: Vec<usize>,
    /// Equivalent degrees of freedom of each band value.
    pub dof: Vec<f64>,
}

impl BandSpectrum {
    /// Number of bands.
    pub fn len(&self) -> usize {
        self.psd.len()
    }

    /// True when no band holds a bin.
    pub fn is_empty(&self) -> bool {
        self.psd.is_empty()
    }

    /// Lower and upper `confidence` limits of the true band-averaged PSD of every band.
    pub fn confidence_band(&self, confidence: f64) -> Result<(Vec<f64>, Vec<f64>), DspError> {
        let mut lower = Vec::with_capacity(self.len());
        let mut upper = Vec::with_capacity(self.len());
        for (&p, &dof) in self.psd.iter().zip(&self.dof) {
            let interval = ChiSquaredInterval::new(dof, confidence)?;
            lower.push(p * interval.lower);
            upper.push(p * interval.upper);
        }
        Ok((lower, upper))
    }
}

/// Averages `spectrum` over log-frequency bands, `bands_per_decade` of them per decade.
///
/// The DC and Nyquist bins are left out: they have half the degrees of freedom of the others,
/// DC cannot sit on a log axis, and Nyquist is where aliasing is worst. The degrees of freedom
/// of a band of M bins are `nu M / (1 + 2 sum_{k=1}^{M-1} (1 - k/M) rho_k)`, with nu the
/// degrees of freedom of one bin and rho_k the correlation of bins k apart
/// ([`Spectrum::bin_correlation`]); for a Hann window that is about half of nu M.
pub fn log_band_average(spectrum: &Spectrum, bands_per_decade: f64) -> Result<BandSpectrum, DspError> {
    if !(bands_per_decade > 0.0 && bands_per_decade.is_finite()) {
        return Err(DspError::invalid("bands_per_decade", format!("must be positive, got {bands_per_decade}")));
    }
    let last_interior = spectrum.psd.len().saturating_sub(if spectrum.segment_len.is_multiple_of(2) { 1 } else { 0 });
    let mut result = BandSpectrum {
        frequency_hz: Vec::new(),
        lower_edge_hz: Vec::new(),
        upper_edge_hz: Vec::new(),
        psd: Vec::new(),
        bins: Vec::new(),
        dof: Vec::new(),
    };
    let band_of = |f: f64| (f.log10() * bands_per_decade).floor() as i64;
    let mut start = 1;
    while start < last_interior {
        let band = band_of(spectrum.frequency_hz[start]);
        let mut end = start + 1;
        while end < last_interior && band_of(spectrum.frequency_hz[end]) == band {
            end += 1;
        }
        let count = end - start;
        let psd = spectrum.psd[start..end].iter().sum::<f64>() / count as f64;
        let log_mean = spectrum.frequency_hz[start..end].iter().map(|f| f.ln()).sum::<f64>() / count as f64;
        result.frequency_hz.push(log_mean.exp());
        result.lower_edge_hz.push(10f64.powf(band as f64 / bands_per_decade));
        result.upper_edge_hz.push(10f64.powf((band + 1) as f64 / bands_per_decade));
        result.psd.push(psd);
        result.bins.push(count);
        result.dof.push(band_dof(spectrum.dof, &spectrum.bin_correlation, count));
        start = end;
    }
    Ok(result)
}

/// Degrees of freedom of the mean of `count` neighbouring bins with `dof` each and the given
/// correlation between bins k apart.
fn band_dof(dof: f64, correlation: &[f64], count: usize) -> f64 {
    let m = count as f64;
    let mut inflation = 1.0;
    for (k, rho) in correlation.iter().enumerate().take(count).skip(1) {
        inflation += 2.0 * (1.0 - k as f64 / m) * rho;
    }
    dof * m / inflation
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectral::{welch_psd, WelchConfig};
    use crate::test_signals::white_noise;
    use crate::window::Window;

    #[test]
    fn bands_are_aligned_to_decades_and_count_their_bins() {
        let x = white_noise(20_000, 1.0, 11);
        let spectrum = welch_psd(&x, 10.0, &WelchConfig::new(1000)).unwrap();
        let bands = log_band_average(&spectrum, 10.0).unwrap();
        // Every interior bin lands in exactly one band.
        assert_eq!(bands.bins.iter().sum::<usize>(), spectrum.psd.len() - 2);
        for i in 0..bands.len() {
            assert!(bands.frequency_hz[i] >= bands.lower_edge_hz[i] * (1.0 - 1e-12));
            assert!(bands.frequency_hz[i] < bands.upper_edge_hz[i]);
            let decades = bands.lower_edge_hz[i].log10() * 10.0;
            assert!((decades - decades.round()).abs() < 1e-9, "edge not on the 10-per-decade grid");
        }
        // The band [1, 1.2589) Hz holds the bins 1.00, 1.01, ..., 1.25 Hz (26 bins at 0.01 Hz).
        let one_hz = bands.lower_edge_hz.iter().position(|e| (e - 1.0).abs() < 1e-9).unwrap();
        assert_eq!(bands.bins[one_hz], 26);
        // A band of one bin keeps that bin's value and degrees of freedom.
        assert_eq!(bands.bins[0], 1);
        assert_eq!(bands.psd[0], spectrum.psd[1]);
        assert_eq!(bands.dof[0], spectrum.dof);
    }

    #[test]
    fn band_dof_matches_the_scatter_of_band_averages() {
        // White noise has a flat PSD of 1 here, so (p - 1)^2 dof / 2 has mean 1 for every band
        // whose degrees of freedom are right. Ignoring the correlation of neighbouring Hann
        // bins would overstate the dof of wide bands by about 1.9 and push the mean there.
        let config = WelchConfig::new(400);
        let mut normalised_squares = 0.0;
        let mut count = 0.0;
        for seed in 0..100 {
            let x = white_noise(400 * 6, 1.0, 200 + seed);
            let bands = log_band_average(&welch_psd(&x, 2.0, &config).unwrap(), 5.0).unwrap();
            for ((p, dof), bins) in bands.psd.iter().zip(&bands.dof).zip(&bands.bins) {
                if *bins >= 3 {
                    normalised_squares += (p - 1.0).powi(2) * dof / 2.0;
                    count += 1.0;
                }
            }
        }
        let ratio = normalised_squares / count;
        assert!((ratio - 1.0).abs() < 0.15, "mean normalised square {ratio} over {count} bands");
    }

    #[test]
    fn rectangular_non_overlapped_bins_add_their_dof() {
        let config = WelchConfig::new(100).with_window(Window::Rectangular).with_overlap(0.0);
        let x = white_noise(1000, 1.0, 12);
        let spectrum = welch_psd(&x, 1.0, &config).unwrap();
        let bands = log_band_average(&spectrum, 2.0).unwrap();
        for (bins, dof) in bands.bins.iter().zip(&bands.dof) {
            assert!((dof - 20.0 * *bins as f64).abs() < 1e-9);
        }
    }

    #[test]
    fn non_positive_bands_per_decade_is_an_error() {
        let spectrum = welch_psd(&white_noise(100, 1.0, 13), 1.0, &WelchConfig::new(50)).unwrap();
        assert!(log_band_average(&spectrum, 0.0).is_err());
    }
}
