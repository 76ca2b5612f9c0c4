//! Welch-averaged spectra: the auto spectral density, the cross spectral density, and from
//! them the H1 frequency-response estimate and the magnitude-squared coherence.
//!
//! All estimates share one segmenting ([`WelchConfig`]): the record is cut into segments of
//! `segment_len` samples that overlap by a fraction of their length, each segment is detrended
//! and windowed, and the segment periodograms are averaged. Samples after the last whole
//! segment are not used. The PSD is one-sided and per Hz; see the [module conventions](super).

use crate::distributions::ChiSquaredInterval;
use crate::error::{check_finite, check_sample_rate, DspError};
use crate::window::Window;
pub use rustfft::num_complex::Complex64;
use rustfft::{Fft, FftPlanner};
use std::f64::consts::PI;
use std::sync::Arc;

/// What to remove from each segment before windowing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Detrend {
    /// Nothing: the segment mean leaks into the lowest bins.
    None,
    /// The segment mean (the usual choice).
    #[default]
    Mean,
    /// A least-squares straight line, for records that drift within a segment.
    Linear,
}

/// How a record is cut into segments for a Welch estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WelchConfig {
    /// Samples per segment; the frequency resolution is sample_rate / segment_len.
    pub segment_len: usize,
    /// Overlap between consecutive segments as a fraction of `segment_len`, in [0, 1).
    pub overlap: f64,
    /// Taper applied to each segment.
    pub window: Window,
    /// Trend removed from each segment.
    pub detrend: Detrend,
}

impl WelchConfig {
    /// Segments of `segment_len` samples, Hann window, 50 % overlap, mean removed.
    pub fn new(segment_len: usize) -> Self {
        Self { segment_len, overlap: 0.5, window: Window::Hann, detrend: Detrend::Mean }
    }

    /// Segments lasting `segment_s` seconds at `sample_rate_hz` (rounded to whole samples),
    /// otherwise as [`WelchConfig::new`].
    pub fn from_duration(segment_s: f64, sample_rate_hz: f64) -> Self {
        Self::new((segment_s * sample_rate_hz).round().max(0.0) as usize)
    }

    /// The same configuration with another overlap fraction.
    pub fn with_overlap(mut self, overlap: f64) -> Self {
        self.overlap = overlap;
        self
    }

    /// The same configuration with another window.
    pub fn with_window(mut self, window: Window) -> Self {
        self.window = window;
        self
    }

    /// The same configuration with another detrending.
    pub fn with_detrend(mut self, detrend: Detrend) -> Self {
        self.detrend = detrend;
        self
    }

    /// Samples between the starts of consecutive segments (at least 1).
    pub fn step(&self) -> usize {
        let overlap_samples = (self.overlap * self.segment_len as f64).round() as usize;
        self.segment_len.saturating_sub(overlap_samples).max(1)
    }

    /// Number of whole segments in a record of `len` samples.
    pub fn segment_count(&self, len: usize) -> usize {
        if self.segment_len == 0 || len < self.segment_len {
            0
        } else {
            1 + (len - self.segment_len) / self.step()
        }
    }

    /// Equivalent degrees of freedom of an interior frequency bin of a Welch estimate with
    /// `segments` segments, for a Gaussian signal whose spectrum is smooth over a bin
    /// (Percival & Walden 1993, eq. 292b):
    /// `nu = 2 K / (1 + 2 sum_{m=1}^{K-1} (1 - m/K) rho(m))`, with
    /// `rho(m) = (sum_t w_t w_{t+mD})^2 / (sum_t w_t^2)^2` the correlation between segments
    /// m steps D apart. Without overlap this is 2K; overlap adds less than it seems to.
    pub fn equivalent_dof(&self, segments: usize) -> f64 {
        if segments == 0 {
            return 0.0;
        }
        let window = self.window.coefficients(self.segment_len);
        let norm: f64 = window.iter().map(|w| w * w).sum();
        let step = self.step();
        let k = segments as f64;
        let mut denominator = 1.0;
        for m in 1..segments {
            let shift = m * step;
            if shift >= self.segment_len {
                break;
            }
            let lagged: f64 = (0..self.segment_len - shift).map(|t| window[t] * window[t + shift]).sum();
            denominator += 2.0 * (1.0 - m as f64 / k) * (lagged / norm).powi(2);
        }
        2.0 * k / denominator
    }

    /// Correlation coefficient between the estimates at bins j and j + k of a Welch PSD, for
    /// k = 0, 1, ..., `max_offset`, for a Gaussian signal whose spectrum is smooth over a few
    /// bins. Neighbouring bins are correlated through the window's spectral main lobe (0.44
    /// for adjacent Hann bins), which matters when bins are averaged into bands: averaging M
    /// bins gains fewer than M times the degrees of freedom.
    pub fn bin_correlation(&self, segments: usize, max_offset: usize) -> Vec<f64> {
        let len = self.segment_len;
        if segments == 0 || len == 0 {
            return Vec::new();
        }
        let window = self.window.coefficients(len);
        let norm: f64 = window.iter().map(|w| w * w).sum();
        let step = self.step();
        let k_segments = segments as f64;
        // Products w_t w_{t+mD} for every segment shift m that still overlaps.
        let shifted_products: Vec<Vec<f64>> = (0..segments)
            .take_while(|&m| m * step < len)
            .map(|m| (0..len - m * step).map(|t| window[t] * window[t + m * step]).collect())
            .collect();
        let covariance = |offset: usize| -> f64 {
            let mut total = 0.0;
            for (m, products) in shifted_products.iter().enumerate() {
                let mut sum = Complex64::new(0.0, 0.0);
                for (t, &p) in products.iter().enumerate() {
                    let phase = -2.0 * PI * offset as f64 * t as f64 / len as f64;
                    sum += Complex64::from_polar(p, phase);
                }
                let c = sum.norm_sqr() / (norm * norm);
                let weight = if m == 0 { k_segments } else { 2.0 * (k_segments - m as f64) };
                total += weight * c;
            }
            total
        };
        let zero = covariance(0);
        (0..=max_offset.min(len / 2)).map(|k| if k == 0 { 1.0 } else { covariance(k) / zero }).collect()
    }

    fn validate(&self, len: usize) -> Result<(), DspError> {
        if self.segment_len < 2 {
            return Err(DspError::invalid("segment_len", format!("must be at least 2, got {}", self.segment_len)));
        }
        if !(0.0..1.0).contains(&self.overlap) {
            return Err(DspError::invalid("overlap", format!("must lie in [0, 1), got {}", self.overlap)));
        }
        if len < self.segment_len {
            return Err(DspError::TooShort { needed: self.segment_len, got: len });
        }
        Ok(())
    }
}

/// How many bin offsets of correlation a [`Spectrum`] carries for band averaging; beyond this
/// the correlation of every window offered here is negligible.
pub(crate) const BIN_CORRELATION_OFFSETS: usize = 64;

/// A one-sided power spectral density per Hz with what is needed to judge it.
#[derive(Debug, Clone, PartialEq)]
pub struct Spectrum {
    /// Bin frequencies, 0 to the Nyquist frequency (inclusive when the segment is even).
    pub frequency_hz: Vec<f64>,
    /// One-sided PSD in (signal unit)^2 / Hz.
    pub psd: Vec<f64>,
    /// Equivalent degrees of freedom of an interior bin (DC and Nyquist have half).
    pub dof: f64,
    /// Number of averaged segments.
    pub segments: usize,
    /// Samples per segment.
    pub segment_len: usize,
    /// Sample rate of the record.
    pub sample_rate_hz: f64,
    /// Window used on each segment.
    pub window: Window,
    /// Correlation between bins k apart, k = 0, 1, ... (see [`WelchConfig::bin_correlation`]).
    pub bin_correlation: Vec<f64>,
}

impl Spectrum {
    /// Spacing of the frequency bins, sample_rate / segment_len.
    pub fn resolution_hz(&self) -> f64 {
        self.sample_rate_hz / self.segment_len as f64
    }

    /// Equivalent noise bandwidth of a bin in Hz (1.5 bins for Hann).
    pub fn equivalent_noise_bandwidth_hz(&self) -> f64 {
        self.window.equivalent_noise_bandwidth_bins(self.segment_len) * self.resolution_hz()
    }

    /// Degrees of freedom of bin `index`: DC and Nyquist bins are real-valued and have half.
    pub fn dof_at(&self, index: usize) -> f64 {
        let nyquist = self.segment_len.is_multiple_of(2) && index == self.segment_len / 2;
        if index == 0 || nyquist {
            0.5 * self.dof
        } else {
            self.dof
        }
    }

    /// Factors for the two-sided `confidence` interval of an interior bin.
    pub fn confidence_interval(&self, confidence: f64) -> Result<ChiSquaredInterval, DspError> {
        ChiSquaredInterval::new(self.dof, confidence)
    }

    /// Lower and upper `confidence` limits of the true PSD at every bin.
    pub fn confidence_band(&self, confidence: f64) -> Result<(Vec<f64>, Vec<f64>), DspError> {
        let interior = ChiSquaredInterval::new(self.dof, confidence)?;
        let edge = ChiSquaredInterval::new(0.5 * self.dof, confidence)?;
        let mut lower = Vec::with_capacity(self.psd.len());
        let mut upper = Vec::with_capacity(self.psd.len());
        for (i, &p) in self.psd.iter().enumerate() {
            let factors = if self.dof_at(i) < self.dof { edge } else { interior };
            lower.push(p * factors.lower);
            upper.push(p * factors.upper);
        }
        Ok((lower, upper))
    }

    /// Power in the bins whose frequencies lie in `[f_low_hz, f_high_hz]`: the sum of PSD times
    /// bin spacing. Over all bins this is the variance of the (detrended, windowed) record.
    pub fn integrate(&self, f_low_hz: f64, f_high_hz: f64) -> f64 {
        let df = self.resolution_hz();
        self.frequency_hz
            .iter()
            .zip(&self.psd)
            .filter(|(f, _)| **f >= f_low_hz && **f <= f_high_hz)
            .map(|(_, p)| p * df)
            .sum()
    }

    /// Power over all bins (see [`Spectrum::integrate`]).
    pub fn total_power(&self) -> f64 {
        self.psd.iter().sum::<f64>() * self.resolution_hz()
    }
}

/// A one-sided cross spectral density S_xy = E[conj(X) Y] per Hz.
#[derive(Debug, Clone, PartialEq)]
pub struct CrossSpectrum {
    /// Bin frequencies.
    pub frequency_hz: Vec<f64>,
    /// Complex CSD; its phase is the phase of y relative to x.
    pub csd: Vec<Complex64>,
    /// Equivalent degrees of freedom of an interior bin of the matching auto spectra.
    pub dof: f64,
    /// Number of averaged segments.
    pub segments: usize,
}

/// The H1 frequency-response estimate from x (input) to y (output), with the spectra it is
/// made of and the coherence that says how far to trust it.
#[derive(Debug, Clone, PartialEq)]
pub struct TransferEstimate {
    /// Bin frequencies.
    pub frequency_hz: Vec<f64>,
    /// H1 = S_xy / S_xx: unbiased by noise on the output, biased low by noise on the input.
    pub h1: Vec<Complex64>,
    /// Magnitude-squared coherence |S_xy|^2 / (S_xx S_yy), 0 to 1.
    pub coherence: Vec<f64>,
    /// Input auto spectrum.
    pub sxx: Vec<f64>,
    /// Output auto spectrum.
    pub syy: Vec<f64>,
    /// Cross spectrum.
    pub sxy: Vec<Complex64>,
    /// Equivalent degrees of freedom of an interior bin.
    pub dof: f64,
    /// Number of averaged segments.
    pub segments: usize,
}

impl TransferEstimate {
    /// |H1| in dB (20 log10).
    pub fn magnitude_db(&self) -> Vec<f64> {
        self.h1.iter().map(|h| 20.0 * h.norm().log10()).collect()
    }

    /// Phase of H1 in degrees, unwrapped along frequency.
    pub fn phase_deg(&self) -> Vec<f64> {
        let wrapped: Vec<f64> = self.h1.iter().map(|h| h.arg().to_degrees()).collect();
        unwrap_phase_deg(&wrapped)
    }

    /// Normalised random error (one standard deviation, relative) of |H1| at each bin,
    /// sqrt(1 - g^2) / (|g| sqrt(2 n_d)) with n_d = dof / 2 effective averages
    /// (Bendat & Piersol, Random Data, eq. 9.90). The phase error in radians is about the same.
    pub fn magnitude_relative_error(&self) -> Vec<f64> {
        let averages = 0.5 * self.dof;
        self.coherence.iter().map(|&g2| (1.0 - g2).max(0.0).sqrt() / (g2.sqrt() * (2.0 * averages).sqrt())).collect()
    }

    /// Coherence below which an estimate is indistinguishable from that of two independent
    /// signals at the given `confidence`: 1 - alpha^(1 / (n_d - 1)), n_d = dof / 2
    /// effective averages. Returns 1 when there are too few averages to tell.
    pub fn coherence_threshold(&self, confidence: f64) -> f64 {
        let averages = 0.5 * self.dof;
        if averages <= 1.0 {
            return 1.0;
        }
        1.0 - (1.0 - confidence).powf(1.0 / (averages - 1.0))
    }
}

/// Detrends, windows and transforms segments, reusing one FFT plan and its buffers.
struct SegmentTransformer {
    config: WelchConfig,
    window: Vec<f64>,
    /// Sum of the squared window coefficients, computed once: the density scale needs it for
    /// every bin, and summing it per bin made a long segment's estimate quadratic in its length.
    window_power: f64,
    fft: Arc<dyn Fft<f64>>,
    buffer: Vec<Complex64>,
    scratch: Vec<Complex64>,
    detrended: Vec<f64>,
}

impl SegmentTransformer {
    fn new(config: WelchConfig) -> Self {
        let fft = FftPlanner::<f64>::new().plan_fft_forward(config.segment_len);
        let scratch = vec![Complex64::new(0.0, 0.0); fft.get_inplace_scratch_len()];
        let window = config.window.coefficients(config.segment_len);
        let window_power = window.iter().map(|w| w * w).sum();
        Self {
            config,
            window,
            window_power,
            fft,
            buffer: vec![Complex64::new(0.0, 0.0); config.segment_len],
            scratch,
            detrended: vec![0.0; config.segment_len],
        }
    }

    /// The FFT of the detrended, windowed segment (all bins; callers use 0..=len/2).
    fn transform(&mut self, segment: &[f64]) -> &[Complex64] {
        detrend_into(segment, self.config.detrend, &mut self.detrended);
        for ((out, &v), &w) in self.buffer.iter_mut().zip(&self.detrended).zip(&self.window) {
            *out = Complex64::new(v * w, 0.0);
        }
        self.fft.process_with_scratch(&mut self.buffer, &mut self.scratch);
        &self.buffer
    }

    /// Factor turning |X_k|^2 summed over `segments` into a one-sided density per Hz.
    fn density_scale(&self, bin: usize, segments: usize, sample_rate_hz: f64) -> f64 {
        let len = self.config.segment_len;
        let one_sided = if bin == 0 || (len.is_multiple_of(2) && bin == len / 2) { 1.0 } else { 2.0 };
        one_sided / (sample_rate_hz * self.window_power * segments as f64)
    }
}

fn detrend_into(segment: &[f64], detrend: Detrend, out: &mut [f64]) {
    let n = segment.len() as f64;
    match detrend {
        Detrend::None => out.copy_from_slice(segment),
        Detrend::Mean => {
            let mean = segment.iter().sum::<f64>() / n;
            for (o, v) in out.iter_mut().zip(segment) {
                *o = v - mean;
            }
        }
        Detrend::Linear => {
            // Least squares on a centred time axis, where slope and offset are uncorrelated.
            let t_mean = 0.5 * (n - 1.0);
            let mean = segment.iter().sum::<f64>() / n;
            let mut sxy = 0.0;
            let mut sxx = 0.0;
            for (t, v) in segment.iter().enumerate() {
                let dt = t as f64 - t_mean;
                sxy += dt * (v - mean);
                sxx += dt * dt;
            }
            let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
            for (t, (o, v)) in out.iter_mut().zip(segment).enumerate() {
                *o = v - mean - slope * (t as f64 - t_mean);
            }
        }
    }
}

fn bin_frequencies(segment_len: usize, sample_rate_hz: f64) -> Vec<f64> {
    (0..=segment_len / 2).map(|k| k as f64 * sample_rate_hz / segment_len as f64).collect()
}

/// Welch estimate of the one-sided PSD per Hz of `x` sampled at `sample_rate_hz`.
///
/// Returns [`DspError`] if the configuration is invalid, the record is shorter than one
/// segment, or a sample is not finite.
pub fn welch_psd(x: &[f64], sample_rate_hz: f64, config: &WelchConfig) -> Result<Spectrum, DspError> {
    check_sample_rate(sample_rate_hz)?;
    config.validate(x.len())?;
    check_finite(x)?;
    let segments = config.segment_count(x.len());
    let bins = config.segment_len / 2 + 1;
    let mut transformer = SegmentTransformer::new(*config);
    let mut sum = vec![0.0; bins];
    for s in 0..segments {
        let start = s * config.step();
        let spectrum = transformer.transform(&x[start..start + config.segment_len]);
        for (acc, value) in sum.iter_mut().zip(spectrum) {
            *acc += value.norm_sqr();
        }
    }
    let psd = sum.iter().enumerate().map(|(k, s)| s * transformer.density_scale(k, segments, sample_rate_hz)).collect();
    Ok(Spectrum {
        frequency_hz: bin_frequencies(config.segment_len, sample_rate_hz),
        psd,
        dof: config.equivalent_dof(segments),
        segments,
        segment_len: config.segment_len,
        sample_rate_hz,
        window: config.window,
        bin_correlation: config.bin_correlation(segments, BIN_CORRELATION_OFFSETS),
    })
}

/// The three averaged spectra of a pair of records.
struct PairSpectra {
    sxx: Vec<f64>,
    syy: Vec<f64>,
    sxy: Vec<Complex64>,
    segments: usize,
}

fn pair_spectra(x: &[f64], y: &[f64], sample_rate_hz: f64, config: &WelchConfig) -> Result<PairSpectra, DspError> {
    check_sample_rate(sample_rate_hz)?;
    if x.len() != y.len() {
        return Err(DspError::LengthMismatch { first: x.len(), second: y.len() });
    }
    config.validate(x.len())?;
    check_finite(x)?;
    check_finite(y)?;
    let segments = config.segment_count(x.len());
    let bins = config.segment_len / 2 + 1;
    let mut transformer = SegmentTransformer::new(*config);
    let mut sxx = vec![0.0; bins];
    let mut syy = vec![0.0; bins];
    let mut sxy = vec![Complex64::new(0.0, 0.0); bins];
    let mut x_spectrum = vec![Complex64::new(0.0, 0.0); bins];
    for s in 0..segments {
        let range = s * config.step()..s * config.step() + config.segment_len;
        x_spectrum.copy_from_slice(&transformer.transform(&x[range.clone()])[..bins]);
        let y_spectrum = transformer.transform(&y[range]);
        for k in 0..bins {
            sxx[k] += x_spectrum[k].norm_sqr();
            syy[k] += y_spectrum[k].norm_sqr();
            sxy[k] += x_spectrum[k].conj() * y_spectrum[k];
        }
    }
    for k in 0..bins {
        let scale = transformer.density_scale(k, segments, sample_rate_hz);
        sxx[k] *= scale;
        syy[k] *= scale;
        sxy[k] *= scale;
    }
    Ok(PairSpectra { sxx, syy, sxy, segments })
}

/// The one-sided spectra (bins 0 to segment_len / 2) of each detrended, windowed segment of
/// `x`, unscaled: for estimators that need the segments apart, as a regression per segment
/// whose scatter over the segments gives its uncertainty without a model of the bins'
/// correlation.
pub fn segment_spectra(x: &[f64], config: &WelchConfig) -> Result<Vec<Vec<Complex64>>, DspError> {
    config.validate(x.len())?;
    check_finite(x)?;
    let bins = config.segment_len / 2 + 1;
    let mut transformer = SegmentTransformer::new(*config);
    Ok((0..config.segment_count(x.len()))
        .map(|s| {
            let start = s * config.step();
            transformer.transform(&x[start..start + config.segment_len])[..bins].to_vec()
        })
        .collect())
}

/// Welch estimate of the one-sided cross spectral density S_xy = E[conj(X) Y] per Hz of two
/// sample-aligned records.
pub fn welch_csd(x: &[f64], y: &[f64], sample_rate_hz: f64, config: &WelchConfig) -> Result<CrossSpectrum, DspError> {
    let pair = pair_spectra(x, y, sample_rate_hz, config)?;
    Ok(CrossSpectrum {
        frequency_hz: bin_frequencies(config.segment_len, sample_rate_hz),
        csd: pair.sxy,
        dof: config.equivalent_dof(pair.segments),
        segments: pair.segments,
    })
}

/// H1 estimate of the frequency response from input `x` to output `y`, with the coherence.
pub fn transfer_function_h1(
    x: &[f64],
    y: &[f64],
    sample_rate_hz: f64,
    config: &WelchConfig,
) -> Result<TransferEstimate, DspError> {
    let pair = pair_spectra(x, y, sample_rate_hz, config)?;
    let h1 = pair.sxy.iter().zip(&pair.sxx).map(|(sxy, sxx)| sxy / *sxx).collect();
    let coherence = pair
        .sxy
        .iter()
        .zip(pair.sxx.iter().zip(&pair.syy))
        .map(|(sxy, (sxx, syy))| sxy.norm_sqr() / (sxx * syy))
        .collect();
    Ok(TransferEstimate {
        frequency_hz: bin_frequencies(config.segment_len, sample_rate_hz),
        h1,
        coherence,
        sxx: pair.sxx,
        syy: pair.syy,
        sxy: pair.sxy,
        dof: config.equivalent_dof(pair.segments),
        segments: pair.segments,
    })
}

/// Magnitude-squared coherence of two records: returns (frequency_hz, coherence).
///
/// Averaging is what makes coherence meaningful: with one segment it is identically 1. For
/// independent signals its expected value is about 1 / n_d (n_d = dof / 2 effective averages);
/// see [`TransferEstimate::coherence_threshold`].
pub fn coherence(
    x: &[f64],
    y: &[f64],
    sample_rate_hz: f64,
    config: &WelchConfig,
) -> Result<(Vec<f64>, Vec<f64>), DspError> {
    let estimate = transfer_function_h1(x, y, sample_rate_hz, config)?;
    Ok((estimate.frequency_hz, estimate.coherence))
}

/// Removes the 360-degree jumps from a sequence of phases in degrees, so a phase that keeps
/// falling with frequency is drawn as one curve. NaN entries are passed through and do not
/// disturb the unwrapping of the entries after them.
pub fn unwrap_phase_deg(phase_deg: &[f64]) -> Vec<f64> {
    let mut offset = 0.0;
    let mut previous: Option<f64> = None;
    phase_deg
        .iter()
        .map(|&p| {
            if !p.is_finite() {
                return p;
            }
            if let Some(prev) = previous {
                let jump = p - prev;
                offset -= 360.0 * (jump / 360.0).round();
            }
            previous = Some(p);
            p + offset
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_signals::{process_with_psd, white_noise};

    fn interior_mean(spectrum: &Spectrum) -> f64 {
        let interior = &spectrum.psd[1..spectrum.psd.len() - 1];
        interior.iter().sum::<f64>() / interior.len() as f64
    }

    #[test]
    fn white_noise_psd_level_is_twice_the_variance_over_the_sample_rate() {
        let sigma = 2.0;
        let sample_rate = 100.0;
        let x = white_noise(1 << 18, sigma, 1);
        for window in [Window::Rectangular, Window::Hann, Window::Hamming, Window::Blackman] {
            let spectrum = welch_psd(&x, sample_rate, &WelchConfig::new(1024).with_window(window)).unwrap();
            let expected = 2.0 * sigma * sigma / sample_rate;
            let level = interior_mean(&spectrum);
            // About 500 segments x 512 bins average to a standard error well below 1 %.
            assert!((level / expected - 1.0).abs() < 0.01, "{window:?}: level {level}, expected {expected}");
        }
    }

    #[test]
    fn psd_integrates_to_the_variance() {
        let x = white_noise(50_000, 0.7, 2);
        let spectrum = welch_psd(&x, 20.0, &WelchConfig::new(2000)).unwrap();
        let variance = x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64;
        assert!((spectrum.total_power() / variance - 1.0).abs() < 0.02);
    }

    #[test]
    fn sine_power_appears_at_its_frequency_with_amplitude_squared_over_two() {
        let sample_rate = 50.0;
        let amplitude = 3.0;
        let frequency = 7.31; // deliberately between bins
        let noise = white_noise(100_000, 0.1, 3);
        let x: Vec<f64> = noise
            .iter()
            .enumerate()
            .map(|(t, n)| amplitude * (2.0 * PI * frequency * t as f64 / sample_rate + 0.4).sin() + n)
            .collect();
        let spectrum = welch_psd(&x, sample_rate, &WelchConfig::new(4096)).unwrap();
        let peak = spectrum.psd.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).unwrap().0;
        assert!((spectrum.frequency_hz[peak] - frequency).abs() <= spectrum.resolution_hz());
        let half_width = 5.0 * spectrum.resolution_hz();
        let sine_power = spectrum.integrate(frequency - half_width, frequency + half_width);
        let expected = amplitude * amplitude / 2.0;
        // The noise in those 10 bins adds about 0.0002; leakage beyond 5 bins is below 1e-4.
        assert!((sine_power / expected - 1.0).abs() < 0.005, "sine power {sine_power}, expected {expected}");
    }

    #[test]
    fn equivalent_dof_is_exact_without_overlap_and_reduced_by_overlap() {
        let rectangular = WelchConfig::new(256).with_window(Window::Rectangular).with_overlap(0.0);
        assert!((rectangular.equivalent_dof(10) - 20.0).abs() < 1e-12);
        // Hann at 50 % overlap: neighbouring segments correlate by rho = 1/36 (Harris's 16.7 %
        // amplitude correlation, squared), so nu = 2K / (1 + 2 (1 - 1/K) / 36).
        let hann = WelchConfig::new(256);
        let k = 100.0;
        let expected = 2.0 * k / (1.0 + 2.0 * (1.0 - 1.0 / k) / 36.0);
        assert!((hann.equivalent_dof(100) - expected).abs() < 1e-9, "{}", hann.equivalent_dof(100));
        assert_eq!(hann.equivalent_dof(1), 2.0);
    }

    #[test]
    fn equivalent_dof_matches_the_scatter_of_white_noise_estimates() {
        // For nu degrees of freedom, the estimate over the true level (1 here) has variance
        // 2 / nu.
        for config in [
            WelchConfig::new(128),
            WelchConfig::new(128).with_overlap(0.75),
            WelchConfig::new(128).with_window(Window::Rectangular).with_overlap(0.5),
        ] {
            let mut squared_errors = 0.0;
            let mut count = 0.0;
            for seed in 0..100 {
                let x = white_noise(128 * 8, 1.0, 100 + seed);
                let spectrum = welch_psd(&x, 2.0, &config).unwrap();
                // Bins 1 and 2 are left out: removing the segment mean biases them low.
                for p in &spectrum.psd[3..spectrum.psd.len() - 1] {
                    squared_errors += (p - 1.0).powi(2);
                    count += 1.0;
                }
            }
            let empirical_dof = 2.0 / (squared_errors / count);
            let predicted = config.equivalent_dof(config.segment_count(128 * 8));
            assert!(
                (empirical_dof / predicted - 1.0).abs() < 0.08,
                "{config:?}: empirical {empirical_dof}, predicted {predicted}"
            );
        }
    }

    #[test]
    fn bin_correlation_of_hann_neighbours_is_four_ninths() {
        // One Hann segment: adjacent DFT bins correlate by -(1/4)/(3/8) = -2/3 in amplitude,
        // 4/9 in power; bins two apart by (1/16)/(3/8) = 1/6, i.e. 1/36 in power.
        let rho = WelchConfig::new(256).bin_correlation(1, 4);
        assert!((rho[1] - 4.0 / 9.0).abs() < 1e-12, "{rho:?}");
        assert!((rho[2] - 1.0 / 36.0).abs() < 1e-12);
        assert!(rho[3].abs() < 1e-12);
        let rectangular = WelchConfig::new(256).with_window(Window::Rectangular).with_overlap(0.0);
        assert!(rectangular.bin_correlation(5, 3)[1].abs() < 1e-12);
    }

    #[test]
    fn linear_detrend_removes_a_ramp_that_mean_removal_leaves_in_the_low_bins() {
        let noise = white_noise(8192, 1.0, 4);
        let x: Vec<f64> = noise.iter().enumerate().map(|(t, n)| n + 0.01 * t as f64).collect();
        let mean_only = welch_psd(&x, 1.0, &WelchConfig::new(1024)).unwrap();
        let linear = welch_psd(&x, 1.0, &WelchConfig::new(1024).with_detrend(Detrend::Linear)).unwrap();
        let white_level = 2.0;
        assert!(mean_only.psd[1] > 20.0 * white_level, "ramp leaks into bin 1: {}", mean_only.psd[1]);
        assert!(linear.psd[1] < 3.0 * white_level, "ramp removed: {}", linear.psd[1]);
    }

    #[test]
    fn h1_and_coherence_recover_a_known_fir_filter() {
        let sample_rate = 10.0;
        let taps = [0.5, 0.3, -0.2, 0.1];
        let x = white_noise(200_000, 1.0, 5);
        let noise_sigma = 0.05;
        let output_noise = white_noise(x.len(), noise_sigma, 6);
        let y: Vec<f64> = (0..x.len())
            .map(|t| {
                taps.iter().enumerate().filter(|(d, _)| t >= *d).map(|(d, b)| b * x[t - d]).sum::<f64>()
                    + output_noise[t]
            })
            .collect();
        let estimate = transfer_function_h1(&x, &y, sample_rate, &WelchConfig::new(512)).unwrap();
        let errors = estimate.magnitude_relative_error();
        for (k, &f) in estimate.frequency_hz.iter().enumerate().skip(1) {
            let omega = 2.0 * PI * f / sample_rate;
            let exact: Complex64 =
                taps.iter().enumerate().map(|(d, b)| Complex64::from_polar(*b, -omega * d as f64)).sum();
            let h = estimate.h1[k];
            // Magnitude and phase within 4 standard errors of the estimate's own error bound.
            let tolerance = 4.0 * errors[k];
            assert!((h - exact).norm() / exact.norm() < tolerance, "f={f}: H1={h}, exact={exact}, tol {tolerance}");
            // Coherence of a noisy linear system: |H|^2 Sxx / (|H|^2 Sxx + Snn).
            let expected = exact.norm_sqr() / (exact.norm_sqr() + noise_sigma * noise_sigma);
            assert!(
                (estimate.coherence[k] - expected).abs() < 0.02 + 0.3 * (1.0 - expected),
                "f={f}: coherence {} vs {expected}",
                estimate.coherence[k]
            );
        }
    }

    #[test]
    fn coherence_of_independent_signals_rarely_exceeds_its_threshold() {
        let x = white_noise(64 * 200, 1.0, 7);
        let y = white_noise(64 * 200, 1.0, 8);
        let estimate = transfer_function_h1(&x, &y, 1.0, &WelchConfig::new(64)).unwrap();
        let threshold = estimate.coherence_threshold(0.95);
        let interior = &estimate.coherence[1..estimate.coherence.len() - 1];
        let above = interior.iter().filter(|&&c| c > threshold).count();
        assert!(above <= 5, "{above} of {} bins above {threshold}", interior.len());
        assert!(interior.iter().sum::<f64>() / (interior.len() as f64) < 3.0 / (0.5 * estimate.dof));
    }

    #[test]
    fn cross_spectrum_of_a_delayed_copy_has_linear_phase() {
        let x = white_noise(40_000, 1.0, 9);
        let delay = 3;
        let y: Vec<f64> = (0..x.len()).map(|t| if t >= delay { x[t - delay] } else { 0.0 }).collect();
        let csd = welch_csd(&x, &y, 1.0, &WelchConfig::new(256)).unwrap();
        for k in [5, 20, 40] {
            let expected = -2.0 * PI * csd.frequency_hz[k] * delay as f64;
            let diff = (csd.csd[k].arg() - expected + PI).rem_euclid(2.0 * PI) - PI;
            assert!(diff.abs() < 0.05, "bin {k}: phase {} vs {expected}", csd.csd[k].arg());
        }
    }

    #[test]
    fn steep_spectrum_is_estimated_without_leakage_bias() {
        // A -5/3 power law over three decades: Hann leakage must not flatten it.
        let sample_rate = 20.0;
        let x = process_with_psd(1 << 16, sample_rate, 10, |f| 0.02 * f.powf(-5.0 / 3.0));
        let spectrum = welch_psd(&x, sample_rate, &WelchConfig::new(4096)).unwrap();
        for k in [4, 40, 400, 2000] {
            let f = spectrum.frequency_hz[k];
            let ratio = spectrum.psd[k] / (0.02 * f.powf(-5.0 / 3.0));
            let interval = spectrum.confidence_interval(0.999).unwrap();
            assert!(ratio > interval.lower && ratio < interval.upper, "bin {k}: ratio {ratio}");
        }
    }

    #[test]
    fn invalid_configurations_and_inputs_are_errors_not_panics() {
        let x = vec![1.0; 100];
        assert_eq!(welch_psd(&x, 1.0, &WelchConfig::new(200)), Err(DspError::TooShort { needed: 200, got: 100 }));
        assert!(matches!(
            welch_psd(&x, 1.0, &WelchConfig::new(10).with_overlap(1.0)),
            Err(DspError::InvalidParameter { name: "overlap", .. })
        ));
        assert!(matches!(
            welch_psd(&x, 0.0, &WelchConfig::new(10)),
            Err(DspError::InvalidParameter { name: "sample_rate_hz", .. })
        ));
        let mut with_nan = x.clone();
        with_nan[42] = f64::NAN;
        assert_eq!(welch_psd(&with_nan, 1.0, &WelchConfig::new(10)), Err(DspError::NonFinite { index: 42 }));
        assert_eq!(
            welch_csd(&x, &x[..50], 1.0, &WelchConfig::new(10)),
            Err(DspError::LengthMismatch { first: 100, second: 50 })
        );
    }

    #[test]
    fn unwrapping_removes_jumps_and_skips_nan() {
        let unwrapped = unwrap_phase_deg(&[170.0, -170.0, f64::NAN, -150.0, 170.0]);
        assert_eq!(unwrapped[0], 170.0);
        assert_eq!(unwrapped[1], 190.0);
        assert!(unwrapped[2].is_nan());
        assert_eq!(unwrapped[3], 210.0);
        assert_eq!(unwrapped[4], 170.0);
    }
}
