//! Model validation against measured logs: compute the residual, analyse it as a control
//! engineer would, trace it to a named effect the model lacks, add the effect, refit, and
//! report the error before and after. Documented in docs/validation.md.
//!
//! Two residuals work together. The equation error (inverse dynamics, [`equation_error`])
//! needs no simulation: it finds candidate effects and fits their parameters. The output
//! error ([`output_error`]) simulates the plant FMU through its C ABI ([`plant_fmu`]) over
//! windows re-initialised from the measured state: an effect is claimed only if it also makes
//! the simulation predict the measured motion significantly better, and the error before and
//! after is reported on it, in physical units, as a control engineer compares models.

pub mod band_delay;
pub mod candidates;
pub mod documents;
pub mod equation_error;
pub mod finite;
pub mod frequency;
pub mod measured_log;
pub mod observability;
pub mod output_error;
pub mod parameters;
pub mod plant_fmu;
pub mod presliding;
pub mod reestimate;
pub mod refit;
pub mod report;
pub mod selection;
pub mod sensor_errors;
pub mod signals;
pub mod stats;
pub mod twist;

use crate::measured_log::{MeasuredLog, Signal};
use candidates::{parameter_count, Kind};
use equation_error::{EquationData, EquationOptions, PrepareError, Structure};
use finite::NonFinite;
use output_error::{Comparison, OutputData, OutputError, PlantSimulator, SimulationError, WindowPlan};
use parameters::{FmuConfig, ParameterSet};
use selection::{Fit, Selection, SelectionOptions};

/// Settings of the output-error route.
#[derive(Debug, Clone)]
pub struct OutputOptions {
    /// The window is the lag at which the measured motor speed's autocorrelation falls to
    /// this (see [`output_error::choose_window`]).
    pub window_correlation: f64,
    /// At least this many windows (the window is at most 1/this of the record).
    pub minimum_windows: usize,
    /// Fixed window length (s) instead of the rule above.
    pub window_seconds: Option<f64>,
    /// Fixed length (s) of the drive-path channel's pieces instead of the drive mode's decay
    /// time (see [`output_error::drive_window`]); a length of at least the window scores the
    /// twist on the windows themselves.
    pub drive_window_seconds: Option<f64>,
    /// One-sided level of the signed-rank test that confirms an effect.
    pub alpha: f64,
    /// Refit the found effects' parameters on the output error ([`refit`]).
    pub refit: bool,
    /// Calibrate the friction's presliding compliance before the search ([`presliding`]).
    pub presliding: bool,
    /// Re-estimate the effect families the starting set holds on the output error when the
    /// equation error finds the family in the data ([`reestimate`]).
    pub reestimate: bool,
}

impl Default for OutputOptions {
    fn default() -> Self {
        OutputOptions {
            window_correlation: 0.9,
            minimum_windows: 20,
            window_seconds: None,
            drive_window_seconds: None,
            alpha: 0.01,
            refit: true,
            presliding: true,
            reestimate: true,
        }
    }
}

/// All settings of a validation run.
#[derive(Debug, Clone, Default)]
pub struct ValidateOptions {
    pub equation: EquationOptions,
    pub selection: SelectionOptions,
    pub output: OutputOptions,
    pub twist: twist::TwistOptions,
}

/// Why a log could not be validated. Never a result with NaN in it: a non-finite value in the
/// log, the parameters or anything computed from them stops the validation with its cause.
#[derive(Debug, Clone, thiserror::Error)]
pub enum ValidationError {
    #[error(transparent)]
    Prepare(#[from] PrepareError),
    #[error("the output error of the corrected model: {0}")]
    Simulation(#[from] SimulationError),
    #[error(transparent)]
    NonFinite(#[from] NonFinite),
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

/// The output-error side of a validation.
#[derive(Debug, Clone)]
pub struct OutputReport {
    pub config: FmuConfig,
    pub plan: WindowPlan,
    /// Half-width (samples) of the state estimator that starts the windows.
    pub state_half_width: usize,
    /// The load side's state at the window starts is the motor encoder's less the smoothed
    /// twist (the load encoder does not resolve the twist's motion).
    pub state_through_motor: bool,
    pub before: OutputError,
    pub after: OutputError,
    /// Every confirmation asked during the search: the effect and the comparison of the model
    /// with it against the model without it.
    pub confirmations: Vec<(Kind, Comparison)>,
    /// The corrected model against the starting one.
    pub overall: Comparison,
    /// When that final comparison showed no improvement, the effects it withdrew and why:
    /// the corrected model is then the starting one.
    pub withdrawn: Option<Withdrawal>,
    /// The found effects' parameters refitted on the output error ([`refit`]), when that
    /// lowered its score; the corrected model and "after" are then the refitted ones.
    pub refit: Option<refit::Refit>,
    /// The joint refit after a family the start holds was re-estimated ([`reestimate`]).
    pub refit_after_reestimate: Option<refit::Refit>,
    /// The backward check of the effects found before a re-estimation changed the model, run
    /// again with the re-estimated values in place ([`recheck_after_reestimate`]).
    pub recheck: Option<Recheck>,
    /// The friction-form calibration ([`presliding`]), when it was tried; when kept, `before`
    /// is the calibrated starting model's error and `starting` the uncalibrated one's.
    pub calibration: Option<presliding::Calibration>,
    pub starting: Option<OutputError>,
}

impl OutputReport {
    /// The scored channel whose error dropped most (relative): where the found effects show.
    /// Returns (index, before RMS, after RMS).
    pub fn most_improved(&self) -> Option<(usize, f64, f64)> {
        self.before
            .channels
            .iter()
            .zip(&self.after.channels)
            .enumerate()
            .filter(|(_, (b, _))| b.criterion)
            .map(|(i, (b, a))| (i, b.rms, a.rms))
            .min_by(|x, y| (x.2 / x.1).total_cmp(&(y.2 / y.1)))
    }
}

/// The result of validating one log.
#[derive(Debug, Clone)]
pub struct Validation {
    pub data: EquationData,
    pub selection: Selection,
    pub before: Vec<ChannelStats>,
    pub after: Vec<ChannelStats>,
    pub start: ParameterSet,
    pub output: Option<OutputReport>,
    pub frequency: Option<frequency::FrequencyResponse>,
    /// The two-encoder check of the twist ([`twist`]); for a log whose load encoder was found
    /// to lag, the analysis that found it (the data above are then the corrected ones).
    pub twist: Option<twist::TwistAnalysis>,
    /// The timing skew the load encoder was corrected by (s), when one was found.
    pub encoder_skew: Option<f64>,
    /// The load encoder's position-dependent error, taken out of the data before the search,
    /// when one was found ([`sensor_errors`]).
    pub load_encoder_error: Option<sensor_errors::LoadEncoderError>,
    /// A motor speed sensor's integrated bias drift, taken out of the integrated motor
    /// position before the search, when one was found ([`sensor_errors::tacho_drift`]).
    pub tacho_drift: Option<sensor_errors::TachoDrift>,
    /// A current stamped later than the encoders, taken out of the data before the search,
    /// when one was found ([`band_delay::current_skew`]).
    pub current_skew: Option<band_delay::CurrentSkew>,
    /// Effects not claimed that the output error alone would confirm.
    pub hints: Vec<Hint>,
    /// Candidates that reproduce a found effect over this log ("X or Y: the data cannot
    /// tell"), and found effects collinear with each other ([`observability`]).
    pub indistinct: Vec<observability::Indistinct>,
    pub collinear: Vec<observability::Collinear>,
    /// A found Stribeck change that is mostly a friction term even in the speed: a stand-in for
    /// a direction-dependent friction's low-speed form ([`observability::EvenFriction`]).
    pub even_friction: Option<observability::EvenFriction>,
    /// The band estimate of the delay when the search claimed none ([`band_delay`]): its
    /// detection limit, or a delay it finds that is not claimed, with the simulation's view.
    pub delay_band: Option<band_delay::DelayAccount>,
    /// Whether a two-mass path (the one that fits it best) matches the measured motor-to-load
    /// response ([`frequency::check_path`]); with two encoders and the output error only.
    pub path: Option<frequency::PathCheck>,
    pub notes: Vec<String>,
}

/// An effect the equation-error test did not find significant but the output error would
/// confirm on top of the corrected model: reported as what a longer or richer log could
/// establish, never claimed or written into the corrected parameters.
#[derive(Debug, Clone)]
pub struct Hint {
    pub kind: Kind,
    /// The equation-error p-value at the last step and the threshold it missed.
    pub equation_p: f64,
    pub threshold: f64,
    pub comparison: Comparison,
    /// The corrected model with the effect added.
    pub parameters: ParameterSet,
}

impl Hint {
    /// The effect's own parameters with their values (the refit of the others moves them
    /// only slightly and is left out).
    pub fn changes(&self, corrected: &ParameterSet) -> String {
        let reset = selection::without_effect(self.kind, &self.parameters, corrected);
        self.parameters
            .names()
            .filter(|name| reset.get(name) != self.parameters.get(name))
            .map(|name| format!("{name} = {:.4e}", self.parameters.value(name)))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// The parameter set a validation hands on, with what the data could not decide.
#[derive(Debug, Clone)]
pub struct KeptParameters {
    /// The corrected set, with the simpler law wherever the data cannot tell two apart.
    pub parameters: ParameterSet,
    /// One line per found effect replaced by a simpler law that reproduces it over the log:
    /// "X or Y: the data cannot tell; Y (n parameters) is kept, X's fit was: ...".
    pub cannot_tell: Vec<String>,
    /// One line per law with as many parameters or more that reproduces a found effect over the
    /// log, the found one (the simpler) kept: "X or Y: the data cannot tell; X (n parameters)
    /// is kept, Y's fit was: ...", so that a user of the corrected set sees the other reading.
    pub also_fits: Vec<String>,
}

impl Validation {
    /// The corrected parameters as a user should take them: where a found effect has an
    /// alternative with fewer parameters that reproduces it over this log ("X or Y: the data
    /// cannot tell"), the simpler law is kept and the found one listed, since the log supports
    /// no more than the simpler one. Without such an alternative it is the selection's corrected
    /// set.
    pub fn kept_parameters(&self) -> KeptParameters {
        let structure = self.data.structure;
        let corrected = &self.selection.corrected;
        let mut parameters = corrected.clone();
        let (mut cannot_tell, mut also_fits) = (Vec::new(), Vec::new());
        for found in &self.selection.found {
            let found_count = parameter_count(found.kind, structure);
            let alternatives = self.indistinct.iter().filter(|a| a.found == found.kind);
            let simplest = alternatives
                .clone()
                .filter(|a| parameter_count(a.alternative, structure) < found_count)
                .min_by_key(|a| parameter_count(a.alternative, structure));
            let Some(alternative) = simplest else {
                // The found effect is the simplest law that reproduces itself: it stays, and
                // every other reading is listed with its fit.
                for other in alternatives {
                    also_fits.push(cannot_tell_line(
                        found.kind,
                        other,
                        found.kind,
                        found_count,
                        &other.changes(corrected, &self.start),
                    ));
                }
                continue;
            };
            // The alternative's set is the corrected one with the alternative in place of the
            // found effect: what it changes is carried over (replacements of different found
            // effects touch different parameters, so they compose).
            for name in alternative.parameters.names() {
                if alternative.parameters.get(name) != corrected.get(name) {
                    parameters.set(name, alternative.parameters.value(name));
                }
            }
            let without = selection::without_effect(found.kind, corrected, &self.start);
            cannot_tell.push(cannot_tell_line(
                found.kind,
                alternative,
                alternative.alternative,
                parameter_count(alternative.alternative, structure),
                &observability::changes(corrected, &without),
            ));
        }
        KeptParameters { parameters, cannot_tell, also_fits }
    }

    /// Found effects that stand in for the form of the drive path rather than name a change
    /// of it: a stiffness (with its damping) found where the measured motor-to-load response
    /// departs from every two-mass path's ([`frequency::check_path`]). The two-mass
    /// stiffness is then an effective value for a path with a second mode (or a lost motion),
    /// and a change of the spring cannot be told from that model-form difference: the value
    /// stays in the corrected set, since it predicts the log better, but it is not claimed.
    ///
    /// A Stribeck change that is mostly a friction term even in the speed
    /// ([`observability::stribeck_or_even_friction`]) stands in the same way for the low-speed
    /// form of a direction-dependent friction, which the model's friction law does not have.
    pub fn model_form_stand_ins(&self) -> Vec<Kind> {
        let path_departs = self.path.as_ref().is_some_and(|p| p.departs);
        self.selection
            .found
            .iter()
            .map(|f| f.kind)
            .filter(|k| {
                (*k == Kind::Stiffness && path_departs) || (*k == Kind::Stribeck && self.even_friction.is_some())
            })
            .collect()
    }

    /// Index of the equation-error channel where the fit reduced the error most (relative):
    /// the equation the found effect shows in.
    pub fn most_improved_channel(&self) -> usize {
        (0..self.before.len())
            .min_by(|&a, &b| {
                (self.after[a].rms / self.before[a].rms).total_cmp(&(self.after[b].rms / self.before[b].rms))
            })
            .unwrap_or(0)
    }
}

/// "X or Y: the data cannot tell (what Y leaves of X ...); K (n parameters) is kept, D's fit
/// was ...", with X the found effect, Y its alternative, K the law kept and D the one dropped.
fn cannot_tell_line(
    found: Kind,
    alternative: &observability::Indistinct,
    kept: Kind,
    kept_count: usize,
    dropped_fit: &str,
) -> String {
    let dropped = if kept == found { alternative.alternative } else { found };
    format!(
        "{} or {}: the data cannot tell (what {} leaves of {} is {:.1} % RMS, chi-square {:.1}); {} ({} parameter{}) is kept, {}'s fit was {}",
        found.name(),
        alternative.alternative.name(),
        alternative.alternative.name(),
        found.name(),
        100.0 * alternative.misfit,
        alternative.chi2,
        kept.name(),
        kept_count,
        if kept_count == 1 { "" } else { "s" },
        dropped.name(),
        dropped_fit,
    )
}

/// The output error as the judge of the search: an effect is claimed only if the plant FMU
/// with it predicts the measured motion significantly better over the windows than without it
/// ([`output_error::compare`]), and a lower-ranked candidate replaces the equation error's
/// choice only if it predicts significantly better than that choice.
struct OutputJudge<'a> {
    simulator: &'a mut dyn PlantSimulator,
    data: &'a EquationData,
    out: &'a OutputData,
    plan: &'a WindowPlan,
    cache: Vec<(ParameterSet, OutputError)>,
    confirmations: Vec<(Kind, Comparison)>,
    alpha: f64,
}

impl OutputJudge<'_> {
    /// Compares the models `with` and `without` (the former paying for `parameters` more),
    /// records the comparison under `kind` (its reason prefixed by `context`), and returns it.
    fn compare_and_record(
        &mut self,
        kind: Kind,
        without: &ParameterSet,
        with: &ParameterSet,
        parameters: usize,
        context: Option<String>,
    ) -> Result<String, String> {
        let baseline = self.error_of(without).map_err(|e| format!("the model without it does not simulate: {e}"))?;
        let candidate = self.error_of(with).map_err(|e| format!("the model with it does not simulate: {e}"))?;
        let mut comparison = output_error::compare(&baseline, &candidate, parameters, self.alpha);
        if let Some(context) = context {
            comparison.reason = format!("{context}: {}", comparison.reason);
        }
        let result = if comparison.confirmed { Ok(comparison.reason.clone()) } else { Err(comparison.reason.clone()) };
        self.confirmations.push((kind, comparison));
        result
    }

    fn error_of(&mut self, params: &ParameterSet) -> Result<OutputError, SimulationError> {
        if let Some((_, e)) = self.cache.iter().find(|(p, _)| p == params) {
            return Ok(e.clone());
        }
        let e = output_error::output_error(self.simulator, params, self.data, self.out, self.plan)?;
        self.cache.push((params.clone(), e.clone()));
        Ok(e)
    }
}

impl selection::Judge for OutputJudge<'_> {
    fn confirm(&mut self, kind: Kind, without: &ParameterSet, with: &ParameterSet) -> Result<String, String> {
        self.compare_and_record(kind, without, with, parameter_count(kind, self.data.structure), None)
    }

    fn confirm_joint(
        &mut self,
        kinds: [Kind; 2],
        without: &ParameterSet,
        with: &ParameterSet,
    ) -> Result<String, String> {
        let parameters = kinds.iter().map(|k| parameter_count(*k, self.data.structure)).sum();
        let context = format!("jointly with {}, against the model before both", kinds[1].name());
        self.compare_and_record(kinds[0], without, with, parameters, Some(context))
    }

    fn prefers(&mut self, incumbent: &ParameterSet, challenger: &ParameterSet, extra: isize) -> bool {
        match (self.error_of(incumbent), self.error_of(challenger)) {
            (Ok(a), Ok(b)) => output_error::compare(&a, &b, extra.max(0) as usize, self.alpha).confirmed,
            _ => false,
        }
    }

    fn compares(&self) -> bool {
        true
    }
}

/// Validates a measured log against a starting parameter set with the equation-error route
/// only (no simulator).
pub fn validate(
    log: &MeasuredLog,
    start: &ParameterSet,
    options: &ValidateOptions,
) -> Result<Validation, ValidationError> {
    validate_with(log, start, options, None)
}

/// Validates a measured log against a starting parameter set. With a simulator (the plant
/// FMU), every effect must also be confirmed by the windowed output error, and the output
/// error before and after is reported; if the simulator cannot run the starting model, the
/// validation falls back to the equation error with a note.
///
/// With two encoders, the twist is checked after the search ([`twist`]): a significant timing
/// skew between the encoders is corrected in the data (the load encoder shifted back) and the
/// log validated once more, so the effects are found on consistent data.
pub fn validate_with(
    log: &MeasuredLog,
    start: &ParameterSet,
    options: &ValidateOptions,
    mut simulator: Option<&mut dyn PlantSimulator>,
) -> Result<Validation, ValidationError> {
    // A motor speed sensor without a motor encoder: the motor position is its integral, whose
    // slow drift is a nuisance of every fit (equation_error's slow-twist knots) and which every
    // parameter set's own twist centre follows in the output error.
    // A logged current command is turned into the current the motors carried first (the
    // current loop's lag from the parameter set), so that nothing downstream mistakes the lag
    // for a delay, a torque-constant or an inertia change.
    let from_command = log.with_current_from_command(start.value(parameters::names::CURRENT_LOOP_BANDWIDTH));
    let log = from_command.as_ref().unwrap_or(log);
    let integrated = log.with_motor_position_from_speed();
    let log = integrated.as_ref().unwrap_or(log);
    // The speed sensor's drift, integrated, is a motor-position error that wanders in time:
    // estimated on both torque equations beside every slow effect and taken out first, so the
    // search sees one constant twist offset instead of a free function of time beside every
    // effect ([`sensor_errors`]).
    let drift = match &integrated {
        Some(_) => tacho_drift(log, start, options)?,
        None => None,
    };
    let drift_corrected = drift.as_ref().map(|d| d.correct(log));
    let log = drift_corrected.as_ref().unwrap_or(log);
    // The load encoder's own error is found and taken out before any physical effect is
    // judged, or it would raise every residual and detection limit ([`sensor_errors`]).
    let prepared = equation_error::prepare(log, start, &options.equation)?;
    // What the sensors resolve is a fact of the log as logged: the corrections below
    // interpolate the signals, whose steps would then read as finer than the sensors'.
    let logged_resolution = prepared.notes.iter().find(|n| n.starts_with(equation_error::RESOLUTION_NOTE)).cloned();
    // Likewise its noise: a skew's correction shifts a signal by a fraction of a sample, and
    // the interpolation smooths its noise.
    let logged_noise = [prepared.torque_sigma, prepared.motor_pos_sigma, prepared.load_pos_sigma];
    let encoder_error = sensor_errors::load_encoder_error(&prepared, start, &options.twist);
    let encoder_corrected = encoder_error.as_ref().map(|e| e.correct(log));
    let log = encoder_corrected.as_ref().unwrap_or(log);
    // A current stamped late reads as a negative delay, which no drive has: a sensor skew,
    // corrected in the data before the search ([`band_delay::current_skew`]). The equations
    // are prepared again only if the encoder's correction changed the log.
    let prepared = match &encoder_corrected {
        Some(corrected) => equation_error::prepare(corrected, start, &options.equation)?,
        None => prepared,
    };
    let late_current = current_skew(&prepared, start, options);
    let skew_corrected = late_current.as_ref().map(|s| band_delay::shift_current(log, s.late()));
    let log = skew_corrected.as_ref().unwrap_or(log);
    let (mut observable, mut unobservable) = observable_candidates(log, options);
    if late_current.is_some() {
        observable.equation.logged_noise = Some(logged_noise);
    }
    if let Some(skew) = &late_current {
        unobservable.insert(
            0,
            format!(
                "{}; the current was shifted back by it before the search (a sensor skew, not an effect of the plant)",
                skew.describe()
            ),
        );
    }
    if let Some(drift) = &drift {
        unobservable.insert(
            0,
            format!(
                "{}; taken out of the integrated motor position before the search (a sensor error, not an effect of the plant)",
                drift.describe()
            ),
        );
    }
    if let Some(error) = &encoder_error {
        unobservable.insert(
            0,
            format!(
                "{}; taken out of the load encoder before the search (a sensor error, not an effect of the plant)",
                error.describe()
            ),
        );
    }
    let options = &observable;
    // The reborrow shortens the trait object's lifetime so the simulator can serve both passes.
    let reborrowed = simulator.as_mut().map(|s| &mut **s as &mut dyn PlantSimulator);
    let mut first = validate_once(log, start, options, reborrowed)?;
    first.load_encoder_error = encoder_error.clone();
    first.tacho_drift = drift.clone();
    first.current_skew = late_current.clone();
    first.notes.extend(unobservable.iter().cloned());
    keep_logged_resolution(&mut first.notes, logged_resolution.as_deref());
    // The encoders' timing skew is checked after the search, with the corrected model: a
    // check against the starting set took a delay the start lacks for a skew (a 20-times delay
    // on a coarse load encoder read as a 1.5 ms skew, which then hid the delay from the search).
    // The skew check regresses the twist on a constant offset, which an integrated motor
    // position's drift breaks: no skew is acted on then (its report still shows the terms).
    first.twist = twist::analyse(&first.data, &first.selection.corrected, &options.twist);
    let Some(skew) = first.twist.as_ref().and_then(|t| t.claimed_skew()).filter(|_| integrated.is_none()) else {
        return Ok(first);
    };
    let corrected_log = twist::shift_load_encoder(log, skew);
    let mut logged = options.clone();
    logged.equation.logged_noise = Some(logged_noise);
    let mut second = validate_once(&corrected_log, start, &logged, simulator)?;
    second.notes.push(skew_note(skew, second.data.dt));
    second.notes.extend(unobservable);
    keep_logged_resolution(&mut second.notes, logged_resolution.as_deref());
    second.twist = first.twist;
    second.encoder_skew = Some(skew);
    second.load_encoder_error = encoder_error;
    second.tacho_drift = drift;
    second.current_skew = late_current;
    Ok(second)
}

/// The report's note on an encoder skew taken out of the data.
fn skew_note(skew: f64, dt: f64) -> String {
    // A positive skew is a load angle older than the motor's in the same row.
    let (relation, read) = if skew >= 0.0 { ("behind", "earlier") } else { ("ahead of", "later") };
    format!(
        "each row holds the load encoder's angle {:.3} ms ({:.2} samples) {relation} the motor encoder's (a load encoder read that much {read} than the motor encoder and stamped alike): it was shifted back by that much and the log validated again; the results above are on the corrected data",
        skew.abs() * 1e3,
        skew.abs() / dt
    )
}

/// Puts the resolution note of the log as logged in place of the one computed on corrected
/// data (a shifted or corrected signal has interpolated steps).
fn keep_logged_resolution(notes: &mut [String], logged: Option<&str>) {
    let Some(logged) = logged else { return };
    for note in notes.iter_mut().filter(|n| n.starts_with(equation_error::RESOLUTION_NOTE)) {
        logged.clone_into(note);
    }
}

/// The integrated drift of the motor speed sensor in `log` (whose motor position was
/// integrated from it) with the starting set, when the log shows one
/// ([`sensor_errors::tacho_drift`]).
fn tacho_drift(
    log: &MeasuredLog,
    start: &ParameterSet,
    options: &ValidateOptions,
) -> Result<Option<sensor_errors::TachoDrift>, ValidationError> {
    let data = equation_error::prepare(log, start, &options.equation)?;
    Ok(sensor_errors::tacho_drift(&data, start, &options.twist))
}

/// A current stamped later than the encoders in the prepared `data`, when the band estimate of
/// the delay from the starting set shows one ([`band_delay::current_skew`]); only when the
/// delay is a candidate (the estimate is the delay's), at the search's level.
fn current_skew(
    data: &equation_error::EquationData,
    start: &ParameterSet,
    options: &ValidateOptions,
) -> Option<band_delay::CurrentSkew> {
    if !options.selection.candidates.contains(&Kind::Delay) {
        return None;
    }
    band_delay::current_skew(data, start, options.selection.alpha)
}

/// The options with the candidates a log's signals cannot observe taken out, and a note for
/// each: an effect the data cannot see is not a candidate, or it would be named for whatever
/// it happens to stand in for.
///
/// - A log of torque (not current) has no torque constant in it: a "torque-constant scale" is
///   then a scale of the logged torque, which only stands in for inertia or friction (0.51 on
///   a KUKA record).
/// - A linear axis has no angle: an unbalance periodic in the axis angle does not exist, and a
///   gravity force on an inclined axis is a constant, the offset (an offset of +370 N and an
///   "unbalance" of 374.5 N that cancelled on EMPS).
pub fn observable_candidates(log: &MeasuredLog, options: &ValidateOptions) -> (ValidateOptions, Vec<String>) {
    let mut options = options.clone();
    let mut notes = Vec::new();
    let mut drop = |kind: Kind, why: &str| {
        if options.selection.candidates.contains(&kind) {
            options.selection.candidates.retain(|k| *k != kind);
            notes.push(format!("{} is not a candidate: {why}", kind.name()));
        }
    };
    if !log.torque_from_current() {
        drop(Kind::TorqueConstant, "the log gives torque, not current, so it holds no torque constant to scale");
    }
    if log.is_linear() {
        drop(
            Kind::Unbalance,
            "the axis is linear (positions in metres): a force periodic in an axis angle does not exist, and gravity on an inclined axis is a constant force, the offset",
        );
    }
    (options, notes)
}

/// What the search found, with the output-error side when a simulator judged it.
struct Searched {
    selection: Selection,
    output: Option<OutputReport>,
    frequency: Option<frequency::FrequencyResponse>,
    path: Option<frequency::PathCheck>,
    hints: Vec<Hint>,
    delay_band: Option<band_delay::DelayAccount>,
}

/// One pass of [`validate_with`] on a log as it is.
fn validate_once(
    log: &MeasuredLog,
    start: &ParameterSet,
    options: &ValidateOptions,
    simulator: Option<&mut dyn PlantSimulator>,
) -> Result<Validation, ValidationError> {
    let data = equation_error::prepare(log, start, &options.equation)?;
    let mut notes = log.notes.clone();
    notes.extend(data.notes.iter().cloned());
    let searched = match simulator {
        None => equation_only(&data, start, options),
        Some(simulator) => match prepare_output(simulator, log, &data, start, options) {
            // A simulator that cannot run the starting model leaves the equation error; a NaN
            // in what it returned is not a reason to go on without it.
            Err(SimulationError::NonFinite(cause)) => return Err(SimulationError::NonFinite(cause).into()),
            Err(message) => {
                notes.push(format!(
                    "output error not available ({message}): effects are claimed on the equation error alone"
                ));
                equation_only(&data, start, options)
            }
            Ok(prepared) => search_with_output_error(simulator, &data, start, options, prepared)?,
        },
    };
    let Searched { mut selection, output, frequency, path, hints, delay_band } = searched;
    if let Some(account) = delay_band.as_ref().filter(|a| a.significant) {
        notes.push(account.finding());
    }
    if let Some(check) = &path {
        notes.push(check.describe());
        if check.departs && selection.found.iter().any(|f| f.kind == Kind::Stiffness) {
            notes.push(format!(
                "stiffness is not claimed: its change (path.stiffness {:.4e} against the start's {:.4e} N m/rad) is the two-mass model's effective value for a path the two-mass form does not describe (above); a change of the spring and that model-form difference cannot be told apart with this model, so the value is kept in the corrected set as a stand-in",
                selection.corrected.value(parameters::names::STIFFNESS),
                start.value(parameters::names::STIFFNESS)
            ));
        }
        // A backlash named where the measured path's spring alone is off stands for a
        // stiffness change as well; the reading is carried into the summary and the corrected
        // set as one the data cannot tell apart.
        let found = |kind: Kind| selection.found.iter().any(|f| f.kind == kind);
        if !found(Kind::Stiffness) {
            let named = found(Kind::Backlash).then_some(Kind::Backlash.name());
            if let Some(note) = check.spring_alone_note(options.twist.z_threshold, named) {
                if named.is_some() {
                    selection.mark_equally_consistent(Kind::Backlash, Kind::Stiffness, note.clone());
                }
                notes.push(note);
            }
        }
    }
    let indistinct = observability::indistinct(&data, start, &selection, &options.selection);
    let collinear = observability::collinear(&data, start, &selection);
    let even_friction = observability::stribeck_or_even_friction(&data, start, &selection, options.selection.alpha);
    if let Some(even) = &even_friction {
        notes.push(even.describe(&selection.corrected, start));
    }
    let before = channel_stats(&data, &selection.before, log);
    let after = channel_stats(&data, &selection.after, log);
    check_results(&selection, &before, &after, output.as_ref())?;
    Ok(Validation {
        data,
        selection,
        before,
        after,
        start: start.clone(),
        output,
        frequency,
        twist: None,
        encoder_skew: None,
        load_encoder_error: None,
        tacho_drift: None,
        current_skew: None,
        hints,
        indistinct,
        collinear,
        even_friction,
        delay_band,
        path,
        notes,
    })
}

/// The search on the equation error alone.
fn equation_only(data: &EquationData, start: &ParameterSet, options: &ValidateOptions) -> Searched {
    let selection = selection::select(data, start, &options.selection);
    let delay_band = delay_account(data, start, &selection, selection.steps.len(), options, None);
    Searched { selection, output: None, frequency: None, path: None, hints: Vec::new(), delay_band }
}

/// The output-error data, the window plan and the starting model's output error.
fn prepare_output(
    simulator: &mut dyn PlantSimulator,
    log: &MeasuredLog,
    data: &EquationData,
    start: &ParameterSet,
    options: &ValidateOptions,
) -> Result<(OutputData, WindowPlan, OutputError), SimulationError> {
    let out = OutputData::new(log, data, start)?;
    let mut plan = match options.output.window_seconds {
        Some(seconds) => {
            WindowPlan::new((seconds / out.dt).round() as usize + 1, out.len(), out.dt, format!("fixed at {seconds} s"))
        }
        None => output_error::choose_window(&out, options.output.window_correlation, options.output.minimum_windows),
    };
    let drive = match options.output.drive_window_seconds {
        Some(seconds) => Some(((seconds / out.dt).round() as usize + 1, format!("fixed at {seconds} s"))),
        None => output_error::drive_window(start, out.dt),
    };
    if let (Some((length, reason)), Structure::TwoMass) = (drive, data.structure) {
        plan = plan.with_drive_length(length, reason);
    }
    let before = output_error::output_error(simulator, start, data, &out, &plan)?;
    Ok((out, plan, before))
}

/// The search judged by the output error, the refit of the found effects on it, and the
/// effects the output error alone would confirm (hints).
fn search_with_output_error(
    simulator: &mut dyn PlantSimulator,
    data: &EquationData,
    start: &ParameterSet,
    options: &ValidateOptions,
    (out, plan, before): (OutputData, WindowPlan, OutputError),
) -> Result<Searched, ValidationError> {
    // The friction-form calibration: the presliding compliance of the friction, fitted once on
    // the output error and used in the "before" and "after" models alike (presliding.rs). The
    // starting model's own error is kept for the report.
    let calibration = if options.output.presliding {
        presliding::calibrate(simulator, data, &out, &plan, start, &before, options.output.alpha)
    } else {
        None
    };
    let (calibrated, before, starting) = match &calibration {
        Some(c) if c.kept => (presliding::with_displacement(start, c.displacement), c.error.clone(), Some(before)),
        _ => (start.clone(), before, None),
    };
    let start = &calibrated;
    let mut judge = OutputJudge {
        simulator: &mut *simulator,
        data,
        out: &out,
        plan: &plan,
        cache: vec![(start.clone(), before.clone())],
        confirmations: Vec::new(),
        alpha: options.output.alpha,
    };
    let mut selection = selection::select_judged(data, start, &options.selection, &mut judge);
    let OutputJudge { cache, confirmations, .. } = judge;
    let structure = data.structure;
    let mut after = match cache.iter().find(|(p, _)| *p == selection.corrected) {
        Some((_, e)) => e.clone(),
        None => output_error::output_error(simulator, &selection.corrected, data, &out, &plan)?,
    };
    // The found effects' parameters refitted on the output error: the model is used as a
    // simulation, so its parameters end where it predicts best. The equation error is then
    // reported at those parameters as they are.
    let kinds: Vec<Kind> = selection.found.iter().map(|f| f.kind).collect();
    let refitted = if options.output.refit {
        refit::refit(simulator, data, &out, &plan, start, &kinds, &selection.corrected, &after)
    } else {
        None
    };
    if let Some(r) = &refitted {
        selection.adopt(data, start, r.params.clone(), &kinds);
        after = r.error.clone();
    }
    // The families the start holds, re-estimated where the equation error finds the family in
    // the data and the simulation confirms the new value (reestimate.rs).
    let search_steps = selection.steps.len();
    let earlier: Vec<Kind> = selection.found.iter().map(|f| f.kind).collect();
    let mut confirmations = confirmations;
    let mut refit_after_reestimate = None;
    let mut recheck = None;
    if options.output.reestimate {
        let r = reestimate::reestimate(
            simulator,
            data,
            &out,
            &plan,
            start,
            &mut selection,
            &after,
            &options.selection,
            options.output.alpha,
        );
        confirmations.extend(r.confirmations);
        if r.changed {
            after = r.error;
            refit_after_reestimate = r.refit;
            if !earlier.is_empty() {
                let (checked, error) = recheck_after_reestimate(
                    simulator,
                    data,
                    (&out, &plan),
                    start,
                    &mut selection,
                    &earlier,
                    &after,
                    options,
                    &mut confirmations,
                )?;
                after = error;
                recheck = Some(checked);
            }
        }
    }
    // The band estimate of a delay the search did not claim, with the simulation's view of it;
    // claimed when it is beyond its model-form floor and the simulation confirms it.
    let mut delay_band =
        delay_account(data, start, &selection, search_steps, options, Some((simulator, &out, &plan, &after)));
    if let Some(account) = delay_band.as_mut() {
        if let Some((error, comparison)) =
            claim_band_delay(simulator, data, (&out, &plan), start, &mut selection, account)
        {
            confirmations.push((Kind::Delay, comparison));
            after = error;
        }
    }
    let overall = output_error::compare(
        &before,
        &after,
        selection.found.iter().map(|f| parameter_count(f.kind, structure)).sum(),
        options.output.alpha,
    );
    // The final verdict: a corrected model that does not predict the log significantly better
    // than the starting one supports none of the effects it holds, however each step judged
    // them (a sequence of small wins against ever-changing baselines can end where it began).
    let withdrawn = withdraw_without_improvement(&mut selection, start, &overall, options.output.alpha);
    if withdrawn.is_some() {
        after = before.clone();
    }
    let hints = output_hints(simulator, data, &out, &plan, &selection, search_steps, &after, options);
    if withdrawn.is_some() {
        delay_band = delay_account(data, start, &selection, search_steps, options, None);
    }
    let frequency = frequency::compare(data, &out, start, &selection.corrected);
    let path = frequency::check_path(data, &out, &selection.corrected, options.selection.alpha);
    let output = Some(OutputReport {
        config: out.config,
        plan,
        state_half_width: out.state_half_width,
        state_through_motor: out.state_through_motor,
        before,
        after,
        confirmations,
        overall,
        withdrawn,
        refit: refitted,
        refit_after_reestimate,
        recheck,
        calibration,
        starting,
    });
    Ok(Searched { selection, output, frequency, path, hints, delay_band })
}

/// The re-check of the effects found before a re-estimation: each kept one with the note of
/// its confirmation against the final model less it, each withdrawn one with the reason, and
/// the joint refit on the output error of what is left, when something was withdrawn and the
/// refit lowered the score.
#[derive(Debug, Clone)]
pub struct Recheck {
    pub kept: Vec<(Kind, String)>,
    pub withdrawn: Vec<(Kind, String)>,
    pub refit: Option<refit::Refit>,
}

/// The backward check once more after a re-estimation changed a family the start held: the
/// effects the search found (`earlier`) were each confirmed against a model that still had
/// the start's value, so one of them may have stood in for that value. Each is taken out in
/// turn with the re-estimated value in place, the others refitted, and the output error's
/// confirmation (signed-rank test and BIC gain) asked again ([`selection::recheck`], the
/// backward check's own code); what no longer confirms is withdrawn, and the effects left are
/// refitted together on the output error. Returns the outcome and the output error of the
/// model it ends with; the comparisons are added to `confirmations`, marked as the re-check's.
#[allow(clippy::too_many_arguments)]
fn recheck_after_reestimate(
    simulator: &mut dyn PlantSimulator,
    data: &EquationData,
    (out, plan): (&OutputData, &WindowPlan),
    start: &ParameterSet,
    selection: &mut Selection,
    earlier: &[Kind],
    after: &OutputError,
    options: &ValidateOptions,
    confirmations: &mut Vec<(Kind, Comparison)>,
) -> Result<(Recheck, OutputError), ValidationError> {
    let mut judge = OutputJudge {
        simulator: &mut *simulator,
        data,
        out,
        plan,
        cache: vec![(selection.corrected.clone(), after.clone())],
        confirmations: Vec::new(),
        alpha: options.output.alpha,
    };
    let checked = selection::recheck(data, start, selection, earlier, &options.selection, &mut judge);
    let OutputJudge { cache, confirmations: asked, .. } = judge;
    confirmations.extend(asked.into_iter().map(|(kind, mut c)| {
        c.reason = format!("re-check after the re-estimation: {}", c.reason);
        (kind, c)
    }));
    let mut recheck = Recheck { kept: checked.kept, withdrawn: checked.withdrawn, refit: None };
    if recheck.withdrawn.is_empty() {
        return Ok((recheck, after.clone()));
    }
    let mut error = match cache.iter().find(|(p, _)| *p == selection.corrected) {
        Some((_, e)) => e.clone(),
        None => output_error::output_error(simulator, &selection.corrected, data, out, plan)?,
    };
    let kinds: Vec<Kind> = selection.found.iter().map(|f| f.kind).collect();
    if options.output.refit && !kinds.is_empty() {
        if let Some(r) = refit::refit(simulator, data, out, plan, start, &kinds, &selection.corrected, &error) {
            selection.adopt(data, start, r.params.clone(), &kinds);
            error = r.error.clone();
            recheck.refit = Some(r);
        }
    }
    Ok((recheck, error))
}

/// Effects withdrawn by the final verdict.
#[derive(Debug, Clone)]
pub struct Withdrawal {
    pub kinds: Vec<Kind>,
    pub reason: String,
}

/// The final verdict: when the corrected model does not predict the log better than the
/// starting one (no likelihood gain over the windows, each with its own variance, or the
/// signed-rank test not significant at `alpha`; [`output_error::Comparison::improves`]),
/// every claim is withdrawn and the corrected model is the starting one. The likelihood gain,
/// as in the confirmations' BIC, so that one window whose open-loop simulation diverged
/// cannot overturn what every other window shows.
pub fn withdraw_without_improvement(
    selection: &mut Selection,
    start: &ParameterSet,
    overall: &Comparison,
    alpha: f64,
) -> Option<Withdrawal> {
    let improved = overall.improves(alpha);
    if selection.found.is_empty() || improved {
        return None;
    }
    let kinds: Vec<Kind> = selection.found.iter().map(|f| f.kind).collect();
    let reason = format!(
        "the corrected model does not predict the log better than the starting model ({}): no effect is supported",
        overall.reason
    );
    for kind in &kinds {
        selection.removed.push((*kind, reason.clone()));
    }
    selection.found.clear();
    selection.corrected = start.clone();
    selection.after = selection.before.clone();
    Some(Withdrawal { kinds, reason })
}

/// Hints: effects the equation-error test did not find significant (but at least the noise in
/// size) that the output error alone would confirm on top of the corrected model. Not claimed:
/// the equation error's test failed, typically for want of independent samples in a short or
/// slow log.
#[allow(clippy::too_many_arguments)]
fn output_hints(
    simulator: &mut dyn PlantSimulator,
    data: &EquationData,
    out: &OutputData,
    plan: &WindowPlan,
    selection: &Selection,
    search_steps: usize,
    after: &OutputError,
    options: &ValidateOptions,
) -> Vec<Hint> {
    let mut hints = Vec::new();
    // The last step of the search proper (the re-estimation's steps test other things).
    let Some(last) = selection.steps[..search_steps.min(selection.steps.len())].last() else { return hints };
    let accepted: Vec<Kind> = selection.found.iter().map(|f| f.kind).collect();
    for score in &last.scores {
        if score.not_applicable.is_some()
            || score.significant
            || accepted.contains(&score.kind)
            || score.effect_to_noise < options.selection.min_effect_to_noise
        {
            continue;
        }
        let Ok(with) = selection::fit_candidate(data, &selection.corrected, &accepted, score.kind, &options.selection)
        else {
            continue;
        };
        let Ok(candidate) = output_error::output_error(simulator, &with, data, out, plan) else {
            continue;
        };
        let comparison =
            output_error::compare(after, &candidate, parameter_count(score.kind, data.structure), options.output.alpha);
        if comparison.confirmed {
            hints.push(Hint {
                kind: score.kind,
                equation_p: score.p_value,
                threshold: last.threshold,
                comparison,
                parameters: with,
            });
        }
    }
    hints
}

/// The band estimate of the delay ([`band_delay`]) when delay is a candidate and the search
/// claimed none, tested at the level of the search's last step. A significant, admissible
/// delay is put to the simulation when there is one: the corrected model with it, and with
/// twice its change, against the corrected model (`after`), which gives the verdict and the
/// simulation's resolution for a delay.
fn delay_account(
    data: &EquationData,
    start: &ParameterSet,
    selection: &Selection,
    search_steps: usize,
    options: &ValidateOptions,
    simulation: Option<(&mut dyn PlantSimulator, &OutputData, &WindowPlan, &OutputError)>,
) -> Option<band_delay::DelayAccount> {
    if !options.selection.candidates.contains(&Kind::Delay) {
        return None;
    }
    if selection.found.iter().any(|f| f.kind == Kind::Delay) {
        // A claimed delay: the band estimate of the same log from the start's delay, beside it.
        // From the start's delay the band's Gauss-Newton finds the nearest minimum; a delay of
        // milliseconds turns the upper bins by cycles, and that minimum is then its wrapped
        // remainder (-0.88 ms for an 8 ms delay on a log with clean encoders, whose weight lies
        // at 60-230 Hz). The estimate then starts again from the band's own best delay over
        // the search's range, which is still independent of what the search claimed.
        let mut from_start = selection.corrected.clone();
        from_start.set(parameters::names::DELAY, start.value(parameters::names::DELAY));
        let mut estimate = band_delay::estimate(data, &from_start)?;
        if let Some(better) = estimate.beaten_by {
            from_start.set(parameters::names::DELAY, better);
            if let Some(again) = band_delay::estimate(data, &from_start) {
                estimate = again;
            }
        }
        let claimed = Some(selection.corrected.value(parameters::names::DELAY));
        return Some(band_delay::DelayAccount {
            estimate,
            threshold: f64::NAN,
            significant: false,
            simulation: None,
            claimed,
            from_band: false,
        });
    }
    let threshold = selection.steps[..search_steps.min(selection.steps.len())]
        .last()
        .map_or(options.selection.alpha, |s| s.threshold);
    let estimate = band_delay::estimate(data, &selection.corrected)?;
    let significant = estimate.significant(threshold);
    let mut account = band_delay::DelayAccount {
        estimate,
        threshold,
        significant,
        simulation: None,
        claimed: None,
        from_band: false,
    };
    let change = account.estimate.change;
    if let (true, Some((simulator, out, plan, after))) = (significant && account.estimate.delay() >= 0.0, simulation) {
        let with_change = |c: f64| {
            let mut p = selection.corrected.clone();
            p.set(parameters::names::DELAY, account.estimate.start + c);
            p
        };
        let once = output_error::output_error(simulator, &with_change(change), data, out, plan);
        let twice = output_error::output_error(simulator, &with_change(2.0 * change), data, out, plan);
        if let (Ok(once), Ok(twice)) = (once, twice) {
            let comparison = output_error::compare(after, &once, 1, options.output.alpha);
            let twice_score = output_error::compare(after, &twice, 1, options.output.alpha).score_after;
            account.simulation = Some(band_delay::SimulationView::new(comparison, twice_score, change));
        }
    }
    Some(account)
}

/// A delay claimed from the band estimate ([`band_delay`]): the search's delay test works on
/// the smoothed balance, where a sub-millisecond delay turns the torque by less than its
/// noise, so it cannot find one the unsmoothed band resolves. The band's delay is claimed when
/// the estimate is significant beyond its model-form floor (the spread between the band's
/// halves, which a model error reading as a delay shows and a delay does not) at the search's
/// last p threshold, and the simulation confirmed the corrected model with it (signed-rank
/// test and BIC gain, as every claim), and adopted as a found effect at the band's value.
/// Returns the model's output error and its confirmation.
fn claim_band_delay(
    simulator: &mut dyn PlantSimulator,
    data: &EquationData,
    (out, plan): (&OutputData, &WindowPlan),
    start: &ParameterSet,
    selection: &mut Selection,
    account: &mut band_delay::DelayAccount,
) -> Option<(OutputError, Comparison)> {
    let view = account.simulation.as_ref()?;
    let estimate = &account.estimate;
    if account.claimed.is_some()
        || !view.comparison.confirmed
        || estimate.delay() < 0.0
        || !estimate.significant_beyond_floor(account.threshold)
    {
        return None;
    }
    let comparison = view.comparison.clone();
    let mut params = selection.corrected.clone();
    params.set(parameters::names::DELAY, estimate.delay());
    // Not refitted on the output error: the band resolves the delay far more finely than the
    // simulation does (0.002 ms against a resolution of 0.2-0.4 ms on 30 s logs at 1 and
    // 2 kHz), and a refit would move it within the simulation's own noise (1.009 ms, true
    // 1.0, went to 0.904 ms).
    let error = output_error::output_error(simulator, &params, data, out, plan).ok()?;
    let mut kinds: Vec<Kind> = selection.found.iter().map(|f| f.kind).collect();
    kinds.push(Kind::Delay);
    account.claimed = Some(params.value(parameters::names::DELAY));
    account.from_band = true;
    selection.adopt(data, start, params, &kinds);
    Some((error, comparison))
}

/// The results a report states must be numbers: the corrected parameters, the equation
/// error's RMS before and after, every applicable candidate's test statistic, and the output
/// error's RMS of every channel before and after.
fn check_results(
    selection: &Selection,
    before: &[ChannelStats],
    after: &[ChannelStats],
    output: Option<&OutputReport>,
) -> Result<(), NonFinite> {
    finite::check_parameters(&selection.corrected)?;
    for (label, stats) in [("of the starting model", before), ("of the corrected model", after)] {
        for channel in stats {
            finite::check_value(&format!("the RMS of the {} residual", channel.name), channel.rms, label)?;
        }
    }
    for (index, step) in selection.steps.iter().enumerate() {
        for score in step.scores.iter().filter(|s| s.not_applicable.is_none()) {
            finite::check_value(
                &format!("the equation-error test statistic of {}", score.kind.name()),
                score.likelihood_ratio,
                &format!("at search step {}", index + 1),
            )?;
        }
    }
    if let Some(o) = output {
        for (label, error) in [("of the starting model", &o.before), ("of the corrected model", &o.after)] {
            for channel in &error.channels {
                finite::check_value(
                    &format!("the output error's RMS of the {}", channel.kind.name()),
                    channel.rms,
                    label,
                )?;
            }
        }
    }
    Ok(())
}

/// Residual statistics of a fit, per channel.
pub fn channel_stats(data: &EquationData, fit: &Fit, log: &MeasuredLog) -> Vec<ChannelStats> {
    let decimation = 2 * data.half_width + 1;
    let inputs = input_signals(data, log);
    fit.channels
        .iter()
        .enumerate()
        .map(|(c, channel)| {
            let used: Vec<f64> =
                fit.residual[c].iter().zip(&channel.mask).filter(|(_, m)| **m).map(|(r, _)| *r).collect();
            let measured: Vec<f64> =
                channel.measured.iter().zip(&channel.mask).filter(|(_, m)| **m).map(|(v, _)| *v).collect();
            // Decimate to about one sample per filter length: the smoothing correlates
            // neighbouring residual samples even when the model is right.
            let decimated: Vec<f64> = fit.residual[c].iter().step_by(decimation).copied().collect();
            let lags = 20.min(decimated.len() / 4).max(1);
            let (whiteness_p, lags_outside) = match antenna_dsp::whiteness_test(&decimated, lags, 0) {
                Ok(test) => (test.p_value, test.fraction_outside),
                Err(_) => (f64::NAN, f64::NAN),
            };
            let max_lag = ((1.0 / (data.dt * decimation as f64)).round() as usize)
                .clamp(1, decimated.len().saturating_sub(1).max(1));
            let cross_correlation = inputs
                .iter()
                .filter_map(|(name, x)| {
                    let xd: Vec<f64> = x.iter().step_by(decimation).copied().collect();
                    let cc = antenna_dsp::cross_correlation(
                        &xd[..xd.len().min(decimated.len())],
                        &decimated[..xd.len().min(decimated.len())],
                        max_lag,
                    )
                    .ok()?;
                    let (lag, value) = cc.peak();
                    Some((name.clone(), value, lag as f64 * data.dt * decimation as f64))
                })
                .collect();
            ChannelStats {
                name: channel.name.to_string(),
                rms: antenna_dsp::rms(&used),
                fit_percent: antenna_dsp::fit_percent_from_residual(&measured, &used),
                correlation_time: fit.tau[c],
                whiteness_p,
                lags_outside,
                cross_correlation,
                cross_bound: antenna_dsp::whiteness_bound(decimated.len(), 0.95),
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
    for (signal, name) in
        [(Signal::RefPos, "position command"), (Signal::WindSpeed, "wind speed"), (Signal::Elevation, "elevation")]
    {
        if let Some(values) = log.signal(signal) {
            if values.len() >= start + n {
                inputs.push((name.to_string(), values[start..start + n].to_vec()));
            }
        }
    }
    inputs
}
