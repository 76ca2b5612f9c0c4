//! The library of candidate effects, each with its own signature in the residual.
//!
//! A candidate says how the residual would change if the effect were added to the model: a set
//! of regressor columns (one vector per residual channel) whose coefficients are the effect's
//! linear parameters, and, for effects that move a known term (a delay shifts the torque, a new
//! Stribeck curve replaces the old one), an adjustment of the residual itself. Nonlinear
//! parameters (Stribeck velocity, cogging period, delay) are found by a grid search on the
//! current residual; the grid size enters the significance test as a number of trials, so a
//! wide search is not a licence to find something in noise.
//!
//! Every column is the derivative of a channel's model side (or minus the derivative of its
//! measured side) with respect to the effect's parameter, at the current parameters: the fit
//! is a Gauss-Newton step, and the selection iterates it after adding an effect.
//!
//! Signatures, all axis-side, r = measured - model:
//! - Coulomb: sign(w_m) in the torque equation.
//! - viscous: w_m.
//! - Stribeck: exp(-(w/ws)^2) sign(w), ws searched; replaces the model's hump.
//! - offset / asymmetric friction: a constant torque on the load (load equation with two
//!   equations; a constant while moving in the total equation).
//! - backlash: -K/2 sign(twist) in the motor equation, +K/2 sign(twist) in the load equation.
//! - stiffness: twist and twist rate, with opposite signs in the two equations.
//! - inertia: motor and load accelerations (total acceleration with one encoder).
//! - unbalance: cos and -sin of the axis angle.
//! - delay: the measured torque shifted in time, delay searched.
//! - torque constant: the measured torque itself (a scale error scales everything).
//! - cogging: sin and cos of 2 pi q_m / P, period searched.

use super::equation_error::{backlash_sign, ChannelData, EquationData, Regressor, Structure};
use super::parameters::{names, ParameterSet};
use super::stats::SinCosSums;
use antenna_dsp::weighted_least_squares;
use rayon::prelude::*;

/// The longest delay the grid search looks at, in seconds: a few times a drive's current-loop
/// and sampling delays, and beyond what a velocity loop of a few hertz survives.
pub const DELAY_SEARCH_SECONDS: f64 = 0.05;

/// A named effect the model may lack.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Kind {
    Coulomb,
    Viscous,
    Stribeck,
    Offset,
    Backlash,
    Stiffness,
    Inertia,
    Unbalance,
    Delay,
    TorqueConstant,
    Cogging,
}

impl Kind {
    pub const ALL: [Kind; 11] = [
        Kind::Coulomb,
        Kind::Viscous,
        Kind::Stribeck,
        Kind::Offset,
        Kind::Backlash,
        Kind::Stiffness,
        Kind::Inertia,
        Kind::Unbalance,
        Kind::Delay,
        Kind::TorqueConstant,
        Kind::Cogging,
    ];

    /// Short name, as reports and the suite's truth files use it.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Coulomb => "coulomb",
            Kind::Viscous => "viscous",
            Kind::Stribeck => "stribeck",
            Kind::Offset => "offset",
            Kind::Backlash => "backlash",
            Kind::Stiffness => "stiffness",
            Kind::Inertia => "inertia",
            Kind::Unbalance => "unbalance",
            Kind::Delay => "delay",
            Kind::TorqueConstant => "torque_constant",
            Kind::Cogging => "cogging",
        }
    }

    pub fn description(self) -> &'static str {
        match self {
            Kind::Coulomb => "Coulomb friction level",
            Kind::Viscous => "viscous friction",
            Kind::Stribeck => "Stribeck / breakaway friction",
            Kind::Offset => "asymmetric friction or torque offset",
            Kind::Backlash => "backlash / lost motion at reversals",
            Kind::Stiffness => "drive-path stiffness (anti-resonance) and damping",
            Kind::Inertia => "inertia error",
            Kind::Unbalance => "gravity / unbalance torque",
            Kind::Delay => "time delay between logged and applied torque",
            Kind::TorqueConstant => "torque constant (current-to-torque scale) error",
            Kind::Cogging => "position-periodic (cogging) torque",
        }
    }

    pub fn from_name(name: &str) -> Option<Kind> {
        Kind::ALL.iter().copied().find(|k| k.name() == name)
    }
}

/// Number of parameters an effect adds, as the output error's information criterion counts
/// them (the searched ones included; an inertia change is two with two equations).
pub fn parameter_count(kind: Kind, structure: Structure) -> usize {
    match kind {
        Kind::Stribeck | Kind::Stiffness | Kind::Unbalance => 2,
        Kind::Cogging => 3,
        Kind::Inertia if structure == Structure::TwoMass => 2,
        _ => 1,
    }
}

/// One regressor: its values in each residual channel (empty: zero in that channel).
#[derive(Debug, Clone)]
pub struct Column {
    pub label: String,
    pub unit: String,
    pub channels: Vec<Vec<f64>>,
}

/// A nonlinear parameter found by search, with its profile-likelihood standard deviation.
#[derive(Debug, Clone)]
pub struct Searched {
    pub name: String,
    pub unit: String,
    pub value: f64,
    pub sigma: f64,
    /// The searched range, for the report.
    pub range: (f64, f64),
}

/// Search: a new effect, nonlinear parameters found by grid search on the current residual.
/// Refine: an accepted effect linearised at the current parameters (all parameters, including
/// the searched ones, as Gauss-Newton increments).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    Search,
    Refine,
}

/// A candidate made concrete on one data set.
#[derive(Debug, Clone)]
pub struct Instance {
    pub kind: Kind,
    pub mode: Mode,
    pub columns: Vec<Column>,
    /// Per-channel change of the residual target (empty: none).
    pub adjust: Vec<Vec<f64>>,
    pub searched: Vec<Searched>,
    /// Effective number of alternatives the search tried (1 without a search).
    pub trials: f64,
    /// Parameters found by search that have no column (Search mode).
    pub extra_parameters: usize,
}

impl Instance {
    /// Number of parameters the effect adds.
    pub fn parameter_count(&self) -> usize {
        self.columns.len() + self.extra_parameters
    }
}

/// Rows used by the fit: every masked sample of every channel, in channel order.
pub fn stack(channels: &[ChannelData], per_channel: &[Vec<f64>]) -> Vec<f64> {
    let mut out = Vec::new();
    for (c, channel) in channels.iter().enumerate() {
        let values = per_channel.get(c).filter(|v| !v.is_empty());
        for (i, &used) in channel.mask.iter().enumerate() {
            if used {
                out.push(values.map(|v| v[i]).unwrap_or(0.0));
            }
        }
    }
    out
}

/// Per-row weights from per-channel weights.
pub fn stacked_weights(channels: &[ChannelData], channel_weights: &[f64]) -> Vec<f64> {
    let mut out = Vec::new();
    for (c, channel) in channels.iter().enumerate() {
        out.extend(channel.mask.iter().filter(|m| **m).map(|_| channel_weights[c]));
    }
    out
}

/// Weighted RSS of `target` after fitting `columns` (already stacked).
fn fitted_rss(columns: &[Vec<f64>], target: &[f64], weights: &[f64]) -> f64 {
    let (beta, _) = weighted_least_squares(columns, target, weights);
    target
        .iter()
        .enumerate()
        .map(|(i, y)| {
            let fit: f64 = columns.iter().zip(&beta).map(|(c, b)| c[i] * b).sum();
            weights[i] * (y - fit).powi(2)
        })
        .sum()
}

fn sign(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// Profile standard deviation of a searched parameter: the half-width of the region where the
/// chi-squared (weighted RSS) stays within 1 of its minimum, interpolated between grid points
/// and never narrower than half a grid step.
fn profile_sigma(grid: &[f64], chi2: &[f64], best: usize) -> f64 {
    let min = chi2[best];
    let cross = |step: isize| -> f64 {
        let mut i = best as isize;
        loop {
            let j = i + step;
            if j < 0 || j >= grid.len() as isize {
                return (grid[i as usize] - grid[best]).abs();
            }
            let (a, b) = (chi2[i as usize] - min, chi2[j as usize] - min);
            if b >= 1.0 {
                let f = if b > a { (1.0 - a) / (b - a) } else { 1.0 };
                return (grid[i as usize] + f * (grid[j as usize] - grid[i as usize]) - grid[best]).abs();
            }
            i = j;
        }
    };
    let half_step = if grid.len() > 1 {
        0.5 * (grid[1] - grid[0]).abs().min((grid[grid.len() - 1] - grid[grid.len() - 2]).abs())
    } else {
        0.0
    };
    (0.5 * (cross(-1) + cross(1))).max(half_step)
}

/// Builds a candidate on the data at the current parameters. In Search mode the nonlinear
/// parameters are searched against the current residual (`residual` per channel,
/// `channel_weights` = 1/(sigma^2 tau) per channel). Returns an error string when the
/// candidate does not apply to this data.
pub fn instantiate(
    kind: Kind,
    data: &EquationData,
    params: &ParameterSet,
    channels: &[ChannelData],
    residual: &[Vec<f64>],
    channel_weights: &[f64],
    mode: Mode,
) -> Result<Instance, NotApplicable> {
    let two_mass = data.structure == Structure::TwoMass;
    let stiffness = params.value(names::STIFFNESS);
    let cx = Setup {
        kind,
        mode,
        data,
        params,
        channels,
        n: data.len(),
        weights: stacked_weights(channels, channel_weights),
        target: stack(channels, residual),
        two_mass,
        stiffness,
        ratio: if two_mass { data.twist_scale / stiffness } else { 1.0 },
    };
    let (n, ratio) = (cx.n, cx.ratio);
    let torque_only = |values: Vec<f64>| cx.torque_only(values);
    let simple = |columns: Vec<Column>| cx.simple(columns);

    match kind {
        Kind::Coulomb => {
            let sgn = data.smooth(&data.motor_vel_inner.iter().map(|&v| sign(v)).collect::<Vec<_>>());
            Ok(simple(vec![column("friction.coulomb change", "N m", torque_only(sgn))]))
        }
        Kind::Viscous => {
            Ok(simple(vec![column("friction.viscous change", "N m s/rad", torque_only(data.motor_vel.clone()))]))
        }
        // The offset acts on the load (the plant FMU's load.torque_offset): in the load equation
        // with two equations, in the total equation otherwise.
        Kind::Offset => match data.structure {
            Structure::TwoMass => {
                Ok(simple(vec![column("effect.torque_offset change", "N m", vec![Vec::new(), vec![ratio; n]])]))
            }
            _ => Ok(simple(vec![column("effect.torque_offset change", "N m", torque_only(vec![1.0; n]))])),
        },
        Kind::TorqueConstant => {
            // The model side is divided by the scale s: a relative change d of s changes it by
            // -d times itself.
            let predicted = &channels[data.torque_channel()].predicted;
            Ok(simple(vec![column(
                "relative torque-constant change",
                "-",
                torque_only(predicted.iter().map(|p| -p).collect()),
            )]))
        }
        Kind::Inertia => match data.structure {
            Structure::TwoMass => Ok(simple(vec![
                column("motor inertia change (axis side)", "kg m^2", vec![data.motor_acc.clone(), Vec::new()]),
                column(
                    "load.inertia change",
                    "kg m^2",
                    vec![Vec::new(), data.load_acc.iter().map(|a| ratio * a).collect()],
                ),
            ])),
            // In one total equation the motor and load accelerations differ only by the twist
            // acceleration, so the two inertias are not separable: the load inertia is fitted
            // and the data-sheet motor inertia kept.
            Structure::TotalTwoEncoders => {
                Ok(simple(vec![column("load.inertia change", "kg m^2", vec![data.load_acc.clone()])]))
            }
            Structure::Rigid => Ok(simple(vec![column("load.inertia change", "kg m^2", vec![data.load_acc.clone()])])),
        },
        Kind::Unbalance => {
            let cos: Vec<f64> = data.angle.iter().map(|a| ratio * a.cos()).collect();
            let minus_sin: Vec<f64> = data.angle.iter().map(|a| -ratio * a.sin()).collect();
            let (c, s) = if two_mass {
                (vec![Vec::new(), cos], vec![Vec::new(), minus_sin])
            } else {
                (vec![cos], vec![minus_sin])
            };
            // Over a small range of angle the two columns are nearly collinear with a
            // constant; the fit reports that through a large uncertainty.
            Ok(simple(vec![
                column("unbalance cos part (A cos phase)", "N m", c),
                column("unbalance sin part (A sin phase)", "N m", s),
            ]))
        }
        Kind::Stiffness => stiffness_instance(&cx),
        Kind::Backlash => {
            if !two_mass {
                return Err(NotApplicable::NeedsTwoEncodersAndStiffness);
            }
            let signs = backlash_sign(data, params);
            let motor: Vec<f64> = signs.iter().map(|s| -0.5 * stiffness * s).collect();
            let load: Vec<f64> = signs.iter().map(|s| 0.5 * data.twist_scale * s).collect();
            Ok(simple(vec![column("backlash.width change", "rad", vec![motor, load])]))
        }
        Kind::Stribeck => stribeck_instance(&cx),
        Kind::Delay => delay_instance(&cx),
        Kind::Cogging => cogging_instance(&cx),
    }
}

/// What every candidate's columns are built from: the data, the parameters they are
/// linearised at, the residual target and its weights.
struct Setup<'a> {
    kind: Kind,
    mode: Mode,
    data: &'a EquationData,
    params: &'a ParameterSet,
    channels: &'a [ChannelData],
    n: usize,
    weights: Vec<f64>,
    target: Vec<f64>,
    two_mass: bool,
    stiffness: f64,
    /// The load equation's unit: the starting stiffness over the current one (1 without it).
    ratio: f64,
}

impl Setup<'_> {
    /// Values in the torque equation only.
    fn torque_only(&self, values: Vec<f64>) -> Vec<Vec<f64>> {
        let mut v = vec![Vec::new(); self.channels.len()];
        v[self.data.torque_channel()] = values;
        v
    }

    /// An instance with columns only (no search, no target change).
    fn simple(&self, columns: Vec<Column>) -> Instance {
        Instance {
            kind: self.kind,
            mode: self.mode,
            columns,
            adjust: Vec::new(),
            searched: Vec::new(),
            trials: 1.0,
            extra_parameters: 0,
        }
    }
}

fn column(label: &str, unit: &str, channels: Vec<Vec<f64>>) -> Column {
    Column { label: label.into(), unit: unit.into(), channels }
}

/// Stiffness and damping: their columns in both equations.
fn stiffness_instance(cx: &Setup) -> Result<Instance, NotApplicable> {
    let (data, params, n, stiffness, ratio) = (cx.data, cx.params, cx.n, cx.stiffness, cx.ratio);
    if !cx.two_mass {
        return Err(NotApplicable::NeedsTwoEncodersAndStiffness);
    }
    let load_inertia = params.value(names::LOAD_INERTIA);
    let damping = params.value(names::DAMPING);
    let backlash = params.value(names::BACKLASH_WIDTH);
    let amplitude = params.value(names::UNBALANCE_TORQUE);
    let phase = params.value(names::UNBALANCE_PHASE);
    let offset = params.value(names::TORQUE_OFFSET);
    let signs = if backlash > 0.0 { backlash_sign(data, params) } else { vec![0.0; n] };
    let disturbance = data.disturbance.clone().unwrap_or_else(|| vec![0.0; n]);
    let motor_k: Vec<f64> = (0..n).map(|i| data.twist[i] - 0.5 * backlash * signs[i]).collect();
    let load_k: Vec<f64> = (0..n)
        .map(|i| {
            let load_side =
                load_inertia * data.load_acc[i] + amplitude * (data.angle[i] + phase).cos() + offset - disturbance[i];
            -data.twist_scale / (stiffness * stiffness) * (load_side - damping * data.twist_rate[i])
        })
        .collect();
    let load_d: Vec<f64> = data.twist_rate.iter().map(|v| -ratio * v).collect();
    Ok(cx.simple(vec![
        column("path.stiffness change", "N m/rad", vec![motor_k, load_k]),
        column("path.damping change", "N m s/rad", vec![data.twist_rate.clone(), load_d]),
    ]))
}

/// The Stribeck hump: its level as a column, its velocity by grid search (Search) or as a
/// Gauss-Newton column (Refine).
fn stribeck_instance(cx: &Setup) -> Result<Instance, NotApplicable> {
    let (kind, mode, data, params, channels) = (cx.kind, cx.mode, cx.data, cx.params, cx.channels);
    let (weights, target) = (&cx.weights, &cx.target);
    let torque_only = |values: Vec<f64>| cx.torque_only(values);
    let simple = |columns: Vec<Column>| cx.simple(columns);
    let fc = params.value(names::COULOMB);
    // The Stribeck curve is the breakaway level's rise over the sliding (Coulomb) level. A hump
    // over no sliding level is a friction that vanishes at speed, which no lubricated contact
    // has: from a start without Coulomb friction a hump would stand in for it.
    if mode == Mode::Search && fc <= 0.0 {
        return Err(NotApplicable::StribeckWithoutCoulomb);
    }
    let amplitude = params.get(names::STATIC).unwrap_or(fc) - fc;
    let current_vs = params.value(names::STRIBECK_VELOCITY).max(1e-12);
    // The hump depends on the data and the velocity only: each is smoothed once per log.
    let hump = |vs: f64| {
        let inner = || data.motor_vel_inner.iter().map(|&v| (-(v / vs).powi(2)).exp() * sign(v)).collect::<Vec<_>>();
        data.smoothed_regressor(Regressor::StribeckHump, vs, inner).to_vec()
    };
    if mode == Mode::Refine {
        let slope = data.smooth(
            &data
                .motor_vel_inner
                .iter()
                .map(|&v| amplitude * 2.0 * v * v / current_vs.powi(3) * (-(v / current_vs).powi(2)).exp() * sign(v))
                .collect::<Vec<_>>(),
        );
        let mut instance = simple(vec![
            column("Stribeck hump change", "N m", torque_only(hump(current_vs))),
            column("friction.stribeck_velocity change", "rad/s", torque_only(slope)),
        ]);
        instance.searched = vec![Searched {
            name: names::STRIBECK_VELOCITY.into(),
            unit: "rad/s".into(),
            value: current_vs,
            sigma: f64::NAN,
            range: (current_vs, current_vs),
        }];
        return Ok(instance);
    }
    // The new hump replaces the model's: its old contribution goes back into the target.
    let adjust_torque: Vec<f64> = hump(current_vs).iter().map(|h| amplitude * h).collect();
    let grid = stribeck_velocity_grid(data, &channels[0].mask).ok_or(NotApplicable::TooFewMovingSamples)?;
    let adjust_stacked = stack(channels, &torque_only(adjust_torque.clone()));
    let adjusted_target: Vec<f64> = target.iter().zip(&adjust_stacked).map(|(r, a)| r + a).collect();
    // The grid's points are independent and run side by side, collected in grid order.
    let chi2: Vec<f64> = grid
        .par_iter()
        .map(|&vs| fitted_rss(&[stack(channels, &torque_only(hump(vs)))], &adjusted_target, weights))
        .collect();
    let best = (0..grid.len()).min_by(|&a, &b| chi2[a].total_cmp(&chi2[b])).unwrap_or(0);
    let sigma = profile_sigma(&grid, &chi2, best);
    Ok(Instance {
        kind,
        mode,
        columns: vec![column(
            "Stribeck hump (friction.static - friction.coulomb)",
            "N m",
            torque_only(hump(grid[best])),
        )],
        adjust: torque_only(adjust_torque),
        searched: vec![Searched {
            name: names::STRIBECK_VELOCITY.into(),
            unit: "rad/s".into(),
            value: grid[best],
            sigma,
            range: (grid[0], grid[grid.len() - 1]),
        }],
        // Neighbouring Stribeck velocities a factor 1.3 apart give nearly the same
        // column; about a third of the grid is independent.
        trials: (grid.len() as f64 / 3.0).max(1.0),
        extra_parameters: 1,
    })
}

/// The delay of the applied torque: by grid search in tenths of a sample (Search), or as the
/// torque-rate column (Refine).
fn delay_instance(cx: &Setup) -> Result<Instance, NotApplicable> {
    let (kind, mode, data, channels) = (cx.kind, cx.mode, cx.data, cx.channels);
    let (weights, target) = (&cx.weights, &cx.target);
    let delay = cx.params.value(names::DELAY);
    let torque_only = |values: Vec<f64>| cx.torque_only(values);
    let simple = |columns: Vec<Column>| cx.simple(columns);
    // y(t) = T(t - d): a larger delay changes the measured side by -T'(t - d) per
    // second, so the residual column (minus the derivative of the measured side) is
    // +T'(t - d).
    let rate_column = |d: f64| torque_only(data.torque_rate_delayed(d));
    if mode == Mode::Refine {
        let mut instance = simple(vec![column("effect.delay change", "s", rate_column(delay))]);
        instance.searched = vec![Searched {
            name: names::DELAY.into(),
            unit: "s".into(),
            value: delay,
            sigma: f64::NAN,
            range: (delay, delay),
        }];
        return Ok(instance);
    }
    // The search covers DELAY_SEARCH_SECONDS whatever the log rate, in tenths of a
    // sample; the trials below make a longer search (more samples) stricter.
    let max_steps = ((DELAY_SEARCH_SECONDS / data.dt).round() as usize).max(2);
    let grid: Vec<f64> = (0..=max_steps * 10).map(|k| k as f64 * 0.1 * data.dt).collect();
    let base = if delay != 0.0 { data.torque_delayed(delay) } else { data.torque.clone() };
    let adjust_for =
        |d: f64| -> Vec<f64> { data.torque_delayed(delay + d).iter().zip(&base).map(|(s, b)| s - b).collect() };
    // The grid's points are independent: they run side by side, each summing its rows in the
    // stacked order (the torque channel's adjustment, zero elsewhere) into a buffer of its own.
    let torque_channel = data.torque_channel();
    let base = &base;
    let chi2: Vec<f64> = grid
        .par_iter()
        .map_init(Vec::new, |shifted, &d| {
            data.torque_delayed_into(delay + d, shifted);
            let adjust = channels.iter().enumerate().flat_map(|(c, channel)| {
                let values = (c == torque_channel).then_some(&*shifted);
                channel.mask.iter().enumerate().filter(|(_, used)| **used).map(move |(i, _)| match values {
                    Some(v) => v[i] - base[i],
                    None => 0.0,
                })
            });
            target.iter().zip(adjust).zip(weights).map(|((r, a), w)| w * (r + a).powi(2)).sum()
        })
        .collect();
    let best = (0..grid.len()).min_by(|&a, &b| chi2[a].total_cmp(&chi2[b])).unwrap_or(0);
    let sigma = profile_sigma(&grid, &chi2, best);
    Ok(Instance {
        kind,
        mode,
        // A derivative column refines the grid value between grid points.
        columns: vec![column("effect.delay refinement", "s", rate_column(delay + grid[best]))],
        adjust: torque_only(adjust_for(grid[best])),
        searched: vec![Searched {
            name: names::DELAY.into(),
            unit: "s".into(),
            value: grid[best],
            sigma,
            range: (0.0, grid[grid.len() - 1]),
        }],
        // One independent trial per whole sample of delay searched.
        trials: max_steps as f64,
        extra_parameters: 0,
    })
}

/// Points of the Stribeck velocity's search grid.
pub const STRIBECK_GRID: usize = 25;

/// The Stribeck velocities searched: [`STRIBECK_GRID`] points spaced evenly in logarithm from
/// the stick speed (or the slowest hundredth of the moving samples in `mask`) to the speed
/// below which nine tenths of them move. `None` with fewer than ten moving samples.
pub fn stribeck_velocity_grid(data: &EquationData, mask: &[bool]) -> Option<Vec<f64>> {
    let mut speeds: Vec<f64> = data.motor_vel.iter().zip(mask).filter(|(_, m)| **m).map(|(v, _)| v.abs()).collect();
    if speeds.len() < 10 {
        return None;
    }
    speeds.sort_by(|a, b| a.total_cmp(b));
    let low = data.stick_speed.max(speeds[speeds.len() / 100]).max(1e-9);
    let high = speeds[speeds.len() * 9 / 10].max(low * 2.0);
    let last = (STRIBECK_GRID - 1) as f64;
    Some((0..STRIBECK_GRID).map(|k| low * (high / low).powf(k as f64 / last)).collect())
}

/// The position-periodic (cogging) torque: its period by search ([`cogging`]), or its sin, cos
/// and period columns at the current parameters (Refine).
fn cogging_instance(cx: &Setup) -> Result<Instance, NotApplicable> {
    let (kind, mode, data, params, channels, n) = (cx.kind, cx.mode, cx.data, cx.params, cx.channels, cx.n);
    let weights = &cx.weights;
    let target = &cx.target;
    let torque_only = |values: Vec<f64>| cx.torque_only(values);
    let simple = |columns: Vec<Column>| cx.simple(columns);
    let amplitude = params.value(names::COGGING_AMPLITUDE);
    let period = params.value(names::COGGING_PERIOD);
    let phase = params.value(names::COGGING_PHASE);
    let two_pi = 2.0 * std::f64::consts::PI;
    if mode == Mode::Refine {
        if period <= 0.0 {
            return Err(NotApplicable::NoCoggingPeriod);
        }
        let (a0, b0) = (amplitude * phase.cos(), amplitude * phase.sin());
        let sin = data.smooth(&data.motor_pos_inner.iter().map(|q| (two_pi * q / period).sin()).collect::<Vec<_>>());
        let cos = data.smooth(&data.motor_pos_inner.iter().map(|q| (two_pi * q / period).cos()).collect::<Vec<_>>());
        let slope = data.smooth(
            &data
                .motor_pos_inner
                .iter()
                .map(|q| {
                    let x = two_pi * q / period;
                    two_pi * q / (period * period) * (-a0 * x.cos() + b0 * x.sin())
                })
                .collect::<Vec<_>>(),
        );
        let mut instance = simple(vec![
            column("cogging sin part change", "N m", torque_only(sin)),
            column("cogging cos part change", "N m", torque_only(cos)),
            column("effect.cogging_period change", "rad", torque_only(slope)),
        ]);
        instance.searched = vec![Searched {
            name: names::COGGING_PERIOD.into(),
            unit: "rad".into(),
            value: period,
            sigma: f64::NAN,
            range: (period, period),
        }];
        return Ok(instance);
    }
    // Any cogging already in the model goes back into the target: the search fits the
    // whole position-periodic torque afresh.
    let existing: Vec<f64> = if amplitude != 0.0 && period > 0.0 {
        data.smooth(
            &data.motor_pos_inner.iter().map(|q| amplitude * (two_pi * q / period + phase).sin()).collect::<Vec<_>>(),
        )
    } else {
        vec![0.0; n]
    };
    let adjust = torque_only(existing);
    let adjust_stacked = stack(channels, &adjust);
    let adjusted: Vec<f64> = target.iter().zip(&adjust_stacked).map(|(r, a)| r + a).collect();
    let mut instance = cogging(data, channels, &adjusted, weights, &torque_only, kind)?;
    instance.adjust = adjust;
    Ok(instance)
}

/// Cogging: a periodogram over the motor angle, fitted by sine and cosine at each period.
///
/// The period grid is uniform in spatial frequency with a step of 1/8 cycle over the angle
/// range, so a true period is never more than 1/16 cycle of phase drift from a grid point.
/// Periods run from a third of the angle range down to the shortest the filter passes at the
/// median speed, and never more than 5000 grid points (a documented search limit); below
/// that, the periods of m cycles per motor revolution ([`motor_cycle_periods`]).
fn cogging(
    data: &EquationData,
    channels: &[ChannelData],
    target: &[f64],
    weights: &[f64],
    torque_only: &dyn Fn(Vec<f64>) -> Vec<Vec<f64>>,
    kind: Kind,
) -> Result<Instance, NotApplicable> {
    let mask = &channels[data.torque_channel()].mask;
    let angles: Vec<f64> = data.motor_pos.iter().zip(mask).filter(|(_, m)| **m).map(|(q, _)| *q).collect();
    let torque_rows = angles.len();
    if torque_rows < 20 {
        return Err(NotApplicable::TooFewMovingSamples);
    }
    let (lo, hi) = angles.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), q| (a.min(*q), b.max(*q)));
    let range = hi - lo;
    let mut speeds: Vec<f64> = data.motor_vel.iter().zip(mask).filter(|(_, m)| **m).map(|(v, _)| v.abs()).collect();
    speeds.sort_by(|a, b| a.total_cmp(b));
    let median_speed = speeds[speeds.len() / 2];
    let step = 1.0 / (8.0 * range);
    let f_low = 3.0 / range;
    let mut f_high = (0.5 * data.cutoff_hz / median_speed.max(1e-12)).max(2.0 * f_low);
    f_high = f_high.min(f_low + 5000.0 * step);
    let count = ((f_high - f_low) / step).floor() as usize + 1;
    if count < 2 {
        return Err(NotApplicable::AngleRangeTooSmall);
    }
    // Only the torque channel's rows matter: the other channels get zero columns.
    let r = &target[..torque_rows];
    let w = &weights[..torque_rows];
    let two_pi = 2.0 * std::f64::consts::PI;
    let mut phase: Vec<(f64, f64)> =
        angles.iter().map(|q| ((two_pi * q * f_low).cos(), (two_pi * q * f_low).sin())).collect();
    let rotation: Vec<(f64, f64)> =
        angles.iter().map(|q| ((two_pi * q * step).cos(), (two_pi * q * step).sin())).collect();
    let total: f64 = r.iter().zip(w).map(|(r, w)| w * r * r).sum();
    let mut chi2 = Vec::with_capacity(count);
    for _ in 0..count {
        let mut sums = SinCosSums::default();
        for i in 0..torque_rows {
            let (c, s) = phase[i];
            sums.add(w[i], r[i], c, s);
            let (rcos, rsin) = rotation[i];
            phase[i] = (c * rcos - s * rsin, s * rcos + c * rsin);
        }
        chi2.push(total - sums.explained());
    }
    let best = (0..count).min_by(|&a, &b| chi2[a].total_cmp(&chi2[b])).unwrap_or(0);
    // Refine the best frequency by a parabola through its neighbours.
    let mut frequency = f_low + best as f64 * step;
    if best > 0 && best + 1 < count {
        let (a, b, c) = (chi2[best - 1], chi2[best], chi2[best + 1]);
        let denominator = a - 2.0 * b + c;
        if denominator > 0.0 {
            frequency += 0.5 * (a - c) / denominator * step;
        }
    }
    let frequencies: Vec<f64> = (0..count).map(|k| f_low + k as f64 * step).collect();
    let frequency_sigma = profile_sigma(&frequencies, &chi2, best);
    let mut period = 1.0 / frequency;
    let mut period_sigma = frequency_sigma / (frequency * frequency);
    // Below the grid, at the periods a motor has: m cycles per motor revolution.
    let motor_periods = motor_cycle_periods(data, 1.0 / f_high, &speeds);
    let mut shortest = 1.0 / f_high;
    if let Some(&(_, last)) = motor_periods.last() {
        shortest = last;
        let explained = |period: f64| -> f64 {
            // The columns depend on the data and the period only: each is smoothed once per log.
            let column = |regressor: Regressor, f: fn(f64) -> f64| -> Vec<f64> {
                let inner = || data.motor_pos_inner.iter().map(|q| f(two_pi * q / period)).collect::<Vec<_>>();
                let smoothed = data.smoothed_regressor(regressor, period, inner);
                smoothed.iter().zip(mask).filter(|(_, m)| **m).map(|(v, _)| *v).collect()
            };
            let (sin, cos) = (column(Regressor::CoggingSin, f64::sin), column(Regressor::CoggingCos, f64::cos));
            let mut sums = SinCosSums::default();
            for i in 0..torque_rows {
                sums.add(w[i], r[i], cos[i], sin[i]);
            }
            sums.explained()
        };
        // Each motor period is fitted on its own, side by side; the best is taken in the
        // periods' order, as one after another would.
        let gains: Vec<(f64, f64)> = motor_periods.par_iter().map(|&(_, p)| (p, explained(p))).collect();
        let (best_motor, gain) = gains.into_iter().max_by(|a, b| a.1.total_cmp(&b.1)).unwrap_or((period, 0.0));
        if total - gain < chi2[best] {
            // A motor's period is exact (a whole number of cycles a revolution).
            period = best_motor;
            period_sigma = 0.0;
        }
    }
    let frequency = 1.0 / period;
    let sin = data.smooth(&data.motor_pos_inner.iter().map(|q| (two_pi * q * frequency).sin()).collect::<Vec<_>>());
    let cos = data.smooth(&data.motor_pos_inner.iter().map(|q| (two_pi * q * frequency).cos()).collect::<Vec<_>>());
    Ok(Instance {
        kind,
        mode: Mode::Search,
        columns: vec![
            Column { label: "cogging sin part (A cos phase)".into(), unit: "N m".into(), channels: torque_only(sin) },
            Column { label: "cogging cos part (A sin phase)".into(), unit: "N m".into(), channels: torque_only(cos) },
        ],
        adjust: Vec::new(),
        searched: vec![Searched {
            name: names::COGGING_PERIOD.into(),
            unit: "rad".into(),
            value: period,
            sigma: period_sigma,
            range: (shortest, 1.0 / f_low),
        }],
        // The grid oversamples the spatial-frequency resolution 1/range by 8; each motor
        // period is one more trial.
        trials: (count as f64 / 8.0).max(1.0) + motor_periods.len() as f64,
        extra_parameters: 1,
    })
}

/// The periods (axis-referred motor angle, rad) of m cycles per motor revolution, 2 pi /
/// (N m), that are shorter than `shorter_than` (the continuous grid's shortest): a cogging
/// torque (slots and poles), a torque ripple (six per electrical period) or a motor encoder's
/// error repeat a whole number of times a motor revolution, so below the grid the search tries
/// those periods only, m up to 64, with columns evaluated on the unsmoothed angle and smoothed
/// as the torque is, so they are seen wherever the motor turns slowly enough for the filter to
/// pass them: a period is tried only when at least a twentieth of the moving samples
/// (`sorted_speeds`, axis-referred motor speeds in ascending order) are that slow (their
/// cycles at most half the cut-off frequency), since every period tried makes the test of
/// every candidate stricter. (m, period), longest first.
fn motor_cycle_periods(data: &EquationData, shorter_than: f64, sorted_speeds: &[f64]) -> Vec<(u32, f64)> {
    let revolution = 2.0 * std::f64::consts::PI / data.gear_ratio.abs().max(f64::MIN_POSITIVE);
    let slow_speed = sorted_speeds.get(sorted_speeds.len() / 20).copied().unwrap_or(f64::INFINITY);
    (1..=MAX_CYCLES_PER_MOTOR_REVOLUTION)
        .map(|m| (m, revolution / m as f64))
        .filter(|&(_, p)| p < shorter_than && slow_speed <= 0.5 * data.cutoff_hz * p)
        .collect()
}

/// The most cycles per motor revolution the cogging search tries ([`motor_cycle_periods`]).
pub const MAX_CYCLES_PER_MOTOR_REVOLUTION: u32 = 64;

/// How large an effect is in physical terms: the change of its leading parameter from
/// `before` to `after` (name, change, unit): the friction level, the offset, the width, the
/// stiffness, the load inertia, the delay or the torque-constant scale; for an unbalance the
/// size of the change of its (cos, sin) vector; for a cogging torque, of its amplitude.
pub fn size_change(kind: Kind, before: &ParameterSet, after: &ParameterSet) -> (&'static str, f64, &'static str) {
    let change = |name: &str| after.value(name) - before.value(name);
    match kind {
        Kind::Coulomb => (names::COULOMB, change(names::COULOMB), "N m"),
        Kind::Viscous => (names::VISCOUS, change(names::VISCOUS), "N m s/rad"),
        Kind::Offset => (names::TORQUE_OFFSET, change(names::TORQUE_OFFSET), "N m"),
        Kind::Backlash => (names::BACKLASH_WIDTH, change(names::BACKLASH_WIDTH), "rad"),
        Kind::Stiffness => (names::STIFFNESS, change(names::STIFFNESS), "N m/rad"),
        Kind::Inertia => (names::LOAD_INERTIA, change(names::LOAD_INERTIA), "kg m^2"),
        Kind::Unbalance => {
            let vector = |p: &ParameterSet| {
                let (a, phase) = (p.value(names::UNBALANCE_TORQUE), p.value(names::UNBALANCE_PHASE));
                (a * phase.cos(), a * phase.sin())
            };
            let ((c0, s0), (c1, s1)) = (vector(before), vector(after));
            (names::UNBALANCE_TORQUE, (c1 - c0).hypot(s1 - s0), "N m")
        }
        Kind::Delay => (names::DELAY, change(names::DELAY), "s"),
        Kind::TorqueConstant => (names::TORQUE_CONSTANT_SCALE, change(names::TORQUE_CONSTANT_SCALE), "-"),
        Kind::Stribeck => ("friction.static - friction.coulomb", change(names::STATIC) - change(names::COULOMB), "N m"),
        Kind::Cogging => (names::COGGING_AMPLITUDE, change(names::COGGING_AMPLITUDE), "N m"),
    }
}

/// Whether [`apply`] keeps the kind's leading parameter within a physical bound (a backlash
/// width is not negative), so that a fit past the bound changes it less than its coefficient
/// says.
pub fn has_bound(kind: Kind) -> bool {
    matches!(kind, Kind::Backlash)
}

/// The physical parameters of a fitted effect: (name, value, standard deviation, unit).
pub type Reported = Vec<(String, f64, f64, String)>;

/// Writes a fitted effect into the parameter set: in Search mode from the coefficients of a
/// new effect, in Refine mode as Gauss-Newton increments. `beta` are the effect's own
/// coefficients.
pub fn apply(instance: &Instance, beta: &[f64], data: &EquationData, params: &mut ParameterSet) {
    let gear2 = data.gear_ratio * data.gear_ratio;
    let refine = instance.mode == Mode::Refine;
    match instance.kind {
        Kind::Coulomb => {
            let fc = params.value(names::COULOMB);
            let fs = params.get(names::STATIC).unwrap_or(fc);
            params.set(names::COULOMB, fc + beta[0]);
            params.set(names::STATIC, fs + beta[0]);
        }
        Kind::Viscous => params.set(names::VISCOUS, params.value(names::VISCOUS) + beta[0]),
        Kind::Offset => params.set(names::TORQUE_OFFSET, params.value(names::TORQUE_OFFSET) + beta[0]),
        Kind::Backlash => params.set(names::BACKLASH_WIDTH, (params.value(names::BACKLASH_WIDTH) + beta[0]).max(0.0)),
        Kind::Stiffness => {
            params.set(names::STIFFNESS, params.value(names::STIFFNESS) + beta[0]);
            params.set(names::DAMPING, params.value(names::DAMPING) + beta[1]);
        }
        Kind::Inertia => {
            if instance.columns.len() == 2 {
                params.set(names::MOTOR_INERTIA, params.value(names::MOTOR_INERTIA) + beta[0] / gear2);
                params.set(names::LOAD_INERTIA, params.value(names::LOAD_INERTIA) + beta[1]);
            } else {
                params.set(names::LOAD_INERTIA, params.value(names::LOAD_INERTIA) + beta[0]);
            }
        }
        Kind::Unbalance => {
            let a0 = params.value(names::UNBALANCE_TORQUE);
            let p0 = params.value(names::UNBALANCE_PHASE);
            let (c, s) = (a0 * p0.cos() + beta[0], a0 * p0.sin() + beta[1]);
            params.set(names::UNBALANCE_TORQUE, c.hypot(s));
            params.set(names::UNBALANCE_PHASE, s.atan2(c));
        }
        Kind::Delay => {
            let searched = if refine { 0.0 } else { instance.searched[0].value };
            params.set(names::DELAY, params.value(names::DELAY) + searched + beta[0]);
        }
        Kind::TorqueConstant => {
            let s = params.value(names::TORQUE_CONSTANT_SCALE);
            params.set(names::TORQUE_CONSTANT_SCALE, s * (1.0 + beta[0]));
        }
        Kind::Stribeck => {
            let fc = params.value(names::COULOMB);
            if refine {
                let fs = params.get(names::STATIC).unwrap_or(fc);
                params.set(names::STATIC, fs + beta[0]);
                let vs = params.value(names::STRIBECK_VELOCITY);
                // A Gauss-Newton step may overshoot on this nonlinear parameter: keep it
                // within a factor 2 per step.
                params.set(names::STRIBECK_VELOCITY, (vs + beta[1]).clamp(0.5 * vs, 2.0 * vs));
            } else {
                params.set(names::STATIC, fc + beta[0]);
                params.set(names::STRIBECK_VELOCITY, instance.searched[0].value);
            }
        }
        Kind::Cogging => {
            let (a, b, period) = if refine {
                let amplitude = params.value(names::COGGING_AMPLITUDE);
                let phase = params.value(names::COGGING_PHASE);
                let p = params.value(names::COGGING_PERIOD);
                (
                    amplitude * phase.cos() + beta[0],
                    amplitude * phase.sin() + beta[1],
                    (p + beta[2]).clamp(0.9 * p, 1.1 * p),
                )
            } else {
                (beta[0], beta[1], instance.searched[0].value)
            };
            params.set(names::COGGING_AMPLITUDE, a.hypot(b));
            params.set(names::COGGING_PHASE, b.atan2(a));
            params.set(names::COGGING_PERIOD, period);
        }
    }
}

/// Why a candidate cannot be set up on a log.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NotApplicable {
    #[error("needs two encoders and a stiffness in the parameter set")]
    NeedsTwoEncodersAndStiffness,
    #[error("too few moving samples")]
    TooFewMovingSamples,
    #[error("no cogging period to refine")]
    NoCoggingPeriod,
    #[error("a Stribeck hump rises over a Coulomb level, which the parameter set lacks (Coulomb first)")]
    StribeckWithoutCoulomb,
    #[error("the angle range is too small for a period search")]
    AngleRangeTooSmall,
}

/// Why a fitted parameter set is physically inadmissible ([`admissible`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Inadmissible {
    #[error("{name} would be negative ({value:.4e})")]
    Negative { name: &'static str, value: f64 },
    #[error("{} would not be positive", names::STIFFNESS)]
    StiffnessNotPositive,
    #[error("{name} would be {scale:.3}, outside 0.5 to 2", name = names::TORQUE_CONSTANT_SCALE)]
    TorqueConstantScale { scale: f64 },
    #[error(
        "{} would be {value:.3e} rad/s, outside the measured speeds (0 to {fastest:.3e})",
        names::STRIBECK_VELOCITY
    )]
    StribeckVelocity { value: f64, fastest: f64 },
    #[error("{name} would be negative ({delay:.3e} s)", name = names::DELAY)]
    NegativeDelay { delay: f64 },
    #[error("{} would be below {}", names::STATIC, names::COULOMB)]
    StaticBelowCoulomb,
}

/// Physical admissibility of a parameter set after an effect was fitted: inertias, friction
/// levels, damping and backlash not negative, stiffness positive, the torque-constant scale
/// within a factor 2 (a larger error is a units mistake, not an effect), a Stribeck velocity
/// within the speeds the data covers (above them the hump is indistinguishable from Coulomb
/// friction), a delay not negative, breakaway friction not below sliding friction (the plant FMU accepts nothing else). A fit that leaves this region has found
/// a collinear direction of the data, not an effect.
pub fn admissible(params: &ParameterSet, data: &EquationData) -> Result<(), Inadmissible> {
    let nonnegative = [
        names::MOTOR_INERTIA,
        names::LOAD_INERTIA,
        names::VISCOUS,
        names::COULOMB,
        names::STATIC,
        names::DAMPING,
        names::BACKLASH_WIDTH,
    ];
    for name in nonnegative {
        if params.get(name).is_some_and(|v| v < 0.0) {
            return Err(Inadmissible::Negative { name, value: params.value(name) });
        }
    }
    if params.get(names::STIFFNESS).is_some_and(|k| k <= 0.0) && data.structure == Structure::TwoMass {
        return Err(Inadmissible::StiffnessNotPositive);
    }
    let scale = params.value(names::TORQUE_CONSTANT_SCALE);
    if !(0.5..=2.0).contains(&scale) {
        return Err(Inadmissible::TorqueConstantScale { scale });
    }
    let fastest = data.motor_vel.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let vs = params.value(names::STRIBECK_VELOCITY);
    if params.value(names::STATIC) != params.value(names::COULOMB) && !(vs > 0.0 && vs <= fastest) {
        return Err(Inadmissible::StribeckVelocity { value: vs, fastest });
    }
    if params.value(names::DELAY) < 0.0 {
        return Err(Inadmissible::NegativeDelay { delay: params.value(names::DELAY) });
    }
    // The plant FMU's friction law needs the breakaway level at least the sliding level.
    if params.get(names::STATIC).is_some_and(|fs| fs < params.value(names::COULOMB)) {
        return Err(Inadmissible::StaticBelowCoulomb);
    }
    Ok(())
}

/// The parameters of an accepted effect for the report, with standard deviations from the
/// covariance of its Refine-mode coefficients at the converged parameters (`covariance`: the
/// effect's own block, in the order of its columns).
pub fn report(
    kind: Kind,
    start: &ParameterSet,
    params: &ParameterSet,
    covariance: &nalgebra::DMatrix<f64>,
    data: &EquationData,
) -> Reported {
    let gear2 = data.gear_ratio * data.gear_ratio;
    let mut out: Reported = Vec::new();
    let mut add =
        |name: &str, value: f64, sd: f64, unit: &str| out.push((name.to_string(), value, sd, unit.to_string()));
    let change = |name: &str| params.value(name) - start.value(name);
    let sd = |i: usize| if i < covariance.nrows() { covariance[(i, i)].max(0.0).sqrt() } else { f64::NAN };
    match kind {
        Kind::Coulomb => {
            add("friction.coulomb change", change(names::COULOMB), sd(0), "N m");
            add(names::COULOMB, params.value(names::COULOMB), sd(0), "N m");
        }
        Kind::Viscous => {
            add("friction.viscous change", change(names::VISCOUS), sd(0), "N m s/rad");
            add(names::VISCOUS, params.value(names::VISCOUS), sd(0), "N m s/rad");
        }
        Kind::Offset => add(names::TORQUE_OFFSET, params.value(names::TORQUE_OFFSET), sd(0), "N m"),
        Kind::Backlash => add(names::BACKLASH_WIDTH, params.value(names::BACKLASH_WIDTH), sd(0), "rad"),
        Kind::Stiffness => {
            add("path.stiffness change", change(names::STIFFNESS), sd(0), "N m/rad");
            add(names::STIFFNESS, params.value(names::STIFFNESS), sd(0), "N m/rad");
            add(names::DAMPING, params.value(names::DAMPING), sd(1), "N m s/rad");
        }
        Kind::Inertia => {
            if covariance.nrows() == 2 {
                add("load.inertia change", change(names::LOAD_INERTIA), sd(1), "kg m^2");
                add(names::LOAD_INERTIA, params.value(names::LOAD_INERTIA), sd(1), "kg m^2");
                add(names::MOTOR_INERTIA, params.value(names::MOTOR_INERTIA), sd(0) / gear2, "kg m^2");
            } else {
                add("load.inertia change (total inertia)", change(names::LOAD_INERTIA), sd(0), "kg m^2");
                add(names::LOAD_INERTIA, params.value(names::LOAD_INERTIA), sd(0), "kg m^2");
            }
        }
        Kind::Unbalance => {
            let (amp_sd, phase_sd) = polar_deviations(
                params.value(names::UNBALANCE_TORQUE),
                params.value(names::UNBALANCE_PHASE),
                covariance,
            );
            add(names::UNBALANCE_TORQUE, params.value(names::UNBALANCE_TORQUE), amp_sd, "N m");
            add(names::UNBALANCE_PHASE, params.value(names::UNBALANCE_PHASE), phase_sd, "rad");
        }
        Kind::Delay => add(names::DELAY, params.value(names::DELAY), sd(0), "s"),
        Kind::TorqueConstant => {
            let s = params.value(names::TORQUE_CONSTANT_SCALE);
            add(names::TORQUE_CONSTANT_SCALE, s, s * sd(0), "-");
        }
        Kind::Stribeck => {
            add("friction.static change", change(names::STATIC) - change(names::COULOMB), sd(0), "N m");
            add(names::STATIC, params.value(names::STATIC), sd(0), "N m");
            add(names::STRIBECK_VELOCITY, params.value(names::STRIBECK_VELOCITY), sd(1), "rad/s");
        }
        Kind::Cogging => {
            let amplitude = params.value(names::COGGING_AMPLITUDE);
            let phase = params.value(names::COGGING_PHASE);
            let (amp_sd, phase_sd) = polar_deviations(amplitude, phase, covariance);
            add(names::COGGING_AMPLITUDE, amplitude, amp_sd, "N m");
            add(names::COGGING_PERIOD, params.value(names::COGGING_PERIOD), sd(2), "rad");
            add(names::COGGING_PHASE, phase, phase_sd, "rad");
        }
    }
    out
}

/// Standard deviations of an amplitude and phase fitted as the Cartesian pair
/// (amplitude cos phase, amplitude sin phase), the first two coefficients of `covariance`, by
/// the delta method with their covariance in full. A periodic effect's phase is referred to
/// angle zero, often far from the logged range, so a period's uncertainty turns it and the
/// pair's variances grow along the phase's direction while the amplitude stays determined: the
/// amplitude's deviation must be the radial one, not the pair's mean variance.
fn polar_deviations(amplitude: f64, phase: f64, covariance: &nalgebra::DMatrix<f64>) -> (f64, f64) {
    if covariance.nrows() < 2 || covariance.ncols() < 2 {
        return (f64::NAN, f64::NAN);
    }
    let (var_c, var_s, cov_cs) = (covariance[(0, 0)], covariance[(1, 1)], covariance[(0, 1)]);
    if amplitude <= 0.0 {
        return ((0.5 * (var_c + var_s)).max(0.0).sqrt(), f64::INFINITY);
    }
    let (cos, sin) = (phase.cos(), phase.sin());
    // Radial direction (cos, sin) and tangential direction (-sin, cos) / amplitude.
    let radial = cos * cos * var_c + 2.0 * cos * sin * cov_cs + sin * sin * var_s;
    let tangential = (sin * sin * var_c - 2.0 * cos * sin * cov_cs + cos * cos * var_s) / (amplitude * amplitude);
    (radial.max(0.0).sqrt(), tangential.max(0.0).sqrt())
}

#[cfg(test)]
mod tests {
    use super::polar_deviations;
    use nalgebra::DMatrix;

    /// A covariance of the Cartesian pair with `radial` and `tangential` deviations about the
    /// direction of `phase`.
    fn pair_covariance(phase: f64, radial: f64, tangential: f64) -> DMatrix<f64> {
        let (c, s) = (phase.cos(), phase.sin());
        let rotation = DMatrix::from_row_slice(2, 2, &[c, -s, s, c]);
        let diagonal =
            DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![radial * radial, tangential * tangential]));
        &rotation * diagonal * rotation.transpose()
    }

    #[test]
    fn a_phase_turned_by_an_uncertain_period_leaves_the_amplitude_determined() {
        // The pair's uncertainty lies along the phase (a period fitted beside it turns the
        // phase at angle zero): 800 N m tangential, 5 N m radial, on an amplitude of 400 N m.
        let (amplitude, phase) = (400.0, 2.1);
        let covariance = pair_covariance(phase, 5.0, 800.0);
        let (amplitude_sd, phase_sd) = polar_deviations(amplitude, phase, &covariance);
        assert!((amplitude_sd - 5.0).abs() < 1e-9, "amplitude deviation {amplitude_sd}");
        assert!((phase_sd - 2.0).abs() < 1e-9, "phase deviation {phase_sd}");
    }

    #[test]
    fn an_amplitude_of_zero_has_no_phase() {
        let (amplitude_sd, phase_sd) = polar_deviations(0.0, 0.0, &pair_covariance(0.3, 3.0, 3.0));
        assert!((amplitude_sd - 3.0).abs() < 1e-9);
        assert!(phase_sd.is_infinite());
    }
}
