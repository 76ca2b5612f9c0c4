//! Re-estimating the effect families a starting set already holds.
//!
//! The search tests each candidate as a change from the starting set, in the equation error,
//! and only then asks the simulation. A starting set that holds a guess of a family (a Coulomb
//! level, a viscous coefficient) is therefore judged by the equation error's test of the change
//! from that guess, which on a coloured residual can sit inside the equation error's
//! uncertainty while the simulation tells the guess from the data: on KUKA axis 2, from a start
//! with Coulomb 500 N m and viscous 1000 N m s/rad, a Coulomb change of +233 N m had a
//! chi-square of 5.4 (level 1.3e-5), while the simulation with it predicted significantly
//! better (29 of 41 windows, p = 2.4e-4). A start without the family gets the family's test
//! from zero, which the data pass easily (chi-square 63.6), and then the simulation's check.
//!
//! So a family the start holds is given the tests a start without it gets:
//!
//! - the equation error must find the family itself, tested from its neutral value with the
//!   found effects fitted jointly ([`selection::presence`], at the search's last level);
//! - the change the equation error fits from the current model
//!   ([`selection::fit_candidate`]) must be at least the noise in the equation where it shows
//!   (the search's practical significance);
//! - the simulation with it must predict the motion significantly better than with the
//!   start's value (signed-rank test at the search's level divided by the number of families
//!   tried, and a BIC gain).
//!
//! Only the equation error's statistical test of the change is left to the simulation. A
//! family the data do not carry (a load inertia the equation error cannot establish) is not
//! re-estimated however much the simulation alone would like it, as it would not be named from
//! a start without it either. Among the confirmed families the simulation chooses the one that
//! predicts best (the equation error could not rank the changes); the confirmed ones it does
//! not beat significantly are reported as equally consistent with it. Families are added one
//! at a time, and all found effects are then refitted on the output error together
//! ([`refit`]).

use super::candidates::{parameter_count, Kind};
use super::equation_error::EquationData;
use super::output_error::{self, Comparison, OutputData, OutputError, PlantSimulator, WindowPlan};
use super::parameters::{names, ParameterSet};
use super::refit;
use super::selection::{self, Selection, SelectionOptions, Step};
use rayon::prelude::*;

/// The model with the family of `kind` taken out of `params` (its neutral value), or None when
/// `params` hold nothing of it or it has no neutral value that leaves the model's structure as
/// it is (a stiffness: a drive without one is another model).
pub fn neutral(kind: Kind, params: &ParameterSet) -> Option<ParameterSet> {
    let mut out = params.clone();
    let value = |name: &str| params.value(name);
    match kind {
        Kind::Coulomb if value(names::COULOMB) != 0.0 => {
            // The breakaway level keeps its hump over the Coulomb level.
            out.set(names::STATIC, params.get(names::STATIC).unwrap_or(value(names::COULOMB)) - value(names::COULOMB));
            out.set(names::COULOMB, 0.0);
        }
        Kind::Viscous if value(names::VISCOUS) != 0.0 => out.set(names::VISCOUS, 0.0),
        Kind::Stribeck if params.get(names::STATIC).is_some_and(|s| s > value(names::COULOMB)) => {
            out.set(names::STATIC, value(names::COULOMB))
        }
        Kind::Offset if value(names::TORQUE_OFFSET) != 0.0 => out.set(names::TORQUE_OFFSET, 0.0),
        Kind::Inertia if value(names::LOAD_INERTIA) != 0.0 => out.set(names::LOAD_INERTIA, 0.0),
        Kind::Unbalance if value(names::UNBALANCE_TORQUE) != 0.0 => out.set(names::UNBALANCE_TORQUE, 0.0),
        Kind::Delay if value(names::DELAY) != 0.0 => out.set(names::DELAY, 0.0),
        Kind::TorqueConstant if params.get(names::TORQUE_CONSTANT_SCALE).is_some_and(|s| s != 1.0) => {
            out.set(names::TORQUE_CONSTANT_SCALE, 1.0)
        }
        Kind::Cogging if value(names::COGGING_AMPLITUDE) != 0.0 => out.set(names::COGGING_AMPLITUDE, 0.0),
        Kind::Backlash if value(names::BACKLASH_WIDTH) != 0.0 => out.set(names::BACKLASH_WIDTH, 0.0),
        _ => return None,
    }
    Some(out)
}

/// What the re-estimation did: the comparisons it asked (for the report's list of
/// confirmations), the output error of the model it ends with, and whether it changed it.
pub struct Reestimation {
    pub confirmations: Vec<(Kind, Comparison)>,
    pub error: OutputError,
    pub changed: bool,
    /// The joint refit of all found effects after a change, when it lowered the score.
    pub refit: Option<refit::Refit>,
}

/// One family's confirmed trial: its re-estimated parameters and their output error.
struct Trial {
    kind: Kind,
    params: ParameterSet,
    error: OutputError,
    /// Its output-error score relative to the model with the start's value.
    score: f64,
}

/// Re-estimates the families the start holds that the search did not change (see the module
/// documentation), on top of `selection.corrected` whose output error is `error`. Adds each
/// confirmed family to the selection as a found effect (its change from the start), with a
/// search step whose scores are the families' equation-error tests from their neutral values,
/// and refits all found effects' parameters together on the output error at the end.
#[allow(clippy::too_many_arguments)]
pub fn reestimate(
    simulator: &mut dyn PlantSimulator,
    data: &EquationData,
    out: &OutputData,
    plan: &WindowPlan,
    start: &ParameterSet,
    selection: &mut Selection,
    error: &OutputError,
    options: &SelectionOptions,
    alpha: f64,
) -> Reestimation {
    let mut result = Reestimation { confirmations: Vec::new(), error: error.clone(), changed: false, refit: None };
    let Some(threshold) = selection.steps.iter().rev().find(|s| !s.re_estimate).map(|s| s.threshold) else {
        return result;
    };
    let mut accepted: Vec<Kind> = selection.found.iter().map(|f| f.kind).collect();
    let held: Vec<Kind> =
        options.candidates.iter().copied().filter(|k| !accepted.contains(k) && neutral(*k, start).is_some()).collect();
    if held.is_empty() {
        return result;
    }
    // Every family tried is one more chance of a false confirmation.
    let level = alpha / held.len() as f64;
    let mut params = selection.corrected.clone();
    // An unset breakaway level is the Coulomb level; set, it moves with a Coulomb refit (the
    // same model, and the refit's levels stay admissible).
    if params.get(names::STATIC).is_none() {
        params.set(names::STATIC, params.value(names::COULOMB));
    }
    let mut current = error.clone();
    while accepted.len() < options.max_effects {
        // Each family's presence test stands on its own: they run side by side and are
        // collected in the candidates' order.
        let pending: Vec<Kind> = held.iter().copied().filter(|k| !accepted.contains(k)).collect();
        let mut scores: Vec<selection::Score> = pending
            .into_par_iter()
            .filter_map(|kind| {
                let without = neutral(kind, &params)?;
                Some(selection::presence(data, &without, &accepted, kind, threshold, options))
            })
            .collect();
        if scores.is_empty() {
            break;
        }
        // The families the data carry, each at the value the equation error fits from the
        // current model (as the search fits a candidate), judged on the output error against
        // the model with the start's value.
        let mut confirmed: Vec<Trial> = Vec::new();
        for index in (0..scores.len()).filter(|&i| scores[i].significant).collect::<Vec<_>>() {
            let kind = scores[index].kind;
            let Ok(fitted) = selection::fit_candidate(data, &params, &accepted, kind, options) else { continue };
            // The change must still be worth a parameter: at least the noise in the equation
            // where it shows (the search's practical significance; only the equation error's
            // statistical test is left to the simulation).
            let size = selection::change_to_noise(data, kind, &fitted, &params);
            if size < options.min_effect_to_noise {
                scores[index].confirmation =
                    Some(format!("the re-estimate changes the equations by only {size:.2} times the noise"));
                continue;
            }
            let Ok(fitted_error) = output_error::output_error(simulator, &fitted, data, out, plan) else { continue };
            let mut comparison =
                output_error::compare(&current, &fitted_error, parameter_count(kind, data.structure), level);
            comparison.reason = format!("re-estimate of the start's {}: {}", kind.name(), comparison.reason);
            result.confirmations.push((kind, comparison.clone()));
            scores[index].confirmation = Some(comparison.reason.clone());
            if comparison.confirmed {
                confirmed.push(Trial { kind, params: fitted, error: fitted_error, score: comparison.score_after });
            }
        }
        // The equation error could not establish the change, so the simulation chooses: the
        // confirmed family that predicts best; the others it does not beat significantly are
        // equally consistent with it.
        let extra = |a: Kind, b: Kind| {
            (parameter_count(a, data.structure) as isize - parameter_count(b, data.structure) as isize).max(0) as usize
        };
        let chosen = (0..confirmed.len()).min_by(|&a, &b| confirmed[a].score.total_cmp(&confirmed[b].score));
        let equally_consistent: Vec<Kind> = match chosen {
            Some(c) => confirmed
                .iter()
                .enumerate()
                .filter(|(i, t)| {
                    *i != c
                        && !output_error::compare(
                            &t.error,
                            &confirmed[c].error,
                            extra(confirmed[c].kind, t.kind),
                            level,
                        )
                        .confirmed
                })
                .map(|(_, t)| t.kind)
                .collect(),
            None => Vec::new(),
        };
        let chosen = chosen.map(|c| confirmed.swap_remove(c));
        selection.steps.push(Step {
            scores,
            chosen: chosen.as_ref().map(|c| c.kind),
            paired: None,
            threshold,
            iterations: 0,
            equally_consistent,
            re_estimate: true,
        });
        let Some(chosen) = chosen else { break };
        accepted.push(chosen.kind);
        params = chosen.params;
        current = chosen.error;
        result.changed = true;
    }
    if !result.changed {
        return result;
    }
    // All found effects refitted together, as the search's own refit does.
    if let Some(r) = refit::refit(simulator, data, out, plan, start, &accepted, &params, &current) {
        params = r.params.clone();
        current = r.error.clone();
        result.refit = Some(r);
    }
    selection.adopt(data, start, params, &accepted);
    result.error = current;
    result
}
