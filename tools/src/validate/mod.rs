//! Model validation against measured logs: compute the residual, analyse it as a control
//! engineer would, trace it to a named effect the model lacks, add the effect, refit, and
//! report the error before and after. Documented in docs/validation.md.
//!
//! Phase 1 uses the equation-error (inverse-dynamics) residual, which needs no simulation. The
//! output-error route (simulating the plant over windows re-initialised from the measured
//! state) plugs in through [`output_error::PlantSimulator`].

pub mod candidates;
pub mod equation_error;
pub mod output_error;
pub mod parameters;
pub mod report;
pub mod scoring;
pub mod selection;
pub mod signals;
pub mod stats;

use crate::measured_log::{MeasuredLog, Signal};
use equation_error::{EquationData, EquationOptions};
use parameters::ParameterSet;
use selection::{Fit, Selection, SelectionOptions};

/// All settings of a validation run.
#[derive(Debug, Clone, Default)]
pub struct ValidateOptions {
    pub equation: EquationOptions,
    pub selection: SelectionOptions,
}

/// Statistics of one residual channel, as a control engineer reads them.
#[derive(Debug, Clone)]
pub struct ChannelStats {
    pub name: String,
    /// RMS of the residual over the fitted samples, axis-side N m.
    pub rms: f64,
    /// NRMSE fit of the measured side, percent.
    pub fit_percent: f64,
    /// Integrated autocorrelation time (samples): 1 for white.
    pub correlation_time: f64,
    /// Ljung-Box p-value on 20 lags of the residual decimated to independent samples
    /// (one per filter length): small means not white.
    pub whiteness_p: f64,
    /// Fraction of those lags outside the 95 % band.
    pub lags_outside: f64,
    /// Largest |cross-correlation| with each input over +-1 s, with its lag (s), and the 95 %
    /// bound for a white residual on the decimated record.
    pub cross_correlation: Vec<(String, f64, f64)>,
    pub cross_bound: f64,
}

/// The result of validating one log.
#[derive(Debug, Clone)]
pub struct Validation {
    pub data: EquationData,
    pub selection: Selection,
    pub before: Vec<ChannelStats>,
    pub after: Vec<ChannelStats>,
    pub start: ParameterSet,
    pub notes: Vec<String>,
}

impl Validation {
    /// Index of the channel where the fit reduced the error most (relative): the equation the
    /// found effect shows in.
    pub fn most_improved_channel(&self) -> usize {
        (0..self.before.len())
            .min_by(|&a, &b| (self.after[a].rms / self.before[a].rms).total_cmp(&(self.after[b].rms / self.before[b].rms)))
            .unwrap_or(0)
    }
}

/// Validates a measured log against a starting parameter set with the equation-error route.
pub fn validate(log: &MeasuredLog, start: &ParameterSet, options: &ValidateOptions) -> Result<Validation, String> {
    let data = equation_error::prepare(log, start, &options.equation)?;
    let selection = selection::select(&data, start, &options.selection);
    let before = channel_stats(&data, &selection.before, log);
    let after = channel_stats(&data, &selection.after, log);
    let mut notes = log.notes.clone();
    notes.extend(data.notes.iter().cloned());
    Ok(Validation { data, selection, before, after, start: start.clone(), notes })
}

/// Residual statistics of a fit, per channel.
pub fn channel_stats(data: &EquationData, fit: &Fit, log: &MeasuredLog) -> Vec<ChannelStats> {
    let decimation = 2 * data.half_width + 1;
    let inputs = input_signals(data, log);
    fit.channels
        .iter()
        .enumerate()
        .map(|(c, channel)| {
            let used: Vec<f64> = fit.residual[c].iter().zip(&channel.mask).filter(|(_, m)| **m).map(|(r, _)| *r).collect();
            let measured: Vec<f64> = channel.measured.iter().zip(&channel.mask).filter(|(_, m)| **m).map(|(v, _)| *v).collect();
            // Decimate to about one sample per filter length: the smoothing correlates
            // neighbouring residual samples even when the model is right.
            let decimated: Vec<f64> = fit.residual[c].iter().step_by(decimation).copied().collect();
            let (_, whiteness_p) = stats::ljung_box(&decimated, 20.min(decimated.len() / 4).max(1));
            let lags_outside = stats::fraction_outside_whiteness_band(&decimated, 20.min(decimated.len() / 4).max(1));
            let max_lag = ((1.0 / (data.dt * decimation as f64)).round() as usize).max(1);
            let cross_correlation = inputs
                .iter()
                .map(|(name, x)| {
                    let xd: Vec<f64> = x.iter().step_by(decimation).copied().collect();
                    let cc = stats::cross_correlation(&xd, &decimated, max_lag);
                    let (lag, value) = cc.iter().fold((0isize, 0.0f64), |best, &(k, v)| if v.abs() > best.1.abs() { (k, v) } else { best });
                    (name.clone(), value, lag as f64 * data.dt * decimation as f64)
                })
                .collect();
            ChannelStats {
                name: channel.name.to_string(),
                rms: stats::rms(&used),
                fit_percent: stats::nrmse_fit_percent(&measured, &used),
                correlation_time: fit.tau[c],
                whiteness_p,
                lags_outside,
                cross_correlation,
                cross_bound: 1.96 / (decimated.len() as f64).sqrt(),
            }
        })
        .collect()
}

/// The inputs the residual is cross-correlated with, on the analysed region.
fn input_signals(data: &EquationData, log: &MeasuredLog) -> Vec<(String, Vec<f64>)> {
    let mut inputs = vec![
        ("measured torque".to_string(), data.torque.clone()),
        ("motor speed".to_string(), data.motor_vel.clone()),
        ("axis angle".to_string(), data.load_pos.clone()),
    ];
    let n = data.len();
    let start = data.first_sample;
    for (signal, name) in [(Signal::RefPos, "position command"), (Signal::WindSpeed, "wind speed"), (Signal::Elevation, "elevation")] {
        if let Some(values) = log.signal(signal) {
            if values.len() >= start + n {
                inputs.push((name.to_string(), values[start..start + n].to_vec()));
            }
        }
    }
    inputs
}
