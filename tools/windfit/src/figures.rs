//! The figures: the measured spectrum with its confidence band against Eq. 2 and any overlays,
//! and the record's time series with its gust averages.

use crate::analysis::WindAnalysis;
use crate::davenport::DavenportSpectrum;
use crate::error::WindFitError;
use crate::generator::{log_grid, ComparisonCurve};
use crate::record::WindRecord;
use crate::report::file_name;
use crate::spectrum_fit::KOLMOGOROV_SLOPE;
use antenna_dsp::{self, moving_average, window_samples};
use antenna_plot::{Colour, Figure, LegendPosition, Panel, Series};

/// Draws the measured PSD (raw Welch bins, band averages with their confidence band), Eq. 2
/// for the fitted kappa and for the reference z0, the fitted slope and the -5/3 line, with
/// `overlays` on top; below it the premultiplied spectrum n S(n), which shows where the
/// variance lies relative to the Davenport peak.
pub fn spectrum_figure(analysis: &WindAnalysis, overlays: &[ComparisonCurve]) -> Result<Figure, WindFitError> {
    let statistics = &analysis.statistics;
    let v = statistics.mean_m_s;
    let (lower, upper) = analysis.bands.confidence_band(analysis.config.confidence)?;
    let nyquist = 0.5 * statistics.sample_rate_hz;
    let identifiability = &analysis.identifiability;
    let grid = log_grid(
        (0.3 * identifiability.peak_hz).min(0.5 * analysis.identifiability.record_fundamental_hz),
        nyquist,
        40,
    );
    let fitted = DavenportSpectrum { v_mean_m_s: v, kappa: analysis.implied.kappa };
    let reference = DavenportSpectrum { v_mean_m_s: v, kappa: analysis.kappa_reference };
    let variance_matched = DavenportSpectrum { v_mean_m_s: v, kappa: analysis.kappa_from_variance };
    let evaluate = |model: &DavenportSpectrum| grid.iter().map(|&n| model.psd(n)).collect::<Vec<f64>>();
    let (fit_low, fit_high) = analysis.slope.band_hz;
    let fit_x = log_grid(fit_low, fit_high, 20);
    let fit_line: Vec<f64> = fit_x
        .iter()
        .map(|&n| analysis.slope.psd_at_pivot * (n / analysis.slope.pivot_hz).powf(analysis.slope.slope))
        .collect();
    let kolmogorov_x = log_grid(fit_low / 3.0, (fit_high * 3.0).min(nyquist), 20);
    let kolmogorov_line: Vec<f64> =
        kolmogorov_x.iter().map(|&n| analysis.level.level * n.powf(KOLMOGOROV_SLOPE)).collect();
    let height = analysis.config.effective_height_m();
    let percent = (100.0 * analysis.config.confidence).round();

    let raw: Vec<(f64, f64)> =
        analysis.spectrum.frequency_hz.iter().copied().zip(analysis.spectrum.psd.iter().copied()).skip(1).collect();
    let (raw_f, raw_p): (Vec<f64>, Vec<f64>) = raw.into_iter().unzip();
    let mut psd_panel = Panel::new(&format!(
        "{} PSD, {} (mean {:.2} m/s, {:.0} s)",
        analysis.column,
        file_name(&analysis.source),
        v,
        statistics.duration_s
    ))
    .x_label("Frequency (Hz)")
    .y_label("PSD ((m/s)²/Hz)")
    .log_x()
    .log_y()
    .series(Series::new("Welch bins", &raw_f, &raw_p).colour(Colour::rgb(200, 200, 200)).width(1))
    .line_with_band(
        "measured (band average)",
        &analysis.bands.frequency_hz,
        &analysis.bands.psd,
        &lower,
        &upper,
        &format!("{percent:.0} % confidence"),
    )
    .series(
        Series::new(&format!("Eq. 2, κ = {:.3} (from -5/3 level)", fitted.kappa), &grid, &evaluate(&fitted)).dashed(),
    )
    .series(
        Series::new(
            &format!("Eq. 2, κ = {:.3} (matches variance)", variance_matched.kappa),
            &grid,
            &evaluate(&variance_matched),
        )
        .dashed(),
    )
    .series(
        Series::new(
            &format!(
                "Eq. 2, z0 = {} m at {:.2} m (κ = {:.4})",
                analysis.config.reference_z0_m, height, reference.kappa
            ),
            &grid,
            &evaluate(&reference),
        )
        .dotted(),
    )
    .series(
        Series::new("-5/3 at fitted level", &kolmogorov_x, &kolmogorov_line)
            .colour(Colour::rgb(0, 0, 0))
            .dashed()
            .width(1),
    )
    .series(
        Series::new(
            &format!("fit: slope {:.2} ± {:.2}", analysis.slope.slope, analysis.slope.slope_std_error),
            &fit_x,
            &fit_line,
        )
        .colour(Colour::rgb(0, 0, 0))
        .width(3),
    )
    .vertical_line(&format!("Davenport peak {:.2} mHz", 1e3 * identifiability.peak_hz), identifiability.peak_hz)
    .vertical_line("1 / record length", identifiability.record_fundamental_hz);
    let mut premultiplied = Panel::new("Premultiplied spectrum: variance per log-frequency interval")
        .x_label("Frequency (Hz)")
        .y_label("n·S(n) ((m/s)²)")
        .log_x()
        .legend(LegendPosition::UpperRight);
    let times_n = |f: &[f64], p: &[f64]| f.iter().zip(p).map(|(a, b)| a * b).collect::<Vec<f64>>();
    premultiplied = premultiplied
        .series(
            Series::new(
                "measured",
                &analysis.bands.frequency_hz,
                &times_n(&analysis.bands.frequency_hz, &analysis.bands.psd),
            )
            .with_markers(),
        )
        .series(Series::new("Eq. 2, κ from -5/3 level", &grid, &times_n(&grid, &evaluate(&fitted))).dashed())
        .series(
            Series::new("Eq. 2, κ matching variance", &grid, &times_n(&grid, &evaluate(&variance_matched))).dashed(),
        )
        .series(Series::new("Eq. 2, reference z0", &grid, &times_n(&grid, &evaluate(&reference))).dotted());
    for overlay in overlays {
        psd_panel = psd_panel.line(&overlay.name, &overlay.frequency_hz, &overlay.psd);
        premultiplied =
            premultiplied.line(&overlay.name, &overlay.frequency_hz, &times_n(&overlay.frequency_hz, &overlay.psd));
    }
    premultiplied = premultiplied
        .vertical_line("Davenport n·S(n) peak", identifiability.premultiplied_peak_hz)
        .vertical_line("1 / record length", identifiability.record_fundamental_hz);
    Ok(Figure::new(1100, 1200).panel(psd_panel).panel(premultiplied))
}

/// The record over time with its gust-window moving average and block means.
pub fn time_series_figure(record: &WindRecord, analysis: &WindAnalysis) -> Figure {
    let fs = record.sample_rate_hz;
    let t0 = record.time_s[0];
    let time: Vec<f64> = record.time_s.iter().map(|t| t - t0).collect();
    let window = window_samples(analysis.config.gust_window_s, fs).max(1);
    let averaged = moving_average(&record.speed_m_s, window);
    // The average over samples i..i+w is plotted at the window's centre.
    let centre: Vec<f64> = (0..averaged.len()).map(|i| time[i] + 0.5 * (window - 1) as f64 / fs).collect();
    let mut panel = Panel::new(&format!("{} from {}", record.column, file_name(&record.source)))
        .x_label("Time from start (s)")
        .y_label("Speed (m/s)")
        .series(Series::new("measured", &time, &record.speed_m_s).colour(Colour::rgb(170, 190, 215)).width(1))
        .series(
            Series::new(&format!("{} s moving average", analysis.config.gust_window_s), &centre, &averaged).width(2),
        );
    if let Some(minute) = analysis.periods.iter().find(|p| (p.period_s - 60.0).abs() < 1e-9) {
        let (x, y): (Vec<f64>, Vec<f64>) = minute.blocks.iter().map(|b| (b.start_s + 30.0, b.mean_m_s)).unzip();
        panel = panel.series(Series::new("1-min means", &x, &y).markers_only());
    }
    let gust_label = format!("{} s gust {:.2} m/s", analysis.config.gust_window_s, analysis.statistics.gust_m_s);
    panel = panel
        .horizontal_line(&format!("mean {:.2} m/s", analysis.statistics.mean_m_s), analysis.statistics.mean_m_s)
        .vertical_line(&gust_label, analysis.statistics.gust_time_s + 0.5 * analysis.config.gust_window_s);
    Figure::new(1400, 500).panel(panel)
}
