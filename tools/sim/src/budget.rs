//! The pointing error budget of a jitter scenario: the beam's error over the judged (worst)
//! 10 s window split into what the servo leaves, what the encoder adds, and what the structure
//! adds statically and dynamically, with the wind's share of the servo part from a calm rerun;
//! and the beam error's spectrum with the structural modes marked.

use std::path::Path;

use antenna_dsp::{welch_psd, WelchConfig};
use antenna_plot::{Figure, Panel, PlotError, Series, PALETTE};

use super::coupled::{ErrorParts, Trace};
use super::metrics::JITTER_WINDOW_S;

/// RMS over the judged window of each part of the beam's error, arcsec on the sky.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Budget {
    /// Command minus encoder reading: the servo's error, wind rejection included.
    pub servo_arcsec: f64,
    /// The same in the same window of a calm run (no wind): the servo's own part.
    pub servo_calm_arcsec: Option<f64>,
    /// Encoder reading minus the true axis: graduation, interpolation, eccentricity, noise, count.
    pub encoder_arcsec: f64,
    /// The structure's quasi-static deflection under the wind's loads.
    pub structure_static_arcsec: f64,
    /// The structure's modes ringing about that deflection.
    pub structure_dynamic_arcsec: f64,
    /// Root-sum-square of the four parts.
    pub rss_arcsec: f64,
    /// The budget's estimate of the total: the parts' mean offsets added as vectors, their
    /// fluctuations about those means root-sum-squared, `sqrt(|sum of means|^2 + sum of
    /// variances)`. Exact when the fluctuations are uncorrelated.
    pub combined_arcsec: f64,
    /// RMS of their vector sum over the window: the absolute error.
    pub total_arcsec: f64,
    /// The length of the total's mean vector over the window: the offset that centring (or a
    /// pointing model) takes out, mostly the repeatable parts below.
    pub offset_arcsec: f64,
    /// The total's RMS about that mean: the jitter after centring, the judged figure.
    pub centred_arcsec: f64,
    /// The lengths of the repeatable parts' mean vectors over the window: the encoder's
    /// (graduation, eccentricity: a function of the axis angles) and the structure's static
    /// deflection (a function of the mean wind's speed and direction).
    pub encoder_offset_arcsec: f64,
    pub structure_static_offset_arcsec: f64,
}

impl Budget {
    /// The wind's share of the servo error, `sqrt(servo^2 - calm^2)` (0 when the calm run is
    /// not smaller).
    pub fn servo_wind_arcsec(&self) -> Option<f64> {
        self.servo_calm_arcsec.map(|calm| (self.servo_arcsec.powi(2) - calm.powi(2)).max(0.0).sqrt())
    }
}

/// Sample indices of the window starting at `start_s`.
fn window(trace: &Trace, start_s: f64) -> std::ops::Range<usize> {
    let first = trace.time_s.partition_point(|&t| t < start_s - 1e-9);
    let last = trace.time_s.partition_point(|&t| t < start_s + JITTER_WINDOW_S - 1e-9);
    first..last
}

fn vector_rms(part: &[[f64; 2]], range: std::ops::Range<usize>) -> f64 {
    let n = range.len().max(1) as f64;
    (part[range].iter().map(|[x, y]| x * x + y * y).sum::<f64>() / n).sqrt()
}

/// The mean vector of a part over a window and its variance about that mean (arcsec^2).
fn mean_and_variance(part: &[[f64; 2]], range: std::ops::Range<usize>) -> ([f64; 2], f64) {
    let n = range.len().max(1) as f64;
    let slice = &part[range];
    let mean = [slice.iter().map(|p| p[0]).sum::<f64>() / n, slice.iter().map(|p| p[1]).sum::<f64>() / n];
    let variance = slice.iter().map(|p| (p[0] - mean[0]).powi(2) + (p[1] - mean[1]).powi(2)).sum::<f64>() / n;
    (mean, variance)
}

/// RMS of the servo part of a trace over the window starting at `start_s`, arcsec.
pub fn servo_rms_arcsec(trace: &Trace, start_s: f64) -> f64 {
    vector_rms(&trace.error_parts().servo, window(trace, start_s))
}

/// The budget of `trace` over the window starting at `start_s`; `calm` is the same scenario
/// run without wind, if there is one.
pub fn budget(trace: &Trace, start_s: f64, calm: Option<&Trace>) -> Budget {
    let range = window(trace, start_s);
    let parts = trace.error_parts();
    let total = Trace::summed_parts(&parts);
    let ErrorParts { servo, encoder, structure_static, structure_dynamic, pointing_model } = parts;
    let servo_arcsec = vector_rms(&servo, range.clone());
    let encoder_arcsec = vector_rms(&encoder, range.clone());
    let structure_static_arcsec = vector_rms(&structure_static, range.clone());
    let structure_dynamic_arcsec = vector_rms(&structure_dynamic, range.clone());
    let rss_arcsec = [servo_arcsec, encoder_arcsec, structure_static_arcsec, structure_dynamic_arcsec]
        .iter()
        .map(|x| x * x)
        .sum::<f64>()
        .sqrt();
    let mut mean_sum = [0.0; 2];
    let mut variance_sum = 0.0;
    for part in [&servo, &encoder, &structure_static, &structure_dynamic, &pointing_model] {
        let (mean, variance) = mean_and_variance(part, range.clone());
        mean_sum = [mean_sum[0] + mean[0], mean_sum[1] + mean[1]];
        variance_sum += variance;
    }
    let combined_arcsec = (mean_sum[0].powi(2) + mean_sum[1].powi(2) + variance_sum).sqrt();
    let (total_mean, total_variance) = mean_and_variance(&total, range.clone());
    let offset_length = |part: &[[f64; 2]]| {
        let (mean, _) = mean_and_variance(part, range.clone());
        mean[0].hypot(mean[1])
    };
    Budget {
        offset_arcsec: total_mean[0].hypot(total_mean[1]),
        centred_arcsec: total_variance.sqrt(),
        encoder_offset_arcsec: offset_length(&encoder),
        structure_static_offset_arcsec: offset_length(&structure_static),
        combined_arcsec,
        servo_arcsec,
        servo_calm_arcsec: calm.map(|c| servo_rms_arcsec(c, start_s)),
        encoder_arcsec,
        structure_static_arcsec,
        structure_dynamic_arcsec,
        rss_arcsec,
        total_arcsec: vector_rms(&total, range),
    }
}

/// One-sided spectra (arcsec^2/Hz) of the beam error's cross-elevation and elevation parts,
/// means removed, from `from_s` to the end of the trace: (frequencies, cross, elevation).
pub fn beam_error_spectra(trace: &Trace, from_s: f64) -> Option<(Vec<f64>, Vec<f64>, Vec<f64>)> {
    let dt = trace.time_s.get(1)? - trace.time_s.first()?;
    let first = trace.time_s.partition_point(|&t| t < from_s);
    let total = Trace::summed_parts(&trace.error_parts());
    let component = |axis: usize| -> Vec<f64> { total[first..].iter().map(|p| p[axis]).collect() };
    let (cross, elevation) = (component(0), component(1));
    // Segments of 2^14 samples: 0.06 Hz resolution at 1 kHz, several segments in a minute.
    let segment = 16384.min(cross.len().next_power_of_two() / 2).max(256);
    let config = WelchConfig::new(segment);
    let a = welch_psd(&cross, 1.0 / dt, &config).ok()?;
    let b = welch_psd(&elevation, 1.0 / dt, &config).ok()?;
    Some((a.frequency_hz, a.psd, b.psd))
}

/// The frequency of the largest spectral peak between `low_hz` and `high_hz`, refined by a
/// parabola through the peak bin and its neighbours in log power; `None` when the largest value
/// is at an end of the band (a slope, not a peak: a mode damped into the background).
pub fn peak_frequency_hz(frequency_hz: &[f64], psd: &[f64], low_hz: f64, high_hz: f64) -> Option<f64> {
    let band: Vec<usize> = (1..frequency_hz.len().saturating_sub(1))
        .filter(|&k| frequency_hz[k] >= low_hz && frequency_hz[k] <= high_hz)
        .collect();
    let k = band.iter().copied().max_by(|&a, &b| psd[a].total_cmp(&psd[b]))?;
    if Some(&k) == band.first() || Some(&k) == band.last() {
        return None;
    }
    let (l, c, r) = (psd[k - 1].max(1e-300).ln(), psd[k].max(1e-300).ln(), psd[k + 1].max(1e-300).ln());
    let denominator = l - 2.0 * c + r;
    let shift = if denominator.abs() > 0.0 { 0.5 * (l - r) / denominator } else { 0.0 };
    Some(frequency_hz[k] + shift.clamp(-0.5, 0.5) * (frequency_hz[k + 1] - frequency_hz[k]))
}

/// A PNG of the beam error's spectra with each structural mode's frequency marked.
pub fn plot_beam_spectrum(
    title: &str,
    spectra: &(Vec<f64>, Vec<f64>, Vec<f64>),
    modes_hz: &[(String, f64)],
    path: &Path,
) -> Result<(), PlotError> {
    let (f, cross, elevation) = spectra;
    let keep: Vec<usize> = (1..f.len()).filter(|&k| f[k] <= 100.0).collect();
    let pick = |v: &[f64]| keep.iter().map(|&k| v[k].max(1e-12)).collect::<Vec<f64>>();
    let frequencies = pick(f);
    let mut panel = Panel::new(title)
        .x_label("frequency (Hz)")
        .y_label("beam error PSD (arcsec^2/Hz)")
        .log_x()
        .log_y()
        .series(Series::new("cross-elevation", &frequencies, &pick(cross)).colour(PALETTE[0]))
        .series(Series::new("elevation", &frequencies, &pick(elevation)).colour(PALETTE[1]));
    // The cumulative RMS from the lowest frequency up: where the error's variance comes from.
    let cumulative = |psd: &[f64]| -> Vec<f64> {
        let mut sum = 0.0;
        (1..f.len())
            .filter_map(|k| {
                sum += psd[k] * (f[k] - f[k - 1]);
                (f[k] <= 100.0).then(|| sum.max(0.0).sqrt().max(1e-6))
            })
            .collect()
    };
    let mut rms = Panel::new("cumulative RMS of the beam error (about its mean), from the lowest frequency up")
        .x_label("frequency (Hz)")
        .y_label("cumulative RMS (arcsec)")
        .log_x()
        .series(Series::new("cross-elevation", &frequencies, &cumulative(cross)).colour(PALETTE[0]))
        .series(Series::new("elevation", &frequencies, &cumulative(elevation)).colour(PALETTE[1]));
    // Marks of modes at nearly the same frequency would cover each other: one mark each.
    let mut marked: Vec<(String, f64)> = Vec::new();
    for (name, frequency) in modes_hz {
        match marked.iter_mut().find(|(_, f)| (f / frequency - 1.0).abs() < 0.02) {
            Some((label, _)) => *label = format!("{label}; {name}"),
            None => marked.push((name.clone(), *frequency)),
        }
    }
    for (name, frequency) in &marked {
        panel = panel.vertical_line(name, *frequency);
        rms = rms.vertical_line("", *frequency);
    }
    Figure::new(1100, 900).panel(panel).panel(rms).save_png(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trace_with(parts: impl Fn(f64) -> ([f64; 2], [f64; 2], [f64; 2], [f64; 2])) -> Trace {
        let mut t = Trace::default();
        for k in 0..20_000 {
            let time = 1e-3 * k as f64;
            let (servo, encoder, static_part, dynamic) = parts(time);
            // Elevation 60 deg: an azimuth angle counts half on the sky.
            let el: f64 = 60.0;
            let cos_el = el.to_radians().cos();
            let axis = [5.0, el];
            let encoder_reading = [axis[0] + encoder[0] / 3600.0 / cos_el, axis[1] + encoder[1] / 3600.0];
            t.time_s.push(time);
            t.azimuth_deg.push(axis[0]);
            t.elevation_deg.push(axis[1]);
            t.encoder_azimuth_deg.push(encoder_reading[0]);
            t.encoder_elevation_deg.push(encoder_reading[1]);
            t.command_azimuth_deg.push(encoder_reading[0] + servo[0] / 3600.0 / cos_el);
            t.command_elevation_deg.push(encoder_reading[1] + servo[1] / 3600.0);
            t.beam_offset_static_arcsec.push([-static_part[0], -static_part[1]]);
            t.beam_offset_arcsec.push([-static_part[0] - dynamic[0], -static_part[1] - dynamic[1]]);
        }
        t
    }

    #[test]
    fn the_parts_add_up_to_the_beam_error_and_each_is_measured_alone() {
        let trace = trace_with(|t| {
            let w = std::f64::consts::TAU * 6.0 * t;
            ([1.0, 0.0], [0.0, 2.0], [3.0, -1.0], [0.5 * w.sin(), 0.0])
        });
        let b = budget(&trace, 5.0, None);
        let close = |a: f64, b: f64| (a - b).abs() < 1e-6;
        assert!(close(b.servo_arcsec, 1.0), "{b:?}");
        assert!(close(b.encoder_arcsec, 2.0), "{b:?}");
        assert!(close(b.structure_static_arcsec, 10f64.sqrt()), "{b:?}");
        assert!(close(b.structure_dynamic_arcsec, 0.5 / 2f64.sqrt()), "{b:?}");
        // The total is the RMS of the error the report judges.
        let error = trace.pointing_error_arcsec();
        let range = window(&trace, 5.0);
        let judged = (error[range.clone()].iter().map(|e| e * e).sum::<f64>() / range.len() as f64).sqrt();
        assert!(close(b.total_arcsec, judged), "{} against {judged}", b.total_arcsec);
        // Constant offsets add as vectors and one fluctuation adds in quadrature: exact here.
        assert!(close(b.combined_arcsec, b.total_arcsec), "{} against {}", b.combined_arcsec, b.total_arcsec);
    }

    #[test]
    fn a_ringing_mode_shows_as_the_spectral_peak_at_its_frequency() {
        let trace = trace_with(|t| ([0.0; 2], [0.0; 2], [0.0; 2], [0.0, (std::f64::consts::TAU * 6.0 * t).sin()]));
        let (f, _, elevation) = beam_error_spectra(&trace, 0.0).unwrap();
        let peak = peak_frequency_hz(&f, &elevation, 1.0, 20.0).unwrap();
        assert!((peak / 6.0 - 1.0).abs() < 0.02, "{peak} Hz");
    }
}
