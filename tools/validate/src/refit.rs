//! Refitting the found effects' parameters on the output error.
//!
//! The search fits an effect's parameters on the equation error (inverse dynamics), whose
//! static friction law meets the truth's or the real drive's friction dynamics only
//! approximately: the fit of one effect can absorb part of that difference (a Stribeck level
//! fitted low where the real friction lags). The model is used as a simulation, so its
//! parameters are finally adjusted to what the simulation predicts: a Levenberg-Marquardt
//! search over the found effects' own parameters (at most [`MAX_PARAMETERS`]) that minimises
//! the output error's score, the sum over the scored channels of the squared error over that
//! channel's mean squared error at the equation-error parameters. The Jacobian is taken by
//! forward differences, one simulation per parameter; a step is taken only when it lowers
//! the score and keeps the parameters admissible, so the refit never makes the simulation
//! worse than the equation-error fit.

use super::candidates::{self, Kind};
use super::equation_error::EquationData;
use super::output_error::{self, OutputData, OutputError, PlantSimulator, WindowPlan};
use super::parameters::{names, ParameterSet};

/// The refit is done over at most this many parameters (every simulation of the Jacobian
/// costs one output error).
pub const MAX_PARAMETERS: usize = 3;

/// Levenberg-Marquardt iterations at most.
pub const MAX_ITERATIONS: usize = 5;

/// One free parameter of the refit: a named parameter, or a level that moves two parameters
/// together (a Coulomb change raises the breakaway level by as much, keeping the hump).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Free {
    Plain(&'static str),
    Together(&'static str, &'static str),
}

impl Free {
    fn value(self, p: &ParameterSet) -> f64 {
        match self {
            Free::Plain(name) | Free::Together(name, _) => p.value(name),
        }
    }

    fn shift(self, p: &mut ParameterSet, delta: f64) {
        match self {
            Free::Plain(name) => p.set(name, p.value(name) + delta),
            Free::Together(a, b) => {
                p.set(a, p.value(a) + delta);
                p.set(b, p.value(b) + delta);
            }
        }
    }

    fn name(self) -> &'static str {
        match self {
            Free::Plain(name) | Free::Together(name, _) => name,
        }
    }

    /// An angle: its difference step is absolute, not relative to its value.
    fn is_phase(self) -> bool {
        matches!(self, Free::Plain(names::UNBALANCE_PHASE) | Free::Plain(names::COGGING_PHASE))
    }
}

/// The parameters an effect's refit moves: the ones that define its size and form. Periods
/// and the damping that goes with a stiffness stay at the equation-error values.
fn free_parameters(kind: Kind) -> Vec<Free> {
    match kind {
        Kind::Coulomb => vec![Free::Together(names::COULOMB, names::STATIC)],
        Kind::Viscous => vec![Free::Plain(names::VISCOUS)],
        Kind::Stribeck => vec![Free::Plain(names::STATIC), Free::Plain(names::STRIBECK_VELOCITY)],
        Kind::Offset => vec![Free::Plain(names::TORQUE_OFFSET)],
        Kind::Backlash => vec![Free::Plain(names::BACKLASH_WIDTH)],
        Kind::Stiffness => vec![Free::Plain(names::STIFFNESS)],
        Kind::Inertia => vec![Free::Plain(names::LOAD_INERTIA)],
        Kind::Unbalance => vec![Free::Plain(names::UNBALANCE_TORQUE), Free::Plain(names::UNBALANCE_PHASE)],
        Kind::Delay => vec![Free::Plain(names::DELAY)],
        Kind::TorqueConstant => vec![Free::Plain(names::TORQUE_CONSTANT_SCALE)],
        Kind::Cogging => vec![Free::Plain(names::COGGING_AMPLITUDE), Free::Plain(names::COGGING_PHASE)],
    }
}

/// The outcome of a refit.
#[derive(Debug, Clone)]
pub struct Refit {
    /// The parameters with the refitted values.
    pub params: ParameterSet,
    /// (parameter, equation-error value, output-error value).
    pub changes: Vec<(String, f64, f64)>,
    /// The output error's score at the equation-error parameters (1 by construction) and after.
    pub score_before: f64,
    pub score_after: f64,
    pub iterations: usize,
    /// The output error at the refitted parameters.
    pub error: OutputError,
}

/// The residual vector of the scored channels, each over the root of its scale.
fn residual(e: &OutputError, scale: &[f64]) -> Vec<f64> {
    e.channels
        .iter()
        .filter(|c| c.scored)
        .zip(scale)
        .flat_map(|(c, s)| c.measured.iter().zip(&c.simulated).map(move |(m, x)| (m - x) / s.sqrt()))
        .collect()
}

fn cost(r: &[f64]) -> f64 {
    r.iter().map(|x| x * x).sum()
}

/// Refits the found effects' parameters on the output error, starting from `params` (the
/// equation-error fit) whose output error is `error`. None when there is nothing to refit,
/// more than [`MAX_PARAMETERS`] parameters, or no step lowered the score.
#[allow(clippy::too_many_arguments)]
pub fn refit(
    simulator: &mut dyn PlantSimulator,
    data: &EquationData,
    out: &OutputData,
    plan: &WindowPlan,
    start: &ParameterSet,
    found: &[Kind],
    params: &ParameterSet,
    error: &OutputError,
) -> Option<Refit> {
    let free: Vec<Free> = found.iter().flat_map(|&k| free_parameters(k)).collect();
    if free.is_empty() || free.len() > MAX_PARAMETERS {
        return None;
    }
    let scale: Vec<f64> = error
        .channels
        .iter()
        .filter(|c| c.scored)
        .map(|c| (c.window_sse.iter().sum::<f64>() / c.measured.len().max(1) as f64).max(f64::MIN_POSITIVE))
        .collect();
    let mut current = params.clone();
    let mut r = residual(error, &scale);
    let initial = cost(&r);
    if initial.is_nan() || initial <= 0.0 {
        return None;
    }
    let mut best_error = error.clone();
    let mut c0 = initial;
    let mut lambda = 1e-2;
    let mut iterations = 0;
    let evaluate = |simulator: &mut dyn PlantSimulator, p: &ParameterSet| -> Option<OutputError> {
        candidates::admissible(p, data).ok()?;
        output_error::output_error(simulator, p, data, out, plan).ok()
    };
    while iterations < MAX_ITERATIONS {
        iterations += 1;
        // Forward differences, the step a hundredth of the effect's own change from the start
        // (the size the data showed), so a parameter that starts at zero gets a useful step.
        let mut jacobian: Vec<Vec<f64>> = Vec::with_capacity(free.len());
        for &f in &free {
            let change = (f.value(&current) - f.value(start)).abs();
            let h = if f.is_phase() { 1e-2 } else { (1e-2 * change).max(1e-4 * f.value(&current).abs()).max(1e-12) };
            let mut probe = current.clone();
            f.shift(&mut probe, h);
            let e = evaluate(simulator, &probe).or_else(|| {
                f.shift(&mut probe, -2.0 * h);
                evaluate(simulator, &probe)
            })?;
            let sign = if f.value(&probe) > f.value(&current) { 1.0 } else { -1.0 };
            let rp = residual(&e, &scale);
            jacobian.push(rp.iter().zip(&r).map(|(a, b)| sign * (a - b) / h).collect());
        }
        let k = free.len();
        let mut normal = nalgebra::DMatrix::<f64>::zeros(k, k);
        let mut gradient = nalgebra::DVector::<f64>::zeros(k);
        for i in 0..k {
            gradient[i] = jacobian[i].iter().zip(&r).map(|(j, x)| j * x).sum();
            for j in 0..k {
                normal[(i, j)] = jacobian[i].iter().zip(&jacobian[j]).map(|(a, b)| a * b).sum();
            }
        }
        let mut improved = false;
        for _ in 0..4 {
            let mut damped = normal.clone();
            for i in 0..k {
                damped[(i, i)] *= 1.0 + lambda;
            }
            let Some(delta) = damped.lu().solve(&(-&gradient)) else {
                lambda *= 10.0;
                continue;
            };
            let mut trial = current.clone();
            for (i, &f) in free.iter().enumerate() {
                f.shift(&mut trial, delta[i]);
            }
            match evaluate(simulator, &trial) {
                Some(e) => {
                    let rt = residual(&e, &scale);
                    let ct = cost(&rt);
                    if ct < c0 {
                        let gain = (c0 - ct) / c0;
                        current = trial;
                        r = rt;
                        c0 = ct;
                        best_error = e;
                        lambda = (lambda / 3.0).max(1e-6);
                        improved = gain > 1e-3;
                        break;
                    }
                    lambda *= 4.0;
                }
                None => lambda *= 4.0,
            }
        }
        if !improved {
            break;
        }
    }
    if c0 >= initial {
        return None;
    }
    let changes = free.iter().map(|f| (f.name().to_string(), f.value(params), f.value(&current))).collect();
    Some(Refit {
        params: current,
        changes,
        score_before: 1.0,
        score_after: c0 / initial,
        iterations,
        error: best_error,
    })
}
