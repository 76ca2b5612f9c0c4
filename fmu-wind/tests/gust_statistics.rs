//! Statistical checks of generated gust records that run in a few seconds: variance over seeds
//! against Davenport within the interval the record length allows, spectra against their exact
//! expectation within their confidence band, independence of the step size and of seeds.
//! The 2 h, many-seed versions are in `long_statistics.rs` (run in release, ignored without
//! optimisation).

use antenna_dsp::{expected_lpsd, lpsd, ChiSquaredInterval};
use fmu_wind::analysis::{independent_correlation_std, record, sample_variance_std, sampled_autocovariance};
use fmu_wind::davenport::Davenport;
use fmu_wind::prototype::log_grid;
use fmu_wind::shaping::ShapingFilter;

fn davenport_filter(v: f64) -> ShapingFilter {
    ShapingFilter::davenport(&Davenport::new(v, 10.0, 0.4).unwrap())
}

/// The exact expectation of the estimate at `frequency` of a record of `filter` at `step`.
fn expected_estimate(filter: &ShapingFilter, step: f64, frequency: f64, cycles: f64) -> f64 {
    expected_lpsd(sampled_autocovariance(filter, step), 1.0 / step, frequency, cycles)
}

/// The range of estimate / true spectrum that holds with probability `confidence`.
fn estimate_range(dof: f64, confidence: f64) -> (f64, f64) {
    ChiSquaredInterval::new(dof, confidence).unwrap().estimate_factors()
}

/// Mean of the per-seed sample variances (about the known zero mean).
fn sample_variances(filter: &ShapingFilter, seeds: std::ops::Range<u64>, step: f64, duration: f64) -> Vec<f64> {
    seeds
        .map(|seed| {
            let r = record(filter, seed, step, duration);
            r.iter().map(|v| v * v).sum::<f64>() / r.len() as f64
        })
        .collect()
}

/// Checks that the seed-average of sample variances is within `z_max` standard errors of the
/// exact variance, the standard error following from the record length.
fn assert_variance_consistent(filter: &ShapingFilter, variances: &[f64], duration: f64, z_max: f64, label: &str) {
    let target = filter.stationary_variance();
    let m = variances.len() as f64;
    let mean = variances.iter().sum::<f64>() / m;
    let standard_error = sample_variance_std(filter, duration) / m.sqrt();
    let z = (mean - target) / standard_error;
    assert!(z.abs() < z_max, "{label}: mean sample variance {mean:.5} vs {target:.5} (z = {z:.2})");
}

#[test]
fn sample_variance_over_seeds_matches_davenport_within_the_record_interval() {
    let (v, duration, step) = (9.5, 1800.0, 0.1);
    let filter = davenport_filter(v);
    let variances = sample_variances(&filter, 0..16, step, duration);
    assert_variance_consistent(&filter, &variances, duration, 4.0, "9.5 m/s");
    // The scatter between seeds is the one the record length implies: the sample variance of
    // the 16 values against the computed one, inside a 99.9 % chi-square band (15 dof).
    let m = variances.len() as f64;
    let mean = variances.iter().sum::<f64>() / m;
    let spread = variances.iter().map(|s| (s - mean).powi(2)).sum::<f64>() / (m - 1.0);
    let predicted = sample_variance_std(&filter, duration).powi(2);
    let (lo, hi) = estimate_range(m - 1.0, 0.999);
    assert!(spread / predicted > lo && spread / predicted < hi, "spread ratio {}", spread / predicted);
}

#[test]
fn psd_of_a_record_matches_its_exact_expectation_within_the_confidence_band() {
    let (v, duration, step, bins) = (9.5, 3600.0, 0.1, 8.0);
    let filter = davenport_filter(v);
    let samples = record(&filter, 11, step, duration);
    let estimates = lpsd(&samples, 1.0 / step, &log_grid(0.005, 2.0, 16), bins);
    assert!(estimates.len() >= 14);
    let outside = estimates
        .iter()
        .filter(|e| {
            let expected = expected_estimate(&filter, step, e.frequency_hz, bins);
            let (lo, hi) = estimate_range(e.dof, 0.99);
            let ratio = e.psd / expected;
            ratio < lo || ratio > hi
        })
        .count();
    // With 99 % intervals about 0.15 of 16 estimates are expected outside.
    assert!(outside <= 2, "{outside} of {} estimates outside their 99 % band", estimates.len());
}

#[test]
fn statistics_do_not_depend_on_the_communication_step() {
    // 20 m/s has the shortest eddies, so 10 minutes hold enough independent samples.
    let (v, duration) = (20.0, 600.0);
    let filter = davenport_filter(v);
    for step in [0.001, 0.01, 0.1] {
        let variances = sample_variances(&filter, 100..106, step, duration);
        assert_variance_consistent(&filter, &variances, duration, 4.0, &format!("step {step}"));
        // The spectrum of one record at a few frequencies below the 100 ms Nyquist frequency.
        let samples = record(&filter, 200, step, duration);
        for e in lpsd(&samples, 1.0 / step, &[0.05, 0.2, 1.0], 8.0) {
            let expected = expected_estimate(&filter, step, e.frequency_hz, 8.0);
            let (lo, hi) = estimate_range(e.dof, 0.999);
            let ratio = e.psd / expected;
            assert!(
                ratio > lo && ratio < hi,
                "step {step}, f = {}: ratio {ratio} outside [{lo}, {hi}]",
                e.frequency_hz
            );
        }
    }
}

#[test]
fn expected_estimate_is_close_to_the_true_spectrum_away_from_nyquist() {
    let f = davenport_filter(9.5);
    for freq in [0.01, 0.1, 1.0] {
        let expected = expected_estimate(&f, 0.01, freq, 16.0);
        let truth = f.psd_one_sided_per_hz(freq);
        assert!((expected / truth - 1.0).abs() < 0.03, "f = {freq}: {expected} vs {truth}");
    }
}

#[test]
fn records_from_different_seeds_are_uncorrelated() {
    let (v, duration, step) = (9.5, 3600.0, 0.1);
    let filter = davenport_filter(v);
    let sd = independent_correlation_std(&filter, duration);
    let records: Vec<Vec<f64>> = (0..4).map(|seed| record(&filter, 1000 + seed, step, duration)).collect();
    let variance = filter.stationary_variance();
    for i in 0..records.len() {
        for j in i + 1..records.len() {
            let c = records[i].iter().zip(&records[j]).map(|(a, b)| a * b).sum::<f64>()
                / records[i].len() as f64
                / variance;
            assert!(c.abs() < 4.0 * sd, "seeds {i}, {j}: correlation {c:.3}, 4 sigma = {:.3}", 4.0 * sd);
        }
    }
}

#[test]
fn paper_mode_records_have_the_paper_filters_variance() {
    // The paper's H10 keeps a finite DC gain, so its record has much shorter memory than
    // Davenport's: 20 minutes, 8 seeds.
    let (duration, step) = (1200.0, 0.05);
    let filter = ShapingFilter::paper(9.5).unwrap();
    let variances = sample_variances(&filter, 0..8, step, duration);
    assert_variance_consistent(&filter, &variances, duration, 4.0, "H10");
}
