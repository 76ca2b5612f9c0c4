//! The friction-form calibration: the presliding (bristle) compliance of the motor friction,
//! fitted on the output error before the effect search.
//!
//! Real friction yields elastically below breakaway (bristles, asperities) by some
//! microradians; a rigid stick does not. That presliding regime shapes the motion at every
//! reversal and creep phase, and in the twist of a compliant drive it leaves a floor as large as
//! what a stiffness or a lost motion adds. It is not an effect the model lacks in the issue's
//! sense (it is present in every drive, clean or not) but part of the friction law's form, so it
//! is calibrated first, once, and used in the "before" and "after" models alike; it is reported
//! as the calibration, never as a found effect.
//!
//! One parameter is searched: the presliding displacement at breakaway `delta` (axis rad), the
//! bristle stiffness being the breakaway level over it, `sigma = F_s / delta`, and the bristle
//! critically damped with the reflected motor inertia, `c = 2 sqrt(sigma J_M N^2)`. The search
//! is a golden-section search of the output error's score over log10(delta) in
//! [`LOG_DELTA_RANGE`] (the rigid stick is its lower end's limit). The calibration is kept only
//! when the output error confirms it as it would an effect with one parameter (a significant
//! majority of windows better, and the BIC gain), so a drive whose friction does stick rigidly
//! keeps the rigid stick.

use super::equation_error::EquationData;
use super::output_error::{self, Comparison, OutputData, OutputError, PlantSimulator, WindowPlan};
use super::parameters::{names, ParameterSet};

/// Range of log10 of the presliding displacement searched (axis rad): 10 nrad to 100 urad.
pub const LOG_DELTA_RANGE: (f64, f64) = (-8.0, -4.0);

/// The golden-section search stops when the bracket is this narrow (decades).
pub const LOG_TOLERANCE: f64 = 0.05;

/// The outcome of the calibration.
#[derive(Debug, Clone)]
pub struct Calibration {
    /// Presliding displacement at breakaway (axis rad) and the resulting stiffness and damping
    /// (axis side).
    pub displacement: f64,
    pub stiffness: f64,
    pub damping: f64,
    /// The calibrated model against the starting one (rigid stick).
    pub comparison: Comparison,
    /// Whether it was kept (confirmed); when not, the models stay with the rigid stick.
    pub kept: bool,
    /// Every (log10 delta, score) evaluated, in order.
    pub evaluations: Vec<(f64, f64)>,
    /// The output error of the calibrated model.
    pub error: OutputError,
}

/// `params` with the presliding element for displacement `delta` (axis rad).
pub fn with_displacement(params: &ParameterSet, delta: f64) -> ParameterSet {
    let gear = params.value(names::GEAR_RATIO);
    let breakaway = params.value(names::STATIC).max(params.value(names::COULOMB));
    let stiffness = breakaway / delta;
    let inertia = params.value(names::MOTOR_INERTIA) * gear * gear;
    let mut out = params.clone();
    out.set(names::PRESLIDING_STIFFNESS, stiffness);
    out.set(names::PRESLIDING_DAMPING, 2.0 * (stiffness * inertia).sqrt());
    out
}

/// Calibrates the presliding displacement on the output error; None when the model has no
/// friction level to hold with, or the simulation fails.
pub fn calibrate(
    simulator: &mut dyn PlantSimulator,
    data: &EquationData,
    out: &OutputData,
    plan: &WindowPlan,
    start: &ParameterSet,
    before: &OutputError,
    alpha: f64,
) -> Option<Calibration> {
    let breakaway = params_breakaway(start);
    if breakaway.is_nan() || breakaway <= 0.0 {
        return None;
    }
    let mut evaluations = Vec::new();
    let mut best: Option<(f64, OutputError, f64)> = None;
    let score = |x: f64,
                 simulator: &mut dyn PlantSimulator,
                 evaluations: &mut Vec<(f64, f64)>,
                 best: &mut Option<(f64, OutputError, f64)>|
     -> f64 {
        let params = with_displacement(start, 10f64.powf(x));
        let value = match output_error::output_error(simulator, &params, data, out, plan) {
            Ok(e) => {
                let s = output_error::compare(before, &e, 1, alpha).score_after;
                if best.as_ref().is_none_or(|b| s < b.2) {
                    *best = Some((x, e, s));
                }
                s
            }
            Err(_) => f64::INFINITY,
        };
        evaluations.push((x, value));
        value
    };
    // Golden-section search on the (assumed unimodal) score over log10(delta).
    let ratio = (5f64.sqrt() - 1.0) / 2.0;
    let (mut a, mut b) = LOG_DELTA_RANGE;
    let mut c = b - ratio * (b - a);
    let mut d = a + ratio * (b - a);
    let mut fc = score(c, simulator, &mut evaluations, &mut best);
    let mut fd = score(d, simulator, &mut evaluations, &mut best);
    while b - a > LOG_TOLERANCE {
        if fc <= fd {
            b = d;
            d = c;
            fd = fc;
            c = b - ratio * (b - a);
            fc = score(c, simulator, &mut evaluations, &mut best);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + ratio * (b - a);
            fd = score(d, simulator, &mut evaluations, &mut best);
        }
    }
    let (x, error, _) = best?;
    let displacement = 10f64.powf(x);
    let params = with_displacement(start, displacement);
    let comparison = output_error::compare(before, &error, 1, alpha);
    Some(Calibration {
        displacement,
        stiffness: params.value(names::PRESLIDING_STIFFNESS),
        damping: params.value(names::PRESLIDING_DAMPING),
        kept: comparison.confirmed,
        comparison,
        evaluations,
        error,
    })
}

fn params_breakaway(params: &ParameterSet) -> f64 {
    params.value(names::STATIC).max(params.value(names::COULOMB))
}
