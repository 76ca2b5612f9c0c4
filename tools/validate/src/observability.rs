//! What a log cannot tell apart: found effects whose contribution another candidate reproduces
//! over the log's range of motion, and found effects that are collinear with each other.
//!
//! A name depends on the parametrisation when the log's range does not separate two forms: an
//! unbalance over a few degrees of axis angle is a constant torque, an offset; a Stribeck hump
//! wider than every speed in the log is a Coulomb level. Naming one of them as found would say
//! more than the data does, and two of them together can cancel (an offset of +370 N and an
//! "unbalance" of 374.5 N on a linear axis whose real offset was -3.2 N). Both cases are
//! reported as "X or Y: the data cannot tell", with the law they agree on.

use crate::candidates::{parameter_count, Kind};
use crate::equation_error::{model_channels, EquationData, Structure};
use crate::parameters::{names, ParameterSet};
use crate::selection::{self, Selection, SelectionOptions};
use antenna_dsp::chi_squared_sf;
use rayon::prelude::*;

/// An alternative the log cannot tell from a found effect reproduces the effect's contribution
/// so closely that what it leaves is not significant: the weighted sum of squares of the
/// difference (the equations' noise per independent sample as the unit, so a chi-square) stays
/// below the search's own level for the alternative's parameters. This fraction (RMS) bounds it
/// as well: what leaves more than a tenth of an effect is a different law, however noisy the
/// log. (A fixed fraction alone does not work: over the suite's 19 deg of stroke an offset and an
/// unbalance at its extremum agree to 0.4 %, which at 10 times the noise is below the noise and
/// at 50 times is not.)
pub const REPRODUCTION_TOLERANCE: f64 = 0.1;

/// Gauss-Newton iterations of an alternative's fit.
pub const STAND_IN_ITERATIONS: usize = 3;

/// Whether `kind` can stand in for another effect over a log at all: a delay (a time shift of
/// the whole torque) and a cogging torque (periodic in the motor angle at a searched period)
/// have a structure no other effect shares, and their grid searches are the costly ones
/// (25 and several hundred trials), so they are not tried as alternatives.
fn can_stand_in(kind: Kind) -> bool {
    !matches!(kind, Kind::Delay | Kind::Cogging)
}

/// Two found effects whose contributions have a weighted cosine of at least this in magnitude
/// are collinear over the log: only their sum is determined.
pub const COLLINEAR_COSINE: f64 = 0.95;

/// A candidate that reproduces a found effect over this log.
#[derive(Debug, Clone)]
pub struct Indistinct {
    pub found: Kind,
    pub alternative: Kind,
    /// RMS of what the alternative leaves of the found effect's contribution, over the
    /// contribution's RMS (weighted over the equations).
    pub misfit: f64,
    /// What it leaves as a chi-square: the sum of squares over the equations' noise per
    /// independent sample (the residuals' variance times their correlation time).
    pub chi2: f64,
    /// The corrected model with the alternative in place of the found effect.
    pub parameters: ParameterSet,
}

/// Two found effects that are collinear over this log.
#[derive(Debug, Clone)]
pub struct Collinear {
    pub first: Kind,
    pub second: Kind,
    /// Weighted cosine of their contributions (-1: they cancel).
    pub cosine: f64,
}

/// What each found effect adds to every equation (model side with it less without it), with
/// the others kept, stacked over the channels and scaled by the channels' weights' roots.
fn contribution(
    data: &EquationData,
    kind: Kind,
    corrected: &ParameterSet,
    start: &ParameterSet,
    weights: &[f64],
) -> Vec<f64> {
    let without = selection::without_effect(kind, corrected, start);
    difference(data, corrected, &without, weights)
}

/// The weighted, stacked difference of two parameter sets' residuals over the used samples.
///
/// With two equations (motor and load) the difference is taken in their sum, the total-torque
/// equation, from which the twist and its free offset cancel: in the load equation alone that
/// free offset absorbs a constant torque, so an offset and an unbalance over 70 deg of stroke
/// "reproduced" each other there to 0.4 %.
fn difference(data: &EquationData, a: &ParameterSet, b: &ParameterSet, weights: &[f64]) -> Vec<f64> {
    let with = model_channels(data, a);
    let without = model_channels(data, b);
    if data.structure == Structure::TwoMass && with.len() == 2 {
        let residual_change = |c: usize, i: usize| {
            (without[c].measured[i] - without[c].predicted[i]) - (with[c].measured[i] - with[c].predicted[i])
        };
        // The load equation is written in units of the starting stiffness (K0 tw): back to the
        // torque on the load with the parameter set's own stiffness over it.
        let to_torque = |p: &ParameterSet| p.value(names::STIFFNESS) / data.twist_scale;
        let (scale_a, scale_b) = (to_torque(a), to_torque(b));
        // The torque equation's weight: the sum carries the torque sensor's noise.
        let scale = weights.first().copied().unwrap_or(1.0).max(0.0).sqrt();
        return (0..with[0].mask.len())
            .filter(|&i| with[0].mask[i] && with[1].mask[i])
            .map(|i| {
                let load = (without[1].measured[i] - without[1].predicted[i]) * scale_b
                    - (with[1].measured[i] - with[1].predicted[i]) * scale_a;
                scale * (residual_change(0, i) + load)
            })
            .collect();
    }
    let mut out = Vec::new();
    for (c, (x, y)) in with.iter().zip(&without).enumerate() {
        let scale = weights.get(c).copied().unwrap_or(1.0).max(0.0).sqrt();
        for i in 0..x.mask.len() {
            if x.mask[i] {
                out.push(scale * ((y.measured[i] - y.predicted[i]) - (x.measured[i] - x.predicted[i])));
            }
        }
    }
    out
}

fn norm(x: &[f64]) -> f64 {
    x.iter().map(|v| v * v).sum::<f64>().sqrt()
}

/// The candidates that reproduce each found effect over this log, best first.
pub fn indistinct(
    data: &EquationData,
    start: &ParameterSet,
    selection: &Selection,
    options: &SelectionOptions,
) -> Vec<Indistinct> {
    let weights = selection.after.channel_weights();
    let found: Vec<Kind> = selection.found.iter().map(|f| f.kind).collect();
    // A few Gauss-Newton iterations: an alternative that needs more to match the found effect
    // is no close stand-in (the check stays conservative), and the full refit of every
    // alternative would double a validation's time.
    let options =
        SelectionOptions { max_iterations: options.max_iterations.min(STAND_IN_ITERATIONS), ..options.clone() };
    let options = &options;
    let mut out = Vec::new();
    for &kind in &found {
        let effect = contribution(data, kind, &selection.corrected, start, &weights);
        let size = norm(&effect);
        if size <= 0.0 {
            continue;
        }
        let without = selection::without_effect(kind, &selection.corrected, start);
        let others: Vec<Kind> = found.iter().copied().filter(|k| *k != kind).collect();
        // The alternatives are fitted side by side and collected in the candidates' order, so
        // the stable sort below gives the same list whatever the number of threads.
        let alternatives: Vec<Kind> =
            options.candidates.iter().copied().filter(|c| !found.contains(c) && can_stand_in(*c)).collect();
        let mut alike: Vec<Indistinct> = alternatives
            .into_par_iter()
            .filter_map(|alternative| {
                let parameters = selection::fit_candidate(data, &without, &others, alternative, options).ok()?;
                let left = difference(data, &parameters, &selection.corrected, &weights);
                let misfit = norm(&left) / size;
                let chi2 = left.iter().map(|x| x * x).sum::<f64>();
                let dof = parameter_count(alternative, data.structure).max(1) as f64;
                let unresolved = chi_squared_sf(chi2, dof) > options.alpha;
                (misfit <= REPRODUCTION_TOLERANCE && unresolved).then_some(Indistinct {
                    found: kind,
                    alternative,
                    misfit,
                    chi2,
                    parameters,
                })
            })
            .collect();
        alike.sort_by(|a, b| a.misfit.total_cmp(&b.misfit));
        out.extend(alike);
    }
    out
}

/// The pairs of found effects that are collinear over this log.
pub fn collinear(data: &EquationData, start: &ParameterSet, selection: &Selection) -> Vec<Collinear> {
    let weights = selection.after.channel_weights();
    let found: Vec<Kind> = selection.found.iter().map(|f| f.kind).collect();
    let contributions: Vec<Vec<f64>> =
        found.iter().map(|k| contribution(data, *k, &selection.corrected, start, &weights)).collect();
    let mut out = Vec::new();
    for i in 0..found.len() {
        for j in i + 1..found.len() {
            let (a, b) = (&contributions[i], &contributions[j]);
            let denominator = norm(a) * norm(b);
            if denominator <= 0.0 {
                continue;
            }
            let cosine = a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>() / denominator;
            if cosine.abs() >= COLLINEAR_COSINE {
                out.push(Collinear { first: found[i], second: found[j], cosine });
            }
        }
    }
    out
}

impl Indistinct {
    /// The alternative's own parameters in `parameters`, as `name = value` pairs (the refit of
    /// the other effects moves them only slightly and is left out).
    pub fn changes(&self, corrected: &ParameterSet, start: &ParameterSet) -> String {
        let without = selection::without_effect(self.found, corrected, start);
        let reset = selection::without_effect(self.alternative, &self.parameters, &without);
        changes(&self.parameters, &reset)
    }
}

/// The parameters by which `parameters` differs from `reference`, as `name = value` pairs.
pub fn changes(parameters: &ParameterSet, reference: &ParameterSet) -> String {
    parameters
        .names()
        .filter(|name| reference.get(name) != parameters.get(name))
        .map(|name| format!("{name} = {:.4e}", parameters.value(name)))
        .collect::<Vec<_>>()
        .join(", ")
}

/// A found Stribeck change that is mostly a low-speed friction term even in the speed.
///
/// A Stribeck hump is odd in the speed: the breakaway friction opposes the motion in both
/// directions alike. A direction-dependent friction whose difference between the directions
/// fades at low speed (an asymmetric sliding level that vanishes at rest, as a friction law
/// continuous through zero speed has it) leaves, beside the offset that takes its sliding
/// part, a remainder even in the speed: the same torque in both directions over the slowest
/// speeds. Where a log's slow motion runs mostly in one direction (tracking), an odd hump fits
/// that remainder there, and the output error confirms it, since the model's friction law has
/// no even term. Fitted beside the even term (its width searched), the hump keeps its own
/// share: when the even term is significant and takes more of the found change than the hump
/// keeps, the change is reported as a stand-in for the even term, not claimed.
#[derive(Debug, Clone)]
pub struct EvenFriction {
    /// The hump's level change (N m, axis side) fitted alone and beside the even term.
    pub alone: f64,
    pub beside: f64,
    /// The even term's level (N m, axis side: its torque in both directions at rest) and
    /// width (rad/s) of exp(-(w/width)^2).
    pub even_level: f64,
    pub even_width: f64,
    /// The even term's chi-square gain beside the hump, and its probability were there no
    /// such term (one degree of freedom, times the width grid's trials).
    pub gain: f64,
    pub p: f64,
}

/// The weighted least-squares fit of `columns` and a constant (the twist offset's and the
/// offset's share in the torque equation) to `residual`: (chi-square, coefficients).
fn fit_with_constant(columns: &[&[f64]], residual: &[f64], weight: f64) -> (f64, Vec<f64>) {
    let constant = vec![1.0; residual.len()];
    let all: Vec<Vec<f64>> = columns.iter().map(|c| c.to_vec()).chain(std::iter::once(constant)).collect();
    let weights = vec![weight; residual.len()];
    let (beta, _) = antenna_dsp::weighted_least_squares(&all, residual, &weights);
    let chi2 = (0..residual.len())
        .map(|i| weight * (residual[i] - all.iter().zip(&beta).map(|(c, b)| c[i] * b).sum::<f64>()).powi(2))
        .sum();
    (chi2, beta)
}

/// The even low-speed term a found Stribeck change may stand in for ([`EvenFriction`]), on the
/// torque equation's residual without the change: `Some` when the even term is significant
/// beside the hump (at the search's level `alpha`) and more than half the hump's change goes
/// to it.
pub fn stribeck_or_even_friction(
    data: &EquationData,
    start: &ParameterSet,
    selection: &Selection,
    alpha: f64,
) -> Option<EvenFriction> {
    if !selection.found.iter().any(|f| f.kind == Kind::Stribeck) {
        return None;
    }
    let without = selection::without_effect(Kind::Stribeck, &selection.corrected, start);
    let channels = model_channels(data, &without);
    let channel = channels.get(data.torque_channel())?;
    let weight = selection.after.channel_weights().get(data.torque_channel()).copied()?;
    let used = |inner: Vec<f64>| {
        data.smooth(&inner).iter().zip(&channel.mask).filter(|(_, m)| **m).map(|(v, _)| *v).collect::<Vec<_>>()
    };
    let residual: Vec<f64> = (0..channel.mask.len())
        .filter(|&i| channel.mask[i])
        .map(|i| channel.measured[i] - channel.predicted[i])
        .collect();
    // The even term's widths are searched over the Stribeck velocities' grid.
    let grid = crate::candidates::stribeck_velocity_grid(data, &channel.mask)?;
    let gaussian = |v: f64, width: f64| (-(v / width).powi(2)).exp();
    let vs = selection.corrected.value(names::STRIBECK_VELOCITY).max(1e-12);
    let odd = used(
        data.motor_vel_inner.iter().map(|&v| gaussian(v, vs) * v.signum() * f64::from(u8::from(v != 0.0))).collect(),
    );
    let (alone_chi2, alone) = fit_with_constant(&[&odd], &residual, weight);
    let (chi2, width, beta) = grid
        .par_iter()
        .map(|&width| {
            let even = used(data.motor_vel_inner.iter().map(|&v| gaussian(v, width)).collect());
            let (chi2, beta) = fit_with_constant(&[&odd, &even], &residual, weight);
            (chi2, width, beta)
        })
        .collect::<Vec<_>>()
        .into_iter()
        .min_by(|a, b| a.0.total_cmp(&b.0))?;
    let gain = (alone_chi2 - chi2).max(0.0);
    let p = (chi_squared_sf(gain, 1.0) * grid.len() as f64).min(1.0);
    let (alone, beside) = (alone[0], beta[0]);
    let stand_in = p < alpha && (alone - beside).abs() > beside.abs();
    stand_in.then_some(EvenFriction { alone, beside, even_level: beta[1], even_width: width, gain, p })
}

impl EvenFriction {
    /// The report's note: the hump change is kept in the corrected set, since it predicts the
    /// log better, but not claimed.
    pub fn describe(&self, corrected: &ParameterSet, start: &ParameterSet) -> String {
        format!(
            "stribeck is not claimed: a friction term even in the speed (the same torque in both directions, {:.4e} N m at rest, width {:.3e} rad/s) is significant beside the Stribeck hump (chi-square gain {:.1}, p {:.2e}) and takes most of its change ({:.4e} N m alone, {:.4e} N m beside it). A direction-dependent friction whose difference between the directions fades at low speed leaves such a term beside the offset, and the model's friction law has none; the hump change (friction.static {:.4e} against the start's {:.4e} N m) is kept in the corrected set as a stand-in",
            self.even_level,
            self.even_width,
            self.gain,
            self.p,
            self.alone,
            self.beside,
            corrected.value(names::STATIC),
            start.value(names::STATIC)
        )
    }
}
