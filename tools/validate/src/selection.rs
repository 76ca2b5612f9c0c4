//! Tracing the residual to named effects: score every candidate by how much of the residual it
//! explains, with a penalty for its parameters, add the best one if it is significant, refit,
//! repeat.
//!
//! The test: each candidate is fitted jointly with the effects already found; what it adds to
//! the model defines a direction, and its coefficient along that direction is tested against
//! a heteroscedasticity-and-autocorrelation-consistent (Newey-West) variance from the
//! alternative's residual, so a coloured residual (smoothing, model-form misfit) does not make
//! a small systematic effect look significant on a long log. The chi-squared statistic is
//! compared at a family-wise level alpha divided by the number of trials (candidates times the
//! independent alternatives their searches tried; Bonferroni), and the effect must be at least
//! the sensor noise in size (practical significance). Among significant candidates the one that
//! explains most of the residual, less a BIC penalty per parameter, is taken, refitted jointly
//! with the effects already found (Gauss-Newton), and kept if its parameters are physically
//! admissible and it is still at least the noise in size. Nothing here knows what the data
//! holds: the thresholds come from the level alpha, the residual and the noise estimated from
//! the data.

use super::candidates::{self, stack, stacked_weights, Column, Instance, Kind, Mode, Reported};
use super::equation_error::{model_channels, ChannelData, EquationData, Structure};
use super::parameters::ParameterSet;
use super::stats::correlation_time;
use antenna_dsp::chi_squared_sf;
use antenna_dsp::weighted_least_squares;
use rayon::prelude::*;

/// Settings of the search.
#[derive(Debug, Clone)]
pub struct SelectionOptions {
    /// Family-wise false-alarm level per step.
    pub alpha: f64,
    /// At most this many effects are added.
    pub max_effects: usize,
    /// The candidates tried.
    pub candidates: Vec<Kind>,
    /// Gauss-Newton iterations after adding an effect.
    pub max_iterations: usize,
    /// Practical significance: an effect is claimed only if what it adds to the model (RMS
    /// over the fitted samples) is at least this many times the sensor noise of the channel
    /// it shows in, estimated from the data. On a long log any systematic misfit becomes
    /// statistically significant, including the unavoidable difference between a static
    /// friction law and real friction dynamics; an effect below the noise is not worth a
    /// model parameter.
    pub min_effect_to_noise: f64,
}

impl Default for SelectionOptions {
    fn default() -> Self {
        SelectionOptions {
            alpha: 1e-3,
            max_effects: 4,
            candidates: Kind::ALL.to_vec(),
            max_iterations: 15,
            min_effect_to_noise: 1.0,
        }
    }
}

/// A model fitted to the data: channels at its parameters, columns, coefficients, covariance
/// and residual.
#[derive(Debug, Clone)]
pub struct Fit {
    pub channels: Vec<ChannelData>,
    pub columns: Vec<Column>,
    pub beta: Vec<f64>,
    pub covariance: nalgebra::DMatrix<f64>,
    /// Residual per channel on all samples (the mask says which were fitted).
    pub residual: Vec<Vec<f64>>,
    /// Per-channel residual standard deviation and correlation time over the fitted samples.
    pub sigma: Vec<f64>,
    pub tau: Vec<f64>,
    /// Per-channel residual sum of squares over the fitted samples.
    pub rss: Vec<f64>,
    pub used: Vec<usize>,
}

impl Fit {
    /// Effective number of independent samples over all channels.
    pub fn effective_samples(&self) -> f64 {
        self.used.iter().zip(&self.tau).map(|(n, t)| *n as f64 / t).sum()
    }

    /// Weights 1/(sigma^2 tau) per channel.
    pub fn channel_weights(&self) -> Vec<f64> {
        self.sigma.iter().zip(&self.tau).map(|(s, t)| if *s > 0.0 { 1.0 / (s * s * t) } else { 1.0 }).collect()
    }

    /// The model side of each channel after the fit (measured minus residual).
    pub fn fitted(&self) -> Vec<Vec<f64>> {
        self.channels
            .iter()
            .zip(&self.residual)
            .map(|(c, r)| c.measured.iter().zip(r).map(|(m, r)| m - r).collect())
            .collect()
    }
}

/// The score of one candidate at one step.
#[derive(Debug, Clone)]
pub struct Score {
    pub kind: Kind,
    /// Set when the candidate does not apply, with the reason.
    pub not_applicable: Option<String>,
    pub likelihood_ratio: f64,
    pub parameters: usize,
    pub p_value: f64,
    pub trials: f64,
    pub bic_gain: f64,
    /// The ranking among significant candidates: the fraction of the weighted residual the
    /// effect explains, less a BIC penalty of ln(n_eff)/n_eff per parameter in the same units.
    pub rank: f64,
    pub significant: bool,
    /// How much of the weighted residual the effect explains (fraction of RSS).
    pub explained_fraction: f64,
    /// RMS of what the effect adds, over the sensor noise, in the channel where it is largest.
    pub effect_to_noise: f64,
    pub searched: Vec<(String, f64)>,
    /// The range each searched parameter was searched over: (name, low, high, unit).
    pub searched_ranges: Vec<(String, f64, f64, String)>,
    /// The confirmation's note, for the chosen candidate.
    pub confirmation: Option<String>,
    /// The leading parameter's change that the candidate's own fit gave ([`candidates::size_change`]).
    pub fitted_change: Option<(&'static str, f64, &'static str)>,
    /// The candidate could not be set up on this log: its signals or the parameter set lack
    /// what it needs (a stiffness without two encoders). Set with `not_applicable`'s reason,
    /// never by a rejection of a significant candidate.
    pub unobservable: bool,
    /// The smallest effect of this kind the step would have found significant and at least the
    /// noise ([`DetectionLimit`]); `None` where the candidate does not apply or its fit gave
    /// nothing to scale.
    pub detection_limit: Option<DetectionLimit>,
    /// How much larger an effect must be in the direction the log resolves worst than in the
    /// direction its own fit took ([`weakest_direction_factor`]); 1 for effects of one
    /// direction.
    pub weakest_direction_factor: f64,
}

/// What sets a detection limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LimitSetBy {
    /// The significance test (the step's p threshold and a positive BIC gain).
    Significance,
    /// The practical-significance floor: the effect must be at least the noise.
    NoiseFloor,
    /// Telling it from an effect the log resolves below the noise floor, which would otherwise
    /// take it ([`limits_beside_resolved`]).
    Beside(Kind),
}

/// The probability with which an effect at its detection limit passes the step's test: the
/// limit is a size the search finds in nine logs of ten, not the size at which the expected
/// statistic just reaches the threshold (found in half of them).
pub const DETECTION_POWER: f64 = 0.9;

/// The smallest effect of a candidate's kind that a search step would find significant in
/// nine logs of ten ([`DETECTION_POWER`]) and at least the noise, to first order from the
/// candidate's own fit: what the effect adds to the equations scales with its size and the
/// test statistic's non-centrality with its square, so the fitted change over the square root
/// of its chi-square is its standard error, whatever the fit found (noise included). The step's
/// threshold already holds the trials of every candidate it searched (its level is the
/// family-wise one divided by them). A claim also needs the output error's confirmation, so
/// this is a lower bound of what the log can establish: an effect of the kind below it is likely to go unseen
/// in this log, one at or above it passes the test in nine logs of ten and is put to the
/// simulation.
#[derive(Debug, Clone, PartialEq)]
pub struct DetectionLimit {
    /// The leading parameter ([`candidates::size_change`]).
    pub parameter: &'static str,
    /// The smallest claimable |change| of it.
    pub size: f64,
    pub unit: &'static str,
    /// The same effect's RMS in the equations over the noise of the channel it shows in.
    pub effect_to_noise: f64,
    pub set_by: LimitSetBy,
    /// The ranges of the candidate's searched parameters (a delay, a cogging period, a
    /// Stribeck velocity) the limit holds for: (name, low, high, unit). An effect outside
    /// them was not searched, so no limit is stated for it.
    pub searched: Vec<(String, f64, f64, String)>,
}

impl DetectionLimit {
    /// The limit of a scored candidate at a step's p `threshold`, or `None` when its fit gave
    /// no effect to scale (a zero statistic or change).
    pub fn of(score: &Score, threshold: f64, min_effect_to_noise: f64) -> Option<Self> {
        let (parameter, change, unit) = score.fitted_change?;
        let (chi2, dof) = (score.likelihood_ratio, score.parameters as f64);
        let usable = |x: f64| x.is_finite() && x > 0.0;
        if score.not_applicable.is_some() || !usable(chi2) || !usable(change.abs()) || !usable(score.effect_to_noise) {
            return None;
        }
        // The statistic an effect needs: the chi-square quantile of the step's level, and more
        // than the BIC penalty (the score keeps the gain, chi2 less the penalty).
        let needed =
            antenna_dsp::distributions::chi_squared_quantile(1.0 - threshold, dof.max(1.0)).max(chi2 - score.bic_gain);
        if !needed.is_finite() {
            // A level too small for the quantile's precision: no finite limit to give.
            return None;
        }
        // An effect of the limit's size must pass the test in most logs, not in half of them:
        // its statistic is a non-central chi-square whose non-centrality is the square of its
        // size over the standard error, and the limit is the size at which that statistic
        // exceeds what the step needs with the probability DETECTION_POWER.
        let by_test =
            (antenna_dsp::distributions::chi_squared_noncentrality_for_power(needed, dof.max(1.0), DETECTION_POWER)
                / chi2)
                .sqrt();
        // The claim also needs the fitted effect to reach the noise: its estimate scatters by
        // a standard error about the truth, so in nine logs of ten it does where the truth is
        // that far (z of the power, in standard errors) above the floor.
        let z = antenna_dsp::distributions::standard_normal_quantile(DETECTION_POWER);
        let by_floor = min_effect_to_noise / score.effect_to_noise + z / chi2.sqrt();
        let (factor, set_by) =
            if by_test >= by_floor { (by_test, LimitSetBy::Significance) } else { (by_floor, LimitSetBy::NoiseFloor) };
        // An effect with a direction of its own (an unbalance's phase) must be found whatever
        // that direction is, not only along the one the noise gave the clean log's fit.
        Some(DetectionLimit {
            parameter,
            size: change.abs() * factor * score.weakest_direction_factor.max(1.0),
            unit,
            effect_to_noise: score.effect_to_noise * factor,
            set_by,
            searched: score.searched_ranges.clone(),
        })
    }
}

impl Score {
    /// The score of a candidate that does not apply, with the reason: never significant.
    fn not_applicable(kind: Kind, reason: String) -> Self {
        Score {
            kind,
            not_applicable: Some(reason),
            likelihood_ratio: 0.0,
            parameters: 0,
            p_value: 1.0,
            trials: 0.0,
            bic_gain: f64::NEG_INFINITY,
            rank: f64::NEG_INFINITY,
            significant: false,
            explained_fraction: 0.0,
            effect_to_noise: 0.0,
            searched: Vec::new(),
            searched_ranges: Vec::new(),
            confirmation: None,
            fitted_change: None,
            unobservable: true,
            detection_limit: None,
            weakest_direction_factor: 1.0,
        }
    }
}

/// Sensor noise of each channel (raw, before smoothing), from the model-free estimates: the
/// torque sensor for the torque equation, the twist (both encoders) for the load equation.
pub fn channel_noise(data: &EquationData) -> Vec<f64> {
    let mut noise = vec![data.torque_sigma];
    if data.structure == Structure::TwoMass {
        noise.push(data.twist_scale * data.motor_pos_sigma.hypot(data.load_pos_sigma));
    }
    noise
}

/// The noise each channel really has for an effect of `kind`: the channel noise, except that
/// with two equations a torque on the load (an offset, an unbalance, the load's inertia) is
/// judged against the torque sensor's noise in the load channel too.
///
/// The load equation's measured side is the stiffness times the twist, so its raw noise is the
/// stiffness times the encoders' noise, which on a stiff drive is hundreds of newton metres.
/// A load-side torque, however, also appears in the sum of the two equations (the total-torque
/// equation, from which the twist cancels) with the torque sensor's noise: that is the
/// equation where it is observable, and judging it against the twist's noise would hide a
/// large offset (chi-square 1185 with an effect-to-noise of 0.21 on a hidden log). The
/// stiffness, the backlash and the path damping act inside the drive and cancel from that sum,
/// so they keep the twist's noise. The load inertia's torque is in that sum too, with the load
/// encoder's noise through the smoothed second derivative, which the smoothing's own rule keeps
/// below the torque noise through the same kernel (`equation_error::smoothing_sigma`): it is
/// judged there as well (an inertia change of 38 % at chi-square 1311 had an effect-to-noise of
/// 0.62 against the twist's noise on a stiff drive with a 22-bit load encoder).
pub fn observable_noise(kind: Kind, data: &EquationData, noise: &[f64]) -> Vec<f64> {
    let load_torque = matches!(kind, Kind::Offset | Kind::Unbalance | Kind::Inertia);
    noise
        .iter()
        .enumerate()
        .map(|(c, n)| {
            if load_torque && data.structure == Structure::TwoMass && c == 1 && data.torque_sigma > 0.0 {
                n.min(data.torque_sigma)
            } else {
                *n
            }
        })
        .collect()
}

/// What an effect adds to each channel's model on every sample: its fitted columns minus its
/// adjustment.
fn effect_vector(instance: &Instance, beta: &[f64], channels: &[ChannelData]) -> Vec<Vec<f64>> {
    channels
        .iter()
        .enumerate()
        .map(|(c, channel)| {
            let n = channel.mask.len();
            let mut v = vec![0.0; n];
            for (column, b) in instance.columns.iter().zip(beta) {
                if let Some(values) = column.channels.get(c).filter(|v| !v.is_empty()) {
                    for (x, y) in v.iter_mut().zip(values) {
                        *x += b * y;
                    }
                }
            }
            if let Some(a) = instance.adjust.get(c).filter(|a| !a.is_empty()) {
                for (x, y) in v.iter_mut().zip(a) {
                    *x -= y;
                }
            }
            v
        })
        .collect()
}

/// The channel weights an effect's test uses: 1/(sigma^2 tau) of the alternative's residual
/// in each channel (the current model with the effect), sigma at least the channel's sensor
/// noise `noise`; a channel the search's `weights` leave out stays out.
///
/// The search fits with the current model's weights, whose residual holds every effect still
/// missing: where one channel's residual is mostly the effect itself (a load-inertia change of
/// 45 % on the second generator's seed 13: the load equation's residual 246 N m with a
/// correlation time of 636 samples, 8.1 N m and 16 samples with the change), that channel is
/// weighted as if it were that noisy, and the test's variance is the other channel's, whose
/// model-form misfit (74 N m, correlated over 33 samples) the effect's part there only
/// samples: chi-square 5.5 for an effect that leaves the load equation white. Weighted by what
/// the residuals are once the effect is in the model, the same direction has its load part
/// judged against the load equation's noise. Any fixed weights give a test of the right size
/// (the variance is the heteroscedasticity-and-autocorrelation-consistent one); these give it
/// its power. Where the effect is absent the alternative's residual is the current one, and
/// the weights are the search's.
fn test_weights(alternative: &Fit, noise: &[f64], weights: &[f64]) -> Vec<f64> {
    alternative
        .sigma
        .iter()
        .zip(&alternative.tau)
        .enumerate()
        .map(|(c, (sigma, tau))| {
            let sigma = sigma.max(noise.get(c).copied().unwrap_or(0.0));
            if sigma > 0.0 && weights.get(c).is_some_and(|w| *w > 0.0) {
                1.0 / (sigma * sigma * tau.max(1.0))
            } else {
                0.0
            }
        })
        .collect()
}

/// The significance of an effect as a chi-squared statistic that is robust to a coloured
/// residual: the squared coefficient of the fitted effect direction over its
/// heteroscedasticity-and-autocorrelation-consistent variance (Newey and West 1987, Bartlett
/// weights), after partialling out the other columns. For a white residual it equals the drop
/// in residual sum of squares over the variance; for a coloured one it weighs the residual's
/// correlation at the time scales of the effect itself, so a fast effect (a delay) is not
/// penalised for a slow misfit elsewhere, nor a slow effect credited with a fast one. The lag
/// window per channel is three correlation times of the residual. The noise is the
/// alternative's residual (the current model plus this candidate). An effect still missing
/// from the model counts as noise there, so two large effects in one log can hide each other
/// at the first step (a known limitation; the unrestricted model of every candidate at once
/// was tried as the noise and made every candidate significant on such logs, leaving the
/// choice to the ranking, which then picked a compromise effect).
fn robust_chi2(
    channels: &[ChannelData],
    others: &[Column],
    effect: &[Vec<f64>],
    residual: &[Vec<f64>],
    noise: &[Vec<f64>],
    weights: &[f64],
    tau: &[f64],
) -> f64 {
    let u = stack(channels, effect);
    let row_weights = stacked_weights(channels, weights);
    let stacked_others: Vec<Vec<f64>> = others.iter().map(|c| stack(channels, &c.channels)).collect();
    let (beta, _) = weighted_least_squares(&stacked_others, &u, &row_weights);
    let mut u_tilde = u.clone();
    for (column, b) in stacked_others.iter().zip(&beta) {
        for (x, c) in u_tilde.iter_mut().zip(column) {
            *x -= b * c;
        }
    }
    let e = stack(channels, residual);
    let e_noise = stack(channels, noise);
    let denominator: f64 = u_tilde.iter().zip(&row_weights).map(|(x, w)| w * x * x).sum();
    if denominator <= 0.0 {
        return 0.0;
    }
    // The fitted effect's coefficient along its own direction (1 when the residual is
    // orthogonal to the adjustment too).
    let gamma =
        u_tilde.iter().zip(e.iter().zip(&u)).zip(&row_weights).map(|((x, (r, v)), w)| w * x * (r + v)).sum::<f64>()
            / denominator;
    let mut variance = 0.0;
    let mut start = 0;
    for (c, channel) in channels.iter().enumerate() {
        let rows = channel.mask.iter().filter(|m| **m).count();
        let g: Vec<f64> = (start..start + rows).map(|i| row_weights[i] * u_tilde[i] * e_noise[i]).collect();
        start += rows;
        let lags = ((3.0 * tau.get(c).copied().unwrap_or(1.0)).ceil() as usize).clamp(1, (rows / 10).max(1));
        variance += antenna_dsp::stats::bartlett_long_run_sum(&g, lags);
    }
    let variance = variance / (denominator * denominator);
    if variance > 0.0 {
        gamma * gamma / variance
    } else {
        0.0
    }
}

/// The size of an accepted effect at the refined parameters: the RMS change of each channel's
/// residual when the effect's parameters go back to their values before it was added, over
/// the channel's noise, largest over channels.
fn refined_effect_to_noise(
    data: &EquationData,
    kind: Kind,
    refined: &ParameterSet,
    before: &ParameterSet,
    noise: &[f64],
) -> f64 {
    let reset = without_effect(kind, refined, before);
    let with = model_channels(data, refined);
    let without = model_channels(data, &reset);
    with.iter()
        .zip(&without)
        .zip(&observable_noise(kind, data, noise))
        .map(|((a, b), n)| {
            let (mut sum, mut count) = (0.0, 0usize);
            for i in 0..a.mask.len() {
                if a.mask[i] {
                    let d = (a.measured[i] - a.predicted[i]) - (b.measured[i] - b.predicted[i]);
                    sum += d * d;
                    count += 1;
                }
            }
            if *n > 0.0 {
                (sum / count.max(1) as f64).sqrt() / n
            } else {
                0.0
            }
        })
        .fold(0.0, f64::max)
}

/// The size of an effect's change from `before` to `refined` in the equations, over the
/// noise of the channel it shows in (largest over channels): the search's practical
/// significance, for a change found elsewhere ([`crate::reestimate`]).
pub fn change_to_noise(data: &EquationData, kind: Kind, refined: &ParameterSet, before: &ParameterSet) -> f64 {
    refined_effect_to_noise(data, kind, refined, before, &channel_noise(data))
}

/// `params` with the parameters of one effect put back to their values in `before` (the
/// effect removed, everything else kept; for friction levels, only the effect's own change).
pub fn without_effect(kind: Kind, params: &ParameterSet, before: &ParameterSet) -> ParameterSet {
    use super::parameters::names;
    let mut reset = params.clone();
    let copy = |reset: &mut ParameterSet, name: &str| reset.set(name, before.value(name));
    match kind {
        Kind::Coulomb => {
            let change = params.value(names::COULOMB) - before.value(names::COULOMB);
            reset.set(names::COULOMB, before.value(names::COULOMB));
            reset.set(names::STATIC, params.value(names::STATIC) - change);
        }
        Kind::Viscous => copy(&mut reset, names::VISCOUS),
        Kind::Stribeck => {
            let hump = before.value(names::STATIC) - before.value(names::COULOMB);
            reset.set(names::STATIC, params.value(names::COULOMB) + hump);
            copy(&mut reset, names::STRIBECK_VELOCITY);
        }
        Kind::Offset => copy(&mut reset, names::TORQUE_OFFSET),
        Kind::Backlash => copy(&mut reset, names::BACKLASH_WIDTH),
        Kind::Stiffness => {
            copy(&mut reset, names::STIFFNESS);
            copy(&mut reset, names::DAMPING);
        }
        Kind::Inertia => {
            copy(&mut reset, names::LOAD_INERTIA);
            copy(&mut reset, names::MOTOR_INERTIA);
        }
        Kind::Unbalance => {
            copy(&mut reset, names::UNBALANCE_TORQUE);
            copy(&mut reset, names::UNBALANCE_PHASE);
        }
        Kind::Delay => copy(&mut reset, names::DELAY),
        Kind::TorqueConstant => copy(&mut reset, names::TORQUE_CONSTANT_SCALE),
        Kind::Cogging => {
            copy(&mut reset, names::COGGING_AMPLITUDE);
            copy(&mut reset, names::COGGING_PERIOD);
            copy(&mut reset, names::COGGING_PHASE);
        }
    }
    reset
}

/// What an effect adds to each channel's model: its fitted columns minus its adjustment.
fn contribution(instance: &Instance, beta: &[f64], channels: &[ChannelData]) -> Vec<f64> {
    channels
        .iter()
        .enumerate()
        .map(|(c, channel)| {
            let n = channel.mask.len();
            let mut sum = 0.0;
            let mut count = 0usize;
            for i in 0..n {
                if !channel.mask[i] {
                    continue;
                }
                let mut v = 0.0;
                for (column, b) in instance.columns.iter().zip(beta) {
                    if let Some(values) = column.channels.get(c).filter(|v| !v.is_empty()) {
                        v += b * values[i];
                    }
                }
                if let Some(a) = instance.adjust.get(c).filter(|a| !a.is_empty()) {
                    v -= a[i];
                }
                sum += v * v;
                count += 1;
            }
            (sum / count.max(1) as f64).sqrt()
        })
        .collect()
}

/// One step of the search.
#[derive(Debug, Clone)]
pub struct Step {
    pub scores: Vec<Score>,
    pub chosen: Option<Kind>,
    /// The second effect when a pair was taken jointly (no single one passed).
    pub paired: Option<Kind>,
    /// The p-value threshold in force (alpha / total trials).
    pub threshold: f64,
    /// Gauss-Newton iterations used after adding the chosen effect.
    pub iterations: usize,
    /// Other candidates the judge confirmed in this step that the chosen effect does not
    /// predict significantly better: the data cannot tell them from it (an unbalance over a
    /// few degrees of axis angle near its extremum is a constant torque, an offset).
    pub equally_consistent: Vec<Kind>,
    /// A step of the re-estimation of the families the starting set holds
    /// ([`crate::reestimate`]): the scores are the equation error's tests of each family from
    /// its neutral value, and the chosen one was refitted and confirmed on the output error.
    pub re_estimate: bool,
}

/// An effect the search added, with its fitted parameters.
#[derive(Debug, Clone)]
pub struct Found {
    pub kind: Kind,
    pub parameters: Reported,
    /// How strongly its estimates go with each other found effect's in the joint fit: the
    /// largest correlation (by magnitude) between a parameter of it and one of the other, from
    /// the joint covariance of all found effects and the baseline. Effects whose columns
    /// overlap over the log (an unbalance near its extremum and a constant, a Coulomb level
    /// and a viscous term over a one-directional move) trade their sizes: near 1 in magnitude
    /// only their sum is determined, and each one's standard deviation already holds that
    /// trade.
    pub correlations: Vec<(Kind, f64)>,
}

/// The outcome of the search.
#[derive(Debug, Clone)]
pub struct Selection {
    pub before: Fit,
    pub after: Fit,
    pub steps: Vec<Step>,
    pub found: Vec<Found>,
    pub corrected: ParameterSet,
    /// Effects added by the forward search and removed again by the backward check, with the
    /// reason (the model without them predicts as well).
    pub removed: Vec<(Kind, String)>,
    /// Found effects a check after the search cannot tell from another kind: (found, other,
    /// the check's reason), e.g. a backlash where the frequency response's spring alone is off.
    pub alike_after_search: Vec<(Kind, Kind, String)>,
}

impl Selection {
    /// Makes `params` the corrected set with `kinds` as the found effects (after a refit on the
    /// output error or a re-estimation): their figures, and the equation error after, at those
    /// parameters.
    pub fn adopt(&mut self, data: &EquationData, start: &ParameterSet, params: ParameterSet, kinds: &[Kind]) {
        let weights = self.after.channel_weights();
        let (_, found) = final_fit(data, start, &params, kinds, &weights);
        self.after = fit_fixed(data, &params, &weights);
        self.found = found;
        self.corrected = params;
    }

    /// The search's last step (not a re-estimation's), whose scores are of the final model.
    fn last_search_step(&self) -> Option<&Step> {
        self.steps.iter().rev().find(|s| !s.re_estimate)
    }

    /// The detection limit of every candidate the search's last step scored and nothing
    /// claimed: the smallest change of each kind this log would have found significant and at
    /// least the noise ([`DetectionLimit`]). Empty when the search stopped at its effect limit
    /// (its last step chose one) or never ran.
    pub fn detection_limits(&self) -> Vec<(Kind, DetectionLimit)> {
        let Some(last) = self.last_search_step() else { return Vec::new() };
        if last.chosen.is_some() {
            return Vec::new();
        }
        let found: Vec<Kind> = self.found.iter().map(|f| f.kind).collect();
        last.scores
            .iter()
            // A candidate the output error rejected is seen, not below a limit: its note says so.
            .filter(|s| !found.contains(&s.kind) && s.not_applicable.is_none() && !s.significant)
            .filter_map(|s| Some((s.kind, s.detection_limit.clone()?)))
            .collect()
    }

    /// The candidates the search's last step could not set up on this log, with the reason
    /// (a stiffness or a backlash without two encoders): the log cannot show them.
    pub fn unobservable(&self) -> Vec<(Kind, String)> {
        let Some(last) = self.last_search_step() else { return Vec::new() };
        last.scores
            .iter()
            .filter(|s| s.unobservable)
            .filter_map(|s| Some((s.kind, s.not_applicable.clone()?)))
            .collect()
    }

    /// Records `other` as one the data cannot tell from the found effect `found`, by a check
    /// after the search (the frequency response's spring against a backlash), with its reason.
    pub fn mark_equally_consistent(&mut self, found: Kind, other: Kind, reason: String) {
        if !self.alike_after_search.iter().any(|(f, o, _)| *f == found && *o == other) {
            self.alike_after_search.push((found, other, reason));
        }
    }

    /// The candidates the data cannot tell from a found effect: confirmed in the step that
    /// chose it and not predicted significantly worse; and any effect the backward check
    /// removed whose own step could not tell it from this one (the search took that one first,
    /// then this one on top, and kept this one: it stands for both, so the label must not
    /// depend on which the search happened to try first).
    pub fn equally_consistent(&self, kind: Kind) -> Vec<Kind> {
        let single = |s: &&Step| s.paired.is_none();
        let mut alike: Vec<Kind> = self
            .steps
            .iter()
            .filter(single)
            .filter(|s| s.chosen == Some(kind))
            .flat_map(|s| s.equally_consistent.iter().copied())
            .collect();
        for (gone, _) in &self.removed {
            let could_not_tell = self
                .steps
                .iter()
                .filter(single)
                .any(|s| s.chosen == Some(*gone) && s.equally_consistent.contains(&kind));
            if could_not_tell && *gone != kind && !alike.contains(gone) {
                alike.push(*gone);
            }
        }
        for (_, other, _) in self.alike_after_search.iter().filter(|(found, _, _)| *found == kind) {
            if !alike.contains(other) {
                alike.push(*other);
            }
        }
        alike
    }
}

/// Nuisance columns that every model carries: with two equations, the twist offset c (encoder
/// zero offsets and preload), which enters the motor equation as -K c and the load equation
/// as +K0 c.
fn baseline_columns(data: &EquationData, params: &ParameterSet) -> Vec<Column> {
    if data.structure != Structure::TwoMass {
        return Vec::new();
    }
    let n = data.len();
    let k = params.value(super::parameters::names::STIFFNESS);
    if data.slow_twist_hats.is_empty() {
        return vec![Column {
            label: "twist offset (nuisance)".into(),
            unit: "rad".into(),
            channels: vec![vec![-k; n], vec![data.twist_scale; n]],
        }];
    }
    // An integrated motor position: the twist offset varies slowly, one hat function a knot.
    data.slow_twist_hats
        .iter()
        .enumerate()
        .map(|(j, hat)| Column {
            label: format!("twist offset at knot {j} (nuisance)"),
            unit: "rad".into(),
            channels: vec![hat.iter().map(|h| -k * h).collect(), hat.iter().map(|h| data.twist_scale * h).collect()],
        })
        .collect()
}

/// The slow candidates a twist offset that varies in time could take the place of: every
/// effect whose columns are slow on the time scale of a speed sensor's drift (friction levels,
/// offset, unbalance, the drive path, inertias, the torque constant). A delay and a cogging
/// are fast and are not in the list.
fn slow_kinds() -> Vec<Kind> {
    Kind::ALL.into_iter().filter(|k| !matches!(k, Kind::Delay | Kind::Cogging)).collect()
}

/// The slow twist offset's value at each of the data's knots (`data.slow_twist_hats`) and the
/// coefficient of each of `twists` (further twist shapes, axis rad per unit), fitted on both
/// torque equations at `params` together with the linearised columns of every slow candidate
/// ([`slow_kinds`]), with the search's channel weights (1/(sigma^2 tau) from a first fit
/// weighted by each channel's sensor noise, [`channel_noise`]). A twist offset enters the two equations with opposite signs and the
/// stiffness as its unit, an offset or an unbalance only the load's, a friction level only the
/// motor's: fitted together, none of them is taken for the others, and the load equation, whose
/// noise is the encoders' (not the torque sensor's), carries the twist's estimate. Empty
/// without knots.
pub fn slow_twist_offsets(data: &EquationData, params: &ParameterSet, twists: &[Vec<f64>]) -> Vec<f64> {
    if data.slow_twist_hats.is_empty() || data.structure != Structure::TwoMass {
        return Vec::new();
    }
    let channels = model_channels(data, params);
    let k = params.value(super::parameters::names::STIFFNESS);
    let extra: Vec<Column> = twists
        .iter()
        .map(|twist| Column {
            label: "twist shape (nuisance)".into(),
            unit: "rad".into(),
            channels: vec![
                twist.iter().map(|x| -k * x).collect(),
                twist.iter().map(|x| data.twist_scale * x).collect(),
            ],
        })
        .collect();
    let with = |weights: &[f64]| -> Fit {
        let (mut columns, _) = refine_columns(data, params, &channels, &slow_kinds(), weights);
        // The baseline (the knots) comes first; the further shapes follow it.
        let knots = data.slow_twist_hats.len();
        columns.splice(knots..knots, extra.iter().cloned());
        fit(&channels, &columns, &[], weights)
    };
    // The first fit is weighted by the sensors' noise, not equally in newton metres: the load
    // equation's noise is the encoders' (a few newton metres), the motor equation's the torque
    // sensor's, ten times more. With equal weights a torque at the motor that no slow column
    // holds (a cogging whose period the axis crosses slowly) went half into the twist offset
    // and half into the load equation's residual, whose first-fit spread and correlation time
    // then kept the load equation's weight low in the second fit as well.
    let noise_weights: Vec<f64> =
        channel_noise(data).iter().map(|s| if *s > 0.0 { 1.0 / (s * s) } else { 1.0 }).collect();
    let first = with(&noise_weights);
    let weighted = with(&first.channel_weights());
    weighted.beta[..data.slow_twist_hats.len() + twists.len()].to_vec()
}

/// Fits `columns` to the residual of `channels` plus `adjust` with per-channel weights.
fn fit(channels: &[ChannelData], columns: &[Column], adjust: &[Vec<f64>], channel_weights: &[f64]) -> Fit {
    let start: Vec<Vec<f64>> = channels.iter().map(|c| c.residual()).collect();
    let mut residual: Vec<Vec<f64>> = (0..channels.len())
        .map(|c| match adjust.get(c).filter(|a| !a.is_empty()) {
            Some(a) => start[c].iter().zip(a).map(|(r, a)| r + a).collect(),
            None => start[c].clone(),
        })
        .collect();
    let target = stack(channels, &residual);
    let weights = stacked_weights(channels, channel_weights);
    let stacked: Vec<Vec<f64>> = columns.iter().map(|c| stack(channels, &c.channels)).collect();
    let (beta, covariance) = weighted_least_squares(&stacked, &target, &weights);
    for (column, b) in columns.iter().zip(&beta) {
        for (c, values) in column.channels.iter().enumerate() {
            if values.is_empty() {
                continue;
            }
            for (r, v) in residual[c].iter_mut().zip(values) {
                *r -= b * v;
            }
        }
    }
    // The channels' statistics (the correlation time's transform most of all) are computed
    // side by side and collected in channel order.
    let per_channel: Vec<(f64, f64, f64, usize)> = channels
        .par_iter()
        .zip(&residual)
        .map(|(channel, residual)| {
            let fitted: Vec<f64> = residual.iter().zip(&channel.mask).filter(|(_, m)| **m).map(|(r, _)| *r).collect();
            let sum: f64 = fitted.iter().map(|r| r * r).sum();
            let sigma = (sum / fitted.len().max(1) as f64).sqrt();
            let tau = if fitted.len() > 10 { correlation_time(&fitted) } else { 1.0 };
            (sigma, tau, sum, fitted.len())
        })
        .collect();
    let sigma = per_channel.iter().map(|s| s.0).collect();
    let tau = per_channel.iter().map(|s| s.1).collect();
    let rss = per_channel.iter().map(|s| s.2).collect();
    let used = per_channel.iter().map(|s| s.3).collect();
    Fit { channels: channels.to_vec(), columns: columns.to_vec(), beta, covariance, residual, sigma, tau, rss, used }
}

fn add_adjust(a: &[Vec<f64>], b: &[Vec<f64>], channels: usize) -> Vec<Vec<f64>> {
    (0..channels)
        .map(|c| {
            let x = a.get(c).filter(|v| !v.is_empty());
            let y = b.get(c).filter(|v| !v.is_empty());
            match (x, y) {
                (Some(x), Some(y)) => x.iter().zip(y).map(|(p, q)| p + q).collect(),
                (Some(x), None) => x.clone(),
                (None, Some(y)) => y.clone(),
                (None, None) => Vec::new(),
            }
        })
        .collect()
}

/// The accepted effects linearised at `params`, with the baseline first.
fn refine_columns(
    data: &EquationData,
    params: &ParameterSet,
    channels: &[ChannelData],
    accepted: &[Kind],
    weights: &[f64],
) -> (Vec<Column>, Vec<Instance>) {
    let mut columns = baseline_columns(data, params);
    let mut instances = Vec::new();
    let zero: Vec<Vec<f64>> = channels.iter().map(|_| Vec::new()).collect();
    for &kind in accepted {
        if let Ok(instance) = candidates::instantiate(kind, data, params, channels, &zero, weights, Mode::Refine) {
            columns.extend(instance.columns.iter().cloned());
            instances.push(instance);
        }
    }
    (columns, instances)
}

/// Gauss-Newton on the accepted effects' parameters: linearise at the current parameters, fit
/// the increments, apply them, until the increments are small compared with their standard
/// deviations. Returns the parameters and the fit at them (coefficients near zero, covariance
/// of the increments = covariance of the parameters).
fn refine(
    data: &EquationData,
    mut params: ParameterSet,
    accepted: &[Kind],
    weights: &[f64],
    max_iterations: usize,
) -> (ParameterSet, Fit, usize) {
    let baseline = baseline_columns(data, &params).len();
    let mut iterations = 0;
    loop {
        let channels = model_channels(data, &params);
        let (columns, instances) = refine_columns(data, &params, &channels, accepted, weights);
        let result = fit(&channels, &columns, &[], weights);
        if iterations >= max_iterations || instances.is_empty() {
            return (params, result, iterations);
        }
        let mut offset = baseline;
        let mut converged = true;
        let mut next = params.clone();
        for instance in &instances {
            let k = instance.columns.len();
            let beta = &result.beta[offset..offset + k];
            for (i, b) in beta.iter().enumerate() {
                let sd = result.covariance[(offset + i, offset + i)].max(0.0).sqrt();
                if b.abs() > 0.01 * sd.max(f64::MIN_POSITIVE) {
                    converged = false;
                }
            }
            candidates::apply(instance, beta, data, &mut next);
            offset += k;
        }
        if converged {
            return (params, result, iterations);
        }
        params = next;
        iterations += 1;
    }
}

/// A judge of candidate effects beyond the equation-error tests; the output error is one.
pub trait Judge {
    /// Whether an effect may be claimed: given the effect, the parameters without it and the
    /// refined parameters with it, `Ok` with a note to keep it, `Err` with the reason to
    /// reject it.
    fn confirm(&mut self, kind: Kind, without: &ParameterSet, with: &ParameterSet) -> Result<String, String>;
    /// Whether two effects taken together may be claimed: the model `with` both against the
    /// model `without` either, paying for the parameters of both. By default, both confirmed
    /// each on its own account (a judge that simulates compares the two models directly).
    fn confirm_joint(
        &mut self,
        kinds: [Kind; 2],
        without: &ParameterSet,
        with: &ParameterSet,
    ) -> Result<String, String> {
        self.confirm(kinds[0], without, with)?;
        self.confirm(kinds[1], without, with)
    }
    /// Whether the model `challenger` predicts significantly better than `incumbent`, two
    /// confirmed alternatives of one step (`extra` is how many more parameters the challenger
    /// has). The equation error ranks the candidates; a judge that can compare them overrules
    /// the ranking only on significant evidence.
    fn prefers(&mut self, _incumbent: &ParameterSet, _challenger: &ParameterSet, _extra: isize) -> bool {
        false
    }
    /// Whether [`Judge::prefers`] can ever say yes (otherwise the search stops at the first
    /// confirmed candidate).
    fn compares(&self) -> bool {
        false
    }
}

/// The judge that accepts everything: the equation-error tests alone decide.
pub struct EquationOnly;

impl Judge for EquationOnly {
    fn confirm(&mut self, _: Kind, _: &ParameterSet, _: &ParameterSet) -> Result<String, String> {
        Ok(String::new())
    }
}

/// Fits one more effect on top of a model with `accepted` effects, as the search would (grid
/// search of its nonlinear parameters, joint Gauss-Newton refit), without testing it. For
/// diagnostics: what the effect would be if it were added.
pub fn fit_candidate(
    data: &EquationData,
    params: &ParameterSet,
    accepted: &[Kind],
    kind: Kind,
    options: &SelectionOptions,
) -> Result<ParameterSet, CandidateFitError> {
    let channels = model_channels(data, params);
    let unit = vec![1.0; channels.len()];
    let first = fit(&channels, &baseline_columns(data, params), &[], &unit);
    let weights = first.channel_weights();
    let (accepted_columns, accepted_instances) = refine_columns(data, params, &channels, accepted, &weights);
    let current = fit(&channels, &accepted_columns, &[], &weights);
    let instance = candidates::instantiate(kind, data, params, &channels, &current.residual, &weights, Mode::Search)?;
    let mut columns = accepted_columns.clone();
    columns.extend(instance.columns.iter().cloned());
    let alternative = fit(&channels, &columns, &add_adjust(&[], &instance.adjust, channels.len()), &weights);
    let mut offset = baseline_columns(data, params).len();
    let mut next = params.clone();
    for previous in &accepted_instances {
        let k = previous.columns.len();
        candidates::apply(previous, &alternative.beta[offset..offset + k], data, &mut next);
        offset += k;
    }
    candidates::apply(&instance, &alternative.beta[offset..offset + instance.columns.len()], data, &mut next);
    let mut trial = accepted.to_vec();
    trial.push(kind);
    let (refined, _, _) = refine(data, next, &trial, &weights, options.max_iterations);
    candidates::admissible(&refined, data)?;
    Ok(refined)
}

/// Why [`fit_candidate`] gives no parameter set.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CandidateFitError {
    #[error("the candidate does not apply to this log: {0}")]
    NotApplicable(#[from] candidates::NotApplicable),
    #[error("the fitted set is not admissible: {0}")]
    Inadmissible(#[from] candidates::Inadmissible),
}

/// Runs the search on conditioned data from a starting parameter set.
pub fn select(data: &EquationData, start: &ParameterSet, options: &SelectionOptions) -> Selection {
    select_judged(data, start, options, &mut EquationOnly)
}

/// Runs the search, asking the judge about every effect that passes the equation-error tests
/// and is admissible; a rejected effect is not claimed and the next candidate is tried.
pub fn select_judged(
    data: &EquationData,
    start: &ParameterSet,
    options: &SelectionOptions,
    judge: &mut dyn Judge,
) -> Selection {
    let channel_count = data.channels.len();
    let unit = vec![1.0; channel_count];
    let first = fit(&data.channels, &baseline_columns(data, start), &[], &unit);
    let before = fit(&data.channels, &baseline_columns(data, start), &[], &first.channel_weights());
    let mut model = Model { params: start.clone(), current: before.clone(), accepted: Vec::new(), pairs: Vec::new() };
    let mut steps = Vec::new();
    let noise = channel_noise(data);

    while model.accepted.len() < options.max_effects {
        let step = forward_step(data, &mut model, &noise, options, judge);
        let done = step.chosen.is_none();
        steps.push(step);
        if done {
            break;
        }
    }

    let mut removed = backward_check(data, start, &mut model, options, judge);
    removed.extend(drop_lone_pair_members(data, start, &mut model, options));

    // With every effect removed again the model is the starting one, exactly (the resets of
    // a friction level are differences that need not round back).
    if model.accepted.is_empty() {
        model.params = start.clone();
        model.current = before.clone();
    }

    let swapped = swap_retest(data, start, &mut model, &steps, options, judge);
    for (from, to) in &swapped {
        removed.push((
            *from,
            format!("replaced by {} in the final model, which then predicts significantly better", to.name()),
        ));
    }

    // A last fit with weights from the final residual, so the covariance reflects the final
    // residual level.
    let Model { params, mut current, accepted, .. } = model;
    let mut found = Vec::new();
    if !accepted.is_empty() {
        (current, found) = final_fit(data, start, &params, &accepted, &current.channel_weights());
    }
    Selection { before, after: current, steps, found, corrected: params, removed, alike_after_search: Vec::new() }
}

/// The model as the search builds it: parameters, their fit, the effects accepted so far, and
/// the effects taken as a pair (each was claimed only jointly with the other).
struct Model {
    params: ParameterSet,
    current: Fit,
    accepted: Vec<Kind>,
    pairs: Vec<(Kind, Kind)>,
}

/// One step of the forward search: score every candidate, put the significant ones to the
/// judge best first, and add the chosen effect (or, when no single one passes, a pair) to the
/// model. A step that chooses nothing ends the search.
fn forward_step(
    data: &EquationData,
    model: &mut Model,
    noise: &[f64],
    options: &SelectionOptions,
    judge: &mut dyn Judge,
) -> Step {
    let weights = model.current.channel_weights();
    let (mut scores, evaluated, threshold) = score_candidates(data, model, &weights, noise, options);
    let (chosen, equally_consistent) =
        choose_confirmed(data, model, &mut scores, &evaluated, &weights, noise, options, judge);
    let Some((kind, refined, refined_fit, iterations)) = chosen else {
        // No single effect: two large missing effects can hide each other, each counting
        // as noise in the other's test. Pairs are tested jointly before giving up, when a
        // judge that compares models (the output error) confirms each member.
        let pair = if judge.compares() && model.accepted.len() + 2 <= options.max_effects {
            search_pair(
                data,
                &model.params,
                &model.current,
                &model.accepted,
                &evaluated,
                &weights,
                noise,
                threshold,
                options,
                judge,
            )
        } else {
            None
        };
        let Some((a, b, refined, refined_fit, iterations)) = pair else {
            return Step {
                scores,
                chosen: None,
                paired: None,
                threshold,
                iterations: 0,
                equally_consistent: Vec::new(),
                re_estimate: false,
            };
        };
        model.accepted.push(a);
        model.accepted.push(b);
        model.pairs.push((a, b));
        model.params = refined;
        model.current = refined_fit;
        return Step {
            scores,
            chosen: Some(a),
            paired: Some(b),
            threshold,
            iterations,
            equally_consistent: Vec::new(),
            re_estimate: false,
        };
    };
    model.accepted.push(kind);
    model.params = refined;
    model.current = refined_fit;
    Step { scores, chosen: Some(kind), paired: None, threshold, iterations, equally_consistent, re_estimate: false }
}

/// The equation-error test of an effect's whole family, as a start without it would have had
/// it: `neutral` is the model with the family at its neutral value (no Coulomb friction, no
/// load inertia, ...), the `accepted` effects are fitted jointly, and the candidate `kind` is
/// scored from there and marked significant at `threshold` (the search's last step's level),
/// with the BIC and the noise conditions of the search. A starting set that holds a guess of
/// a family cannot otherwise show that the data carry the family at all: its test is of the
/// change from the guess, which on a coloured residual can be well inside the equation error's
/// uncertainty while the simulation still tells the guess from the data.
pub fn presence(
    data: &EquationData,
    neutral: &ParameterSet,
    accepted: &[Kind],
    kind: Kind,
    threshold: f64,
    options: &SelectionOptions,
) -> Score {
    let channels = model_channels(data, neutral);
    let unit = vec![1.0; channels.len()];
    let first = fit(&channels, &baseline_columns(data, neutral), &[], &unit);
    let (columns, _) = refine_columns(data, neutral, &channels, accepted, &first.channel_weights());
    let current = fit(&channels, &columns, &[], &first.channel_weights());
    let model = Model { params: neutral.clone(), current, accepted: accepted.to_vec(), pairs: Vec::new() };
    let weights = model.current.channel_weights();
    let only = SelectionOptions { candidates: vec![kind], ..options.clone() };
    let (scores, _, _) = score_candidates(data, &model, &weights, &channel_noise(data), &only);
    let mut score =
        scores.into_iter().next().unwrap_or_else(|| Score::not_applicable(kind, "already in the model".into()));
    score.significant = score.not_applicable.is_none()
        && score.p_value < threshold
        && score.bic_gain > 0.0
        && score.effect_to_noise >= options.min_effect_to_noise;
    score
}

/// Every candidate not yet accepted, fitted jointly with the accepted effects and tested:
/// the scores (in the order of `options.candidates`, each marked significant or not), the
/// instantiated candidates with their alternative fits, and the step's p-value threshold.
fn score_candidates(
    data: &EquationData,
    model: &Model,
    weights: &[f64],
    noise: &[f64],
    options: &SelectionOptions,
) -> (Vec<Score>, Vec<(Instance, Fit)>, f64) {
    let channel_count = data.channels.len();
    let current = &model.current;
    let (accepted_columns, _) = refine_columns(data, &model.params, &current.channels, &model.accepted, weights);
    // Each candidate is instantiated, fitted and tested on its own, side by side on the rayon
    // pool; the results are collected in the candidates' order, so nothing depends on the
    // number of threads.
    let pending: Vec<Kind> = options.candidates.iter().copied().filter(|k| !model.accepted.contains(k)).collect();
    let outcomes: Vec<(Score, Option<(Instance, Fit)>)> = pending
        .par_iter()
        .map(|&kind| {
            match candidates::instantiate(
                kind,
                data,
                &model.params,
                &current.channels,
                &current.residual,
                weights,
                Mode::Search,
            ) {
                Ok(instance) => {
                    let (score, alternative) =
                        score_instance(data, model, &accepted_columns, &instance, weights, noise, channel_count);
                    (score, Some((instance, alternative)))
                }
                Err(reason) => (Score::not_applicable(kind, reason.to_string()), None),
            }
        })
        .collect();
    // The scores in the order one candidate after another gave them (the not-applicable ones
    // first), which the stable sort below keeps for equal keys.
    let (mut scores, mut applicable, mut evaluated) = (Vec::new(), Vec::new(), Vec::new());
    for (score, fitted) in outcomes {
        match fitted {
            None => scores.push(score),
            Some(fitted) => {
                applicable.push(score);
                evaluated.push(fitted);
            }
        }
    }
    scores.extend(applicable);
    scores.sort_by_key(|s| options.candidates.iter().position(|k| *k == s.kind));
    let total_trials: f64 = scores.iter().map(|s| s.trials).sum::<f64>().max(1.0);
    let threshold = options.alpha / total_trials;
    for score in &mut scores {
        score.significant = score.not_applicable.is_none()
            && score.p_value < threshold
            && score.bic_gain > 0.0
            && score.effect_to_noise >= options.min_effect_to_noise;
        score.detection_limit = DetectionLimit::of(score, threshold, options.min_effect_to_noise);
    }
    let context = StepContext { data, model, accepted_columns: &accepted_columns, weights, noise };
    limits_beside_resolved(&context, &mut scores, &evaluated, threshold, options.min_effect_to_noise);
    (scores, evaluated, threshold)
}

/// What a step's candidates are scored against: the data, the current model, its accepted
/// effects' columns, the weights and the channels' noise.
struct StepContext<'a> {
    data: &'a EquationData,
    model: &'a Model,
    accepted_columns: &'a [Column],
    weights: &'a [f64],
    noise: &'a [f64],
}

/// A candidate the log resolves (its test passed: p below the step's threshold and a positive
/// BIC gain) that is not claimed because it is smaller than the noise floor, and that can
/// stand in for another effect: an effect linear in its parameters (no adjustment of the
/// residual), and not a delay or a cogging torque, whose structure no other effect shares.
fn resolved_below_floor(score: &Score, instance: &Instance, threshold: f64) -> bool {
    score.not_applicable.is_none()
        && !score.significant
        && score.p_value < threshold
        && score.bic_gain > 0.0
        && instance.adjust.iter().all(Vec::is_empty)
        && !matches!(score.kind, Kind::Delay | Kind::Cogging)
}

/// A limit fitted beside an effect the log resolves below the floor replaces the limit alone
/// only when it is larger by more than this factor: a limit is first order from one clean
/// fit, and a rise within a tenth is inside its own precision, not a competitor's doing.
const BESIDE_MARGIN: f64 = 1.1;

/// Raises each unclaimed candidate's detection limit to what it needs to be told from the
/// effects the log resolves below the noise floor ([`resolved_below_floor`]).
///
/// Such an effect is in the data, only too small to claim. An effect of another kind whose
/// form overlaps it (an offset and an unbalance over a short stroke: a constant and the
/// unbalance's constant-and-slope) adds to its fit, and the search then claims it instead,
/// once the sum reaches the floor: the kind added is not named. A kind's limit is therefore
/// the larger of its limit alone and its limit fitted beside those effects, whose statistic
/// is its partial one (what it explains that the other cannot) and whose standard error holds
/// the trade between them, taken over each such effect in turn (the search names one in place
/// of another), the largest with the effect that sets it. Where nothing is resolved below the
/// floor the limits are unchanged.
fn limits_beside_resolved(
    context: &StepContext,
    scores: &mut [Score],
    evaluated: &[(Instance, Fit)],
    threshold: f64,
    min_effect_to_noise: f64,
) {
    let instance_of = |kind: Kind| evaluated.iter().map(|(i, _)| i).find(|i| i.kind == kind);
    let resolved: Vec<Kind> = scores
        .iter()
        .filter(|s| instance_of(s.kind).is_some_and(|i| resolved_below_floor(s, i, threshold)))
        .map(|s| s.kind)
        .collect();
    if resolved.is_empty() {
        return;
    }
    let channel_count = context.data.channels.len();
    let partial: Vec<Option<(Kind, DetectionLimit)>> = scores
        .par_iter()
        .map(|score| {
            let instance = instance_of(score.kind)?;
            score.detection_limit.as_ref()?;
            // One competitor at a time: the search names one effect in place of another, and
            // the limit is what it takes to be told from the one that takes most of it.
            resolved
                .iter()
                .filter(|k| **k != score.kind)
                .filter_map(|k| instance_of(*k))
                .filter_map(|competitor| {
                    let mut columns = context.accepted_columns.to_vec();
                    columns.extend(competitor.columns.iter().cloned());
                    let (partial, _) = score_instance(
                        context.data,
                        context.model,
                        &columns,
                        instance,
                        context.weights,
                        context.noise,
                        channel_count,
                    );
                    Some((competitor.kind, DetectionLimit::of(&partial, threshold, min_effect_to_noise)?))
                })
                .max_by(|a, b| a.1.size.total_cmp(&b.1.size))
        })
        .collect();
    for (score, partial) in scores.iter_mut().zip(partial) {
        let (Some(limit), Some((competitor, beside))) = (score.detection_limit.as_mut(), partial) else { continue };
        if beside.size > BESIDE_MARGIN * limit.size {
            *limit = DetectionLimit { set_by: LimitSetBy::Beside(competitor), ..beside };
        }
    }
}

/// One instantiated candidate fitted jointly with the accepted effects and tested: its score
/// (not yet marked significant) and the alternative fit.
fn score_instance(
    data: &EquationData,
    model: &Model,
    accepted_columns: &[Column],
    instance: &Instance,
    weights: &[f64],
    noise: &[f64],
    channel_count: usize,
) -> (Score, Fit) {
    let current = &model.current;
    let kind = instance.kind;
    let mut columns = accepted_columns.to_vec();
    columns.extend(instance.columns.iter().cloned());
    let adjust = add_adjust(&[], &instance.adjust, channel_count);
    let alternative = fit(&current.channels, &columns, &adjust, weights);
    let own_beta = &alternative.beta[accepted_columns.len()..];
    let effect = effect_vector(instance, own_beta, &current.channels);
    let lr = robust_chi2(
        &current.channels,
        accepted_columns,
        &effect,
        &alternative.residual,
        &alternative.residual,
        &test_weights(&alternative, noise, weights),
        &alternative.tau,
    );
    let k = instance.parameter_count();
    let n_eff = alternative.effective_samples().max(2.0);
    let weighted = |f: &Fit| f.rss.iter().zip(weights).map(|(r, w)| r * w).sum::<f64>();
    let explained = if weighted(current) > 0.0 { 1.0 - weighted(&alternative) / weighted(current) } else { 0.0 };
    let fitted_change = scalable_change(instance, own_beta, data, &model.params);
    let effect_to_noise = contribution(instance, own_beta, &current.channels)
        .iter()
        .zip(&observable_noise(kind, data, noise))
        .map(|(c, n)| if *n > 0.0 { c / n } else { 0.0 })
        .fold(0.0, f64::max);
    let score = Score {
        kind,
        not_applicable: None,
        likelihood_ratio: lr,
        parameters: k,
        p_value: chi_squared_sf(lr, k as f64),
        trials: instance.trials,
        bic_gain: lr - k as f64 * n_eff.ln(),
        rank: explained - k as f64 * n_eff.ln() / n_eff,
        significant: false,
        explained_fraction: explained,
        effect_to_noise,
        searched: instance.searched.iter().map(|s| (s.name.clone(), s.value)).collect(),
        searched_ranges: instance
            .searched
            .iter()
            .map(|s| (s.name.clone(), s.range.0, s.range.1, s.unit.clone()))
            .collect(),
        confirmation: None,
        fitted_change: Some(fitted_change),
        unobservable: false,
        detection_limit: None,
        weakest_direction_factor: weakest_direction_factor(
            kind,
            &alternative.covariance,
            accepted_columns.len(),
            own_beta,
        ),
    };
    (score, alternative)
}

/// The leading parameter's change that the candidate's fit gives, as the detection limit
/// scales it: the larger of the changes the fitted coefficients and their mirror image give.
///
/// A parameter with a physical bound (a backlash width cannot be negative) takes no change
/// when the noise pushes its fit past the bound, yet the test's statistic is of the fitted
/// coefficients, bound or not. The mirrored fit (the same coefficients of the other sign) has
/// the same statistic and moves the parameter into its admissible range, so its change is the
/// size the statistic belongs to. Only the bounded kinds are mirrored: a delay's change holds
/// its searched shift, which the mirror would not keep.
fn scalable_change(
    instance: &Instance,
    beta: &[f64],
    data: &EquationData,
    start: &ParameterSet,
) -> (&'static str, f64, &'static str) {
    let change = |coefficients: &[f64]| {
        let mut fitted = start.clone();
        candidates::apply(instance, coefficients, data, &mut fitted);
        candidates::size_change(instance.kind, start, &fitted)
    };
    let fitted = change(beta);
    if !candidates::has_bound(instance.kind) {
        return fitted;
    }
    let mirrored = change(&beta.iter().map(|b| -b).collect::<Vec<_>>());
    if mirrored.1.abs() > fitted.1.abs() {
        (fitted.0, -mirrored.1, fitted.2)
    } else {
        fitted
    }
}

/// For an effect whose size is the length of its own two-parameter vector (an unbalance: the
/// amplitude of its cos and sin parts, whatever its phase), how much larger it must be to be
/// found in the direction the log resolves worst than in the direction its fit took; 1 for
/// other effects.
///
/// The test's statistic for an effect `v` has the non-centrality `v' F v`, with `F` the
/// inverse of the covariance `C` of the effect's own parameters (the accepted effects
/// profiled out). At a given size that is `|v|^2 u' F u` along the fitted direction `u` and
/// `|v|^2 / lambda_max(C)` along the worst one, so the size needed grows by
/// `sqrt(lambda_max(C) u' F u)`. On a clean log the fitted direction is the noise's, so a
/// limit along it would hold for some phases and not others; over a short stroke an
/// unbalance's two parts are nearly a constant and a slope, and the phase matters.
fn weakest_direction_factor(kind: Kind, covariance: &nalgebra::DMatrix<f64>, offset: usize, own_beta: &[f64]) -> f64 {
    if kind != Kind::Unbalance || own_beta.len() != 2 || covariance.nrows() < offset + 2 {
        return 1.0;
    }
    let (a, b, d) =
        (covariance[(offset, offset)], covariance[(offset, offset + 1)], covariance[(offset + 1, offset + 1)]);
    let length = own_beta[0].hypot(own_beta[1]);
    let determinant = a * d - b * b;
    if !(length > 0.0 && determinant > 0.0) {
        return 1.0;
    }
    let (u0, u1) = (own_beta[0] / length, own_beta[1] / length);
    let along_fit = (d * u0 * u0 - 2.0 * b * u0 * u1 + a * u1 * u1) / determinant;
    let largest_variance = 0.5 * (a + d) + (0.25 * (a - d).powi(2) + b * b).sqrt();
    let factor = (largest_variance * along_fit).sqrt();
    if factor.is_finite() {
        factor.max(1.0)
    } else {
        1.0
    }
}

/// The judge's choice among the significant candidates, taken best first (equation-error
/// rank): each whose refined parameters are physically admissible is put to the judge; the
/// best-ranked confirmed one is chosen (with its refined parameters, fit and Gauss-Newton
/// iterations), unless the judge finds a lower-ranked confirmed one predicts significantly
/// better (the equation error sees the form of an effect sharply, the simulation its
/// consequence). Also returns the confirmed alternatives the chosen effect does not beat.
#[allow(clippy::too_many_arguments)]
#[allow(clippy::type_complexity)]
fn choose_confirmed(
    data: &EquationData,
    model: &Model,
    scores: &mut [Score],
    evaluated: &[(Instance, Fit)],
    weights: &[f64],
    noise: &[f64],
    options: &SelectionOptions,
    judge: &mut dyn Judge,
) -> (Option<(Kind, ParameterSet, Fit, usize)>, Vec<Kind>) {
    let (params, current, accepted) = (&model.params, &model.current, &model.accepted);
    let mut order: Vec<usize> = (0..scores.len()).filter(|&i| scores[i].significant).collect();
    order.sort_by(|&a, &b| scores[b].rank.total_cmp(&scores[a].rank));
    let mut chosen: Option<(usize, Kind, ParameterSet, Fit, usize)> = None;
    let mut confirmed: Vec<(usize, Kind, ParameterSet)> = Vec::new();
    for index in order {
        let kind = scores[index].kind;
        let Some((instance, alternative)) = evaluated.iter().find(|(i, _)| i.kind == kind) else { continue };
        // Starting point for Gauss-Newton: the accepted effects' increments and the new
        // effect's coefficients from the alternative fit.
        let (_, accepted_instances) = refine_columns(data, params, &current.channels, accepted, weights);
        let mut offset = baseline_columns(data, params).len();
        let mut next = params.clone();
        for previous in &accepted_instances {
            let k = previous.columns.len();
            candidates::apply(previous, &alternative.beta[offset..offset + k], data, &mut next);
            offset += k;
        }
        candidates::apply(instance, &alternative.beta[offset..offset + instance.columns.len()], data, &mut next);
        let mut trial = accepted.clone();
        trial.push(kind);
        let (refined, refined_fit, iterations) = refine(data, next, &trial, weights, options.max_iterations);
        // The refined effect must still be at least the noise: a search can pick a
        // direction that the joint refit then shrinks to nothing.
        let size = refined_effect_to_noise(data, kind, &refined, params, noise);
        let check = candidates::admissible(&refined, data).map_err(|e| e.to_string()).and_then(|()| {
            if size >= options.min_effect_to_noise {
                Ok(())
            } else {
                Err(format!("after refitting it is only {size:.2} times the noise"))
            }
        });
        match check {
            Ok(()) => match judge.confirm(kind, params, &refined) {
                Ok(note) => {
                    scores[index].confirmation = Some(note);
                    confirmed.push((index, kind, refined.clone()));
                    let replace = match &chosen {
                        None => true,
                        Some((_, _, incumbent, _, _)) => {
                            let extra = scores[index].parameters as isize
                                - chosen.as_ref().map_or(0, |c| scores[c.0].parameters as isize);
                            judge.prefers(incumbent, &refined, extra)
                        }
                    };
                    if replace {
                        chosen = Some((index, kind, refined, refined_fit, iterations));
                    }
                    if !judge.compares() {
                        break;
                    }
                }
                Err(reason) => {
                    scores[index].significant = false;
                    scores[index].not_applicable = Some(format!("significant but not confirmed: {reason}"));
                }
            },
            Err(reason) => {
                scores[index].significant = false;
                scores[index].not_applicable = Some(format!("significant but not admissible: {reason}"));
            }
        }
    }
    // The confirmed alternatives the chosen effect does not beat significantly.
    let equally_consistent: Vec<Kind> = match &chosen {
        Some((chosen_index, chosen_kind, chosen_params, _, _)) => confirmed
            .iter()
            .filter(|(_, kind, _)| kind != chosen_kind)
            .filter(|(index, _, other)| {
                let extra = scores[*chosen_index].parameters as isize - scores[*index].parameters as isize;
                !judge.prefers(other, chosen_params, extra)
            })
            .map(|(_, kind, _)| *kind)
            .collect(),
        None => Vec::new(),
    };
    (chosen.map(|(_, kind, refined, fit, iterations)| (kind, refined, fit, iterations)), equally_consistent)
}

/// Backward check: with several effects, each must still earn its place in the final model.
/// An effect found early can be a compensation for effects found later (a torque-constant
/// change standing in for Coulomb friction and an unbalance together); it is removed when the
/// model without it (the others refitted) passes the confirmation as well as with it, i.e. the
/// confirmation of the effect against that model fails. Returns the removed effects.
fn backward_check(
    data: &EquationData,
    start: &ParameterSet,
    model: &mut Model,
    options: &SelectionOptions,
    judge: &mut dyn Judge,
) -> Vec<(Kind, String)> {
    let all = model.accepted.clone();
    check_each(data, start, model, &all, options, judge).removed
}

/// What [`check_each`] decided: the effects removed, each with the judge's reason, and the
/// effects kept, each with the note of its last confirmation (against the final model less it).
struct Checked {
    removed: Vec<(Kind, String)>,
    kept: Vec<(Kind, String)>,
}

/// The backward check over the accepted effects in `removable` (the others always stay):
/// each in turn is taken out (its parameters back to `start`'s), the remaining accepted
/// effects refitted, and the judge asked to confirm it against that model; the first that
/// fails is removed, and the round is repeated on the smaller model until every one left
/// confirms. Nothing is checked while the model holds a single effect: against the start it
/// was confirmed when it was added.
fn check_each(
    data: &EquationData,
    start: &ParameterSet,
    model: &mut Model,
    removable: &[Kind],
    options: &SelectionOptions,
    judge: &mut dyn Judge,
) -> Checked {
    let mut removed = Vec::new();
    let mut notes: Vec<(Kind, String)> = Vec::new();
    while model.accepted.len() >= 2 {
        let mut dropped = None;
        for index in 0..model.accepted.len() {
            let kind = model.accepted[index];
            if !removable.contains(&kind) {
                continue;
            }
            let others: Vec<Kind> = model.accepted.iter().copied().filter(|k| *k != kind).collect();
            let weights = model.current.channel_weights();
            let (without, without_fit, _) =
                refine(data, without_effect(kind, &model.params, start), &others, &weights, options.max_iterations);
            if let Err(reason) = candidates::admissible(&without, data) {
                notes.retain(|(k, _)| *k != kind);
                notes.push((kind, format!("the model without it is not admissible ({reason})")));
                continue;
            }
            match judge.confirm(kind, &without, &model.params) {
                Ok(note) => {
                    notes.retain(|(k, _)| *k != kind);
                    notes.push((kind, note));
                }
                Err(reason) => {
                    dropped = Some((index, without, without_fit, reason));
                    break;
                }
            }
        }
        let Some((index, without, without_fit, reason)) = dropped else { break };
        let kind = model.accepted.remove(index);
        notes.retain(|(k, _)| *k != kind);
        removed.push((kind, reason));
        model.params = without;
        model.current = without_fit;
    }
    let kept = removable
        .iter()
        .filter(|k| model.accepted.contains(k))
        .map(|k| {
            let note = notes.iter().find(|(n, _)| n == k).map(|(_, note)| note.clone());
            (*k, note.unwrap_or_else(|| "the only effect left: confirmed against the start when it was added".into()))
        })
        .collect();
    Checked { removed, kept }
}

/// The outcome of [`recheck`]: the effects re-checked and kept (with the note of their
/// confirmation against the final model less each) and the ones withdrawn (with the reason).
#[derive(Debug, Clone, Default)]
pub struct Rechecked {
    pub kept: Vec<(Kind, String)>,
    pub withdrawn: Vec<(Kind, String)>,
}

/// The backward check once more, on the effects in `earlier` only, in the model
/// `selection.corrected` (which holds them and whatever was added since, such as a family the
/// start held and the re-estimation changed): each is taken out in turn, the others refitted,
/// and the judge asked to confirm it against that model; what no longer confirms is withdrawn
/// (with a pair partner claimed only jointly with it) and the selection is refitted on the
/// equation error at the remaining effects. An effect confirmed against a model that still had
/// a wrong value of some family can have been standing in for that value.
pub fn recheck(
    data: &EquationData,
    start: &ParameterSet,
    selection: &mut Selection,
    earlier: &[Kind],
    options: &SelectionOptions,
    judge: &mut dyn Judge,
) -> Rechecked {
    let weights = selection.after.channel_weights();
    let accepted: Vec<Kind> = selection.found.iter().map(|f| f.kind).collect();
    let pairs: Vec<(Kind, Kind)> = selection
        .steps
        .iter()
        .filter(|s| !s.re_estimate)
        .filter_map(|s| Some((s.chosen?, s.paired?)))
        .filter(|(a, b)| accepted.contains(a) && accepted.contains(b))
        .collect();
    let mut model = Model {
        params: selection.corrected.clone(),
        current: fit_fixed(data, &selection.corrected, &weights),
        accepted,
        pairs,
    };
    let removable: Vec<Kind> = earlier.iter().copied().filter(|k| model.accepted.contains(k)).collect();
    let Checked { mut removed, kept } = check_each(data, start, &mut model, &removable, options, judge);
    if removed.is_empty() {
        return Rechecked { kept, withdrawn: removed };
    }
    removed.extend(drop_lone_pair_members(data, start, &mut model, options));
    let kept = kept.into_iter().filter(|(k, _)| model.accepted.contains(k)).collect();
    if model.accepted.is_empty() {
        model.params = start.clone();
    }
    let (after, found) = final_fit(data, start, &model.params, &model.accepted, &weights);
    selection.after = if model.accepted.is_empty() { selection.before.clone() } else { after };
    selection.found = found;
    selection.corrected = model.params;
    selection.removed.extend(removed.iter().cloned());
    Rechecked { kept, withdrawn: removed }
}

/// A pair's members were claimed only jointly: when the backward check removed one, the other
/// goes too (a Coulomb change and a viscous change that compensate each other pass jointly on
/// friction with dynamics, and either alone is what the single test rejected).
fn drop_lone_pair_members(
    data: &EquationData,
    start: &ParameterSet,
    model: &mut Model,
    options: &SelectionOptions,
) -> Vec<(Kind, String)> {
    let mut removed = Vec::new();
    for (a, b) in model.pairs.clone() {
        for (gone, partner) in [(a, b), (b, a)] {
            if model.accepted.contains(&gone) || !model.accepted.contains(&partner) {
                continue;
            }
            let others: Vec<Kind> = model.accepted.iter().copied().filter(|k| *k != partner).collect();
            let weights = model.current.channel_weights();
            let (without, without_fit, _) =
                refine(data, without_effect(partner, &model.params, start), &others, &weights, options.max_iterations);
            model.accepted.retain(|k| *k != partner);
            removed.push((
                partner,
                format!("claimed only jointly with {}, which the backward check removed", gone.name()),
            ));
            model.params = without;
            model.current = without_fit;
        }
    }
    removed
}

/// Swap re-test: an effect chosen early was judged against a model that still lacked the
/// effects found later (or held a compensation the backward check has since removed). Each
/// accepted effect is compared once more with every alternative that was significant and
/// confirmed at some step, in the final model: the alternative replaces it when the model
/// with it (the others refitted) predicts significantly better. An offset and an unbalance
/// over a short angle range are the typical case: nearly collinear in the equations, told
/// apart only by what they do to the simulated motion. Returns the swaps (from, to).
fn swap_retest(
    data: &EquationData,
    start: &ParameterSet,
    model: &mut Model,
    steps: &[Step],
    options: &SelectionOptions,
    judge: &mut dyn Judge,
) -> Vec<(Kind, Kind)> {
    let mut swapped = Vec::new();
    if !judge.compares() || model.accepted.is_empty() {
        return swapped;
    }
    let alternatives: Vec<Kind> = {
        let mut kinds: Vec<Kind> = steps
            .iter()
            .flat_map(|s| {
                s.scores
                    .iter()
                    .filter(|x| {
                        x.confirmation.is_some()
                            || x.not_applicable
                                .as_deref()
                                .is_some_and(|r| r.starts_with("significant but not confirmed"))
                    })
                    .map(|x| x.kind)
            })
            .collect();
        kinds.sort_by_key(|k| Kind::ALL.iter().position(|x| x == k));
        kinds.dedup();
        kinds
    };
    for index in 0..model.accepted.len() {
        let kind = model.accepted[index];
        let mut best: Option<(Kind, ParameterSet, Fit)> = None;
        for &alternative in &alternatives {
            if model.accepted.contains(&alternative) {
                continue;
            }
            let mut trial: Vec<Kind> = model.accepted.clone();
            trial[index] = alternative;
            let weights = model.current.channel_weights();
            let Ok(seeded) = fit_candidate(
                data,
                &without_effect(kind, &model.params, start),
                &trial[..index].iter().chain(&trial[index + 1..]).copied().collect::<Vec<_>>(),
                alternative,
                options,
            ) else {
                continue;
            };
            let (refined, refined_fit, _) = refine(data, seeded, &trial, &weights, options.max_iterations);
            if candidates::admissible(&refined, data).is_err() {
                continue;
            }
            let extra = candidates::parameter_count(alternative, data.structure) as isize
                - candidates::parameter_count(kind, data.structure) as isize;
            let incumbent = best.as_ref().map_or(&model.params, |b| &b.1);
            if judge.prefers(incumbent, &refined, extra) {
                best = Some((alternative, refined, refined_fit));
            }
        }
        if let Some((alternative, refined, refined_fit)) = best {
            swapped.push((kind, alternative));
            model.accepted[index] = alternative;
            model.params = refined;
            model.current = refined_fit;
        }
    }
    swapped
}

/// The joint test of two candidates, for a step at which no single one was significant and
/// confirmed: both fitted together on top of the accepted effects, each tested against the
/// residual of the joint alternative (so neither counts as noise in the other's test) at the
/// step's level divided by the number of pairs (Bonferroni), each at least the noise in size.
/// The passing pairs are tried best-ranked first (explained fraction less the BIC penalty of
/// both); a pair is taken when its refined parameters are admissible, the judge confirms the
/// pair against the model it extends (paying for both), and each effect against the model
/// with only the other.
#[allow(clippy::too_many_arguments)]
fn search_pair(
    data: &EquationData,
    params: &ParameterSet,
    current: &Fit,
    accepted: &[Kind],
    evaluated: &[(Instance, Fit)],
    weights: &[f64],
    noise: &[f64],
    threshold: f64,
    options: &SelectionOptions,
    judge: &mut dyn Judge,
) -> Option<(Kind, Kind, ParameterSet, Fit, usize)> {
    let channel_count = data.channels.len();
    let (accepted_columns, _) = refine_columns(data, params, &current.channels, accepted, weights);
    let count = evaluated.len() * evaluated.len().saturating_sub(1) / 2;
    if count == 0 {
        return None;
    }
    let level = threshold / count as f64;
    let weighted = |f: &Fit| f.rss.iter().zip(weights).map(|(r, w)| r * w).sum::<f64>();
    // Each pair is fitted and tested on its own, side by side; the passing ones are collected
    // in the order one pair after another gives, which the stable sort below keeps for ties.
    let pairs: Vec<(usize, usize)> =
        (0..evaluated.len()).flat_map(|i| (i + 1..evaluated.len()).map(move |j| (i, j))).collect();
    let mut passing: Vec<(f64, usize, usize)> = pairs
        .par_iter()
        .filter_map(|&(i, j)| {
            let (a, b) = (&evaluated[i].0, &evaluated[j].0);
            let mut columns = accepted_columns.clone();
            columns.extend(a.columns.iter().cloned());
            columns.extend(b.columns.iter().cloned());
            let adjust = add_adjust(&a.adjust, &b.adjust, channel_count);
            let joint = fit(&current.channels, &columns, &adjust, weights);
            let offset_a = accepted_columns.len();
            let offset_b = offset_a + a.columns.len();
            let beta_a = &joint.beta[offset_a..offset_b];
            let beta_b = &joint.beta[offset_b..];
            let mut ok = true;
            for (instance, beta, other) in [(a, beta_a, b), (b, beta_b, a)] {
                let mut others = accepted_columns.clone();
                others.extend(other.columns.iter().cloned());
                let effect = effect_vector(instance, beta, &current.channels);
                let chi2 = robust_chi2(
                    &current.channels,
                    &others,
                    &effect,
                    &joint.residual,
                    &joint.residual,
                    &test_weights(&joint, noise, weights),
                    &joint.tau,
                );
                let size = contribution(instance, beta, &current.channels)
                    .iter()
                    .zip(noise)
                    .map(|(c, n)| if *n > 0.0 { c / n } else { 0.0 })
                    .fold(0.0, f64::max);
                let p = chi_squared_sf(chi2, instance.parameter_count() as f64);
                if p.is_nan() || p >= level || size < options.min_effect_to_noise {
                    ok = false;
                }
            }
            if !ok {
                return None;
            }
            let k = (a.parameter_count() + b.parameter_count()) as f64;
            let n_eff = joint.effective_samples().max(2.0);
            let explained = if weighted(current) > 0.0 { 1.0 - weighted(&joint) / weighted(current) } else { 0.0 };
            Some((explained - k * n_eff.ln() / n_eff, i, j))
        })
        .collect();
    passing.sort_by(|x, y| y.0.total_cmp(&x.0));
    for (_, i, j) in passing {
        let (a, b) = (evaluated[i].0.kind, evaluated[j].0.kind);
        let mut trial = accepted.to_vec();
        let Ok(seeded) = fit_candidate(data, params, &trial, a, options) else { continue };
        trial.push(a);
        let Ok(seeded) = fit_candidate(data, &seeded, &trial, b, options) else { continue };
        trial.push(b);
        let (refined, refined_fit, iterations) = refine(data, seeded, &trial, weights, options.max_iterations);
        if candidates::admissible(&refined, data).is_err() {
            continue;
        }
        // The pair must first improve on the model it extends. Each member's own confirmation
        // below is against the joint refit less that member, where the accepted effects have
        // moved with the pair: three nearly collinear effects (a torque-constant change, the
        // Coulomb level and the inertia, each a share of the torque) slide along their common
        // direction, and each member then "confirms" against a model the pair itself made
        // worse than the one it started from.
        if judge.confirm_joint([a, b], params, &refined).is_err() {
            continue;
        }
        let only_b = without_effect(a, &refined, params);
        let only_a = without_effect(b, &refined, params);
        if judge.confirm(a, &only_b, &refined).is_ok() && judge.confirm(b, &only_a, &refined).is_ok() {
            return Some((a, b, refined, refined_fit, iterations));
        }
    }
    None
}

/// The equation-error fit of the model with the accepted effects at `params` (their
/// increments fitted but not applied) and the effects' reported parameters, with standard
/// deviations from the covariance of the increments.
pub fn final_fit(
    data: &EquationData,
    start: &ParameterSet,
    params: &ParameterSet,
    accepted: &[Kind],
    weights: &[f64],
) -> (Fit, Vec<Found>) {
    let channels = model_channels(data, params);
    let (columns, instances) = refine_columns(data, params, &channels, accepted, weights);
    let result = fit(&channels, &columns, &[], weights);
    let mut ranges = Vec::new();
    let mut offset = baseline_columns(data, params).len();
    for instance in &instances {
        ranges.push(offset..offset + instance.columns.len());
        offset += instance.columns.len();
    }
    let found = instances
        .iter()
        .zip(&ranges)
        .map(|(instance, own)| {
            let block = result.covariance.view((own.start, own.start), (own.len(), own.len())).into_owned();
            let correlations = instances
                .iter()
                .zip(&ranges)
                .filter(|(other, _)| other.kind != instance.kind)
                .map(|(other, theirs)| (other.kind, strongest_correlation(&result.covariance, own, theirs)))
                .collect();
            Found {
                kind: instance.kind,
                parameters: candidates::report(instance.kind, start, params, &block, data),
                correlations,
            }
        })
        .collect();
    (result, found)
}

/// The correlation of largest magnitude between a coefficient in `a` and one in `b`, from a
/// covariance matrix (0 where a variance is not positive).
fn strongest_correlation(
    covariance: &nalgebra::DMatrix<f64>,
    a: &std::ops::Range<usize>,
    b: &std::ops::Range<usize>,
) -> f64 {
    let mut strongest = 0.0_f64;
    for i in a.clone() {
        for j in b.clone() {
            let scale = (covariance[(i, i)] * covariance[(j, j)]).sqrt();
            if scale > 0.0 && scale.is_finite() {
                let r = (covariance[(i, j)] / scale).clamp(-1.0, 1.0);
                if r.abs() > strongest.abs() {
                    strongest = r;
                }
            }
        }
    }
    strongest
}

/// The equation-error residual of the model at `params` with only the baseline nuisance
/// columns fitted: how the equations see a parameter set fixed elsewhere (an output-error
/// refit), without moving its parameters.
pub fn fit_fixed(data: &EquationData, params: &ParameterSet, weights: &[f64]) -> Fit {
    let channels = model_channels(data, params);
    fit(&channels, &baseline_columns(data, params), &[], weights)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn empty_fit() -> Fit {
        Fit {
            channels: Vec::new(),
            columns: Vec::new(),
            beta: Vec::new(),
            covariance: nalgebra::DMatrix::zeros(0, 0),
            residual: Vec::new(),
            sigma: Vec::new(),
            tau: Vec::new(),
            rss: Vec::new(),
            used: Vec::new(),
        }
    }

    fn step(chosen: Kind, equally_consistent: Vec<Kind>) -> Step {
        Step {
            scores: Vec::new(),
            chosen: Some(chosen),
            paired: None,
            threshold: 1e-3,
            iterations: 1,
            equally_consistent,
            re_estimate: false,
        }
    }

    fn selection(removed: Vec<(Kind, String)>) -> Selection {
        Selection {
            before: empty_fit(),
            after: empty_fit(),
            // The search took viscous first (Coulomb confirmed as well, not beaten), then Coulomb
            // on top of it.
            steps: vec![step(Kind::Viscous, vec![Kind::Coulomb]), step(Kind::Coulomb, Vec::new())],
            found: Vec::new(),
            corrected: ParameterSet::new(),
            removed,
            alike_after_search: Vec::new(),
        }
    }

    #[test]
    fn a_two_equation_effect_is_judged_by_the_noise_left_once_it_is_in_the_model() {
        use rand::SeedableRng;
        use rand_distr::Distribution;
        // The motor equation carries a misfit correlated over about 30 samples (70 N m), the
        // load equation white noise (8 N m) and a load-inertia change of about 240 N m RMS; the
        // effect's motor-side part is what a joint fit makes of the misfit.
        let n = 20_000;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(13);
        let normal = rand_distr::Normal::new(0.0, 1.0).unwrap();
        let white: Vec<f64> = (0..n + 30).map(|_| normal.sample(&mut rng)).collect();
        let misfit: Vec<f64> = white.windows(30).take(n).map(|w| 70.0 * w.iter().sum::<f64>() / 30f64.sqrt()).collect();
        let acceleration: Vec<f64> =
            (0..n).map(|i| (i as f64 * 0.003).sin() + 0.5 * (i as f64 * 0.011).cos()).collect();
        let load: Vec<f64> = (0..n).map(|i| 300.0 * acceleration[i] + 8.0 * normal.sample(&mut rng)).collect();
        let channel = |measured: Vec<f64>| ChannelData {
            name: "equation",
            measured,
            predicted: vec![0.0; n],
            mask: vec![true; n],
        };
        let channels = vec![channel(misfit), channel(load)];
        let columns = vec![
            Column { label: "motor".into(), unit: "-".into(), channels: vec![acceleration.clone(), Vec::new()] },
            Column { label: "load".into(), unit: "-".into(), channels: vec![Vec::new(), acceleration.clone()] },
        ];
        let current = fit(&channels, &[], &[], &[1.0, 1.0]);
        let search_weights: Vec<f64> = current.sigma.iter().zip(&current.tau).map(|(s, t)| 1.0 / (s * s * t)).collect();
        let alternative = fit(&channels, &columns, &[], &search_weights);
        let effect: Vec<Vec<f64>> =
            (0..2).map(|c| acceleration.iter().map(|a| alternative.beta[c] * a).collect()).collect();
        let chi2 = |weights: &[f64]| {
            robust_chi2(
                &channels,
                &[],
                &effect,
                &alternative.residual,
                &alternative.residual,
                weights,
                &alternative.tau,
            )
        };
        let with_search_weights = chi2(&search_weights);
        let with_test_weights = chi2(&test_weights(&alternative, &[31.0, 4.0], &search_weights));
        // The load equation alone resolves the change at a chi-square in the tens of thousands;
        // weighted by the residual that holds it, the test sees the motor equation's misfit.
        assert!(with_test_weights > 1e4, "{with_test_weights}");
        assert!(with_test_weights > 100.0 * with_search_weights, "{with_test_weights} vs {with_search_weights}");
        // A channel the search leaves out stays out.
        assert_eq!(test_weights(&alternative, &[31.0, 4.0], &[search_weights[0], 0.0])[1], 0.0);
    }

    #[test]
    fn an_effect_that_outlives_a_removed_one_it_could_not_be_told_from_carries_its_name() {
        let kept_both = selection(Vec::new());
        assert_eq!(kept_both.equally_consistent(Kind::Coulomb), Vec::<Kind>::new());
        assert_eq!(kept_both.equally_consistent(Kind::Viscous), vec![Kind::Coulomb]);
        let viscous_removed = selection(vec![(Kind::Viscous, "the model without it predicts as well".into())]);
        assert_eq!(viscous_removed.equally_consistent(Kind::Coulomb), vec![Kind::Viscous]);
        // A removed effect that its step could tell apart lends no label.
        let inertia_removed = Selection {
            steps: vec![step(Kind::Inertia, vec![Kind::Offset]), step(Kind::Coulomb, Vec::new())],
            ..selection(vec![(Kind::Inertia, "compensation".into())])
        };
        assert_eq!(inertia_removed.equally_consistent(Kind::Coulomb), Vec::<Kind>::new());
        // A check after the search adds its reading once, to the effect it names.
        let mut checked = selection(Vec::new());
        checked.mark_equally_consistent(Kind::Coulomb, Kind::Stribeck, "a reason".into());
        checked.mark_equally_consistent(Kind::Coulomb, Kind::Stribeck, "again".into());
        assert_eq!(checked.equally_consistent(Kind::Coulomb), vec![Kind::Stribeck]);
        assert_eq!(checked.equally_consistent(Kind::Viscous), vec![Kind::Coulomb]);
        assert_eq!(checked.alike_after_search.len(), 1);
    }

    fn scored(chi2: f64, bic_gain: f64, effect_to_noise: f64, change: f64) -> Score {
        Score {
            likelihood_ratio: chi2,
            parameters: 1,
            bic_gain,
            effect_to_noise,
            not_applicable: None,
            unobservable: false,
            fitted_change: Some((crate::parameters::names::TORQUE_OFFSET, change, "N m")),
            ..Score::not_applicable(Kind::Offset, String::new())
        }
    }

    #[test]
    fn an_unbalance_limit_holds_in_the_direction_the_log_resolves_worst() {
        // Own parameters after two accepted ones: the sin part is resolved three times worse
        // (variance 9 against 1), correlated with nothing.
        let mut covariance = nalgebra::DMatrix::<f64>::identity(4, 4);
        covariance[(3, 3)] = 9.0;
        let factor = |beta: [f64; 2]| weakest_direction_factor(Kind::Unbalance, &covariance, 2, &beta);
        assert!((factor([2.0, 0.0]) - 3.0).abs() < 1e-12, "fitted along the best direction");
        assert!((factor([0.0, -2.0]) - 1.0).abs() < 1e-12, "fitted along the worst direction");
        let diagonal = factor([1.0, 1.0]);
        assert!(diagonal > 1.0 && diagonal < 3.0, "{diagonal}");
        // Effects of one direction, and a fit that gave nothing, are left as they are.
        assert_eq!(weakest_direction_factor(Kind::Offset, &covariance, 2, &[2.0, 0.0]), 1.0);
        assert_eq!(factor([0.0, 0.0]), 1.0);
        // The limit grows by the factor.
        let threshold = chi_squared_sf(9.0, 1.0);
        let along_fit = DetectionLimit::of(&scored(4.0, 2.0, 3.0, -10.0), threshold, 1.0).unwrap();
        let worst = DetectionLimit::of(
            &Score { weakest_direction_factor: 3.0, ..scored(4.0, 2.0, 3.0, -10.0) },
            threshold,
            1.0,
        )
        .unwrap();
        assert!((worst.size - 3.0 * along_fit.size).abs() < 1e-9 * along_fit.size, "{worst:?}");
    }

    #[test]
    fn a_detection_limit_scales_the_fitted_change_to_the_statistic_or_the_noise_the_step_needs() {
        // The step's level 2.7e-3 needs a chi-square of 9.0 at one parameter (z = 3). At one
        // parameter the statistic is the square of a normal of mean size/error, so it exceeds
        // 9 in nine logs of ten at a size of (3 + z_0.9) standard errors (the other tail is
        // 1e-13): a fitted change of 10 N m at chi-square 4 (standard error 5 N m) scales to
        // 5 (3 + z_0.9) N m.
        let z90 = antenna_dsp::distributions::standard_normal_quantile(DETECTION_POWER);
        let threshold = chi_squared_sf(9.0, 1.0);
        let limit = DetectionLimit::of(&scored(4.0, 2.0, 3.0, -10.0), threshold, 1.0).unwrap();
        assert!((limit.size - 5.0 * (3.0 + z90)).abs() < 1e-4, "{limit:?}");
        assert!((limit.effect_to_noise / limit.size - 3.0 / 10.0).abs() < 1e-9);
        assert_eq!(limit.set_by, LimitSetBy::Significance);
        // The same standard error from a fit that found twice as much: the same limit.
        let again = DetectionLimit::of(&scored(16.0, 14.0, 6.0, 20.0), threshold, 1.0).unwrap();
        assert!((again.size - limit.size).abs() < 1e-6, "{again:?}");
        // A BIC penalty above the quantile sets it instead (chi2 - gain = 16: four errors).
        let by_bic = DetectionLimit::of(&scored(4.0, -12.0, 3.0, 10.0), threshold, 1.0).unwrap();
        assert!((by_bic.size - 5.0 * (4.0 + z90)).abs() < 1e-4, "{by_bic:?}");
        // On a quiet log the noise floor sets it: 1.5 times the noise at 10 N m needs 6.67 N m
        // to reach the noise, and the estimate (standard error 10/sqrt(400) = 0.5 N m) reaches
        // it in nine logs of ten z_0.9 standard errors above that; more than the test needs.
        let floor = DetectionLimit::of(&scored(400.0, 390.0, 0.15, 10.0), threshold, 1.0).unwrap();
        assert_eq!(floor.set_by, LimitSetBy::NoiseFloor);
        assert!((floor.size - (10.0 / 0.15 + 0.5 * z90)).abs() < 1e-9, "{floor:?}");
        assert!((floor.effect_to_noise / floor.size - 0.15 / 10.0).abs() < 1e-12);
        // Nothing to scale, or a candidate that did not apply: no limit.
        assert_eq!(DetectionLimit::of(&scored(0.0, 0.0, 0.0, 0.0), threshold, 1.0), None);
        assert_eq!(DetectionLimit::of(&Score::not_applicable(Kind::Offset, "no".into()), threshold, 1.0), None);
    }

    #[test]
    fn the_strongest_correlation_between_two_effects_is_the_largest_in_magnitude_with_its_sign() {
        // Coefficients 0 (baseline), 1-2 (an effect with two parameters) and 3 (one with one):
        // parameter 2 goes against 3 (covariance -0.9 at unit variances), parameter 1 with it
        // (0.4 over the root of 4 times 1).
        let covariance = nalgebra::DMatrix::from_row_slice(
            4,
            4,
            &[
                1.0, 0.0, 0.0, 0.0, //
                0.0, 4.0, 0.0, 0.8, //
                0.0, 0.0, 1.0, -0.9, //
                0.0, 0.8, -0.9, 1.0,
            ],
        );
        let r = strongest_correlation(&covariance, &(1..3), &(3..4));
        assert!((r + 0.9).abs() < 1e-12, "{r}");
        assert!((strongest_correlation(&covariance, &(3..4), &(1..2)) - 0.4).abs() < 1e-12);
        // Uncorrelated with the baseline; a zero variance gives no correlation.
        assert_eq!(strongest_correlation(&covariance, &(0..1), &(1..4)), 0.0);
        let degenerate = nalgebra::DMatrix::from_row_slice(2, 2, &[0.0, 0.0, 0.0, 1.0]);
        assert_eq!(strongest_correlation(&degenerate, &(0..1), &(1..2)), 0.0);
    }
}
