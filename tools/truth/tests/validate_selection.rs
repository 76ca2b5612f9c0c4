//! Tests of `antenna_validate::selection` against logs of the truth simulation (which depends on
//! the validation crate, so they live here).

use antenna_truth::{simulate, Effect, TruthConfig};
use antenna_validate::candidates::Kind;
use antenna_validate::equation_error::{prepare, EquationOptions};
use antenna_validate::parameters::ParameterSet;
use antenna_validate::selection::*;

fn run(effects: Vec<Effect>, seed: u64) -> (Selection, ParameterSet) {
    let config = TruthConfig { duration: 30.0, effects, seed, ..TruthConfig::default() };
    let start = config.plant.starting_parameters();
    let log = simulate(&config).log;
    let data = prepare(&log, &start, &EquationOptions::default()).unwrap();
    (select(&data, &start, &SelectionOptions::default()), start)
}

#[test]
fn clean_data_gives_no_significant_missing_effect() {
    let (selection, start) = run(vec![], 5);
    assert!(selection.found.is_empty(), "claimed {:?}", selection.found.iter().map(|f| f.kind).collect::<Vec<_>>());
    assert_eq!(selection.corrected, start);
}

#[test]
fn a_large_unbalance_is_named_and_fitted() {
    let (selection, _) = run(vec![Effect::Unbalance { amplitude: 3000.0, phase: 0.4 }], 6);
    assert_eq!(selection.found.first().map(|f| f.kind), Some(Kind::Unbalance));
    let amplitude = selection.corrected.value(antenna_validate::parameters::names::UNBALANCE_TORQUE);
    assert!((amplitude / 3000.0 - 1.0).abs() < 0.1, "{amplitude}");
    let (before, after) = (selection.before.sigma[1], selection.after.sigma[1]);
    assert!(after < 0.2 * before, "load-equation RMS {before} -> {after}");
}

/// A judge that confirms every effect and never finds one model better than another: the
/// data cannot separate any two confirmed candidates.
struct Undecided;

impl Judge for Undecided {
    fn confirm(&mut self, _: Kind, _: &ParameterSet, _: &ParameterSet) -> Result<String, String> {
        Ok(String::new())
    }
    fn compares(&self) -> bool {
        true
    }
}

#[test]
fn confirmed_candidates_the_chosen_effect_does_not_beat_are_reported_as_equally_consistent() {
    let config = TruthConfig {
        duration: 30.0,
        effects: vec![Effect::Unbalance { amplitude: 3000.0, phase: 0.4 }],
        seed: 6,
        ..TruthConfig::default()
    };
    let start = config.plant.starting_parameters();
    let data = prepare(&simulate(&config).log, &start, &EquationOptions::default()).unwrap();
    let options = SelectionOptions { max_effects: 1, ..SelectionOptions::default() };
    let undecided = select_judged(&data, &start, &options, &mut Undecided);
    let chosen = undecided.steps[0].chosen.expect("an effect is chosen");
    let significant: Vec<Kind> = undecided.steps[0]
        .scores
        .iter()
        .filter(|s| s.confirmation.is_some() && s.kind != chosen)
        .map(|s| s.kind)
        .collect();
    assert!(!significant.is_empty(), "the test needs a second confirmed candidate");
    let mut alike = undecided.equally_consistent(chosen);
    alike.sort_by_key(|k| k.name());
    let mut significant = significant;
    significant.sort_by_key(|k| k.name());
    assert_eq!(alike, significant);
    // A judge that stops at the first confirmed candidate compares nothing and claims no
    // ambiguity.
    let first_only = select_judged(&data, &start, &options, &mut EquationOnly);
    assert!(first_only.steps.iter().all(|s| s.equally_consistent.is_empty()));
}

/// A short clean truth log and its starting parameter set.
fn clean_case() -> (antenna_validate::measured_log::MeasuredLog, ParameterSet) {
    let config = TruthConfig { duration: 10.0, seed: 5, ..TruthConfig::default() };
    (simulate(&config).log, config.plant.starting_parameters())
}

#[test]
fn a_nan_in_the_log_is_an_error_naming_the_column_and_sample() {
    use antenna_validate::finite::NonFinite;
    use antenna_validate::{equation_error::PrepareError, validate_with, ValidateOptions, ValidationError};
    let (mut log, start) = clean_case();
    log.channels[1].values[300] = f64::NAN;
    let column = log.channels[1].column.clone();
    let error = validate_with(&log, &start, &ValidateOptions::default(), None).unwrap_err();
    assert!(
        matches!(&error, ValidationError::Prepare(PrepareError::NonFinite(NonFinite::Signal { signal, sample: 300, .. }))
            if signal.contains(&column)),
        "{error:?}"
    );
    assert!(error.to_string().contains("is NaN at sample 300"), "{error}");
}

#[test]
fn a_nan_parameter_is_an_error_naming_it() {
    use antenna_validate::finite::NonFinite;
    use antenna_validate::parameters::names;
    use antenna_validate::{equation_error::PrepareError, validate_with, ValidateOptions, ValidationError};
    let (log, mut start) = clean_case();
    start.set(names::VISCOUS, f64::NAN);
    let error = validate_with(&log, &start, &ValidateOptions::default(), None).unwrap_err();
    assert!(
        matches!(&error, ValidationError::Prepare(PrepareError::NonFinite(NonFinite::Parameter { name, value }))
            if name == names::VISCOUS && value.is_nan()),
        "{error:?}"
    );
    assert_eq!(error.to_string(), format!("parameter {} is NaN", names::VISCOUS));
}

#[test]
fn a_nan_in_the_equation_error_is_an_error_naming_its_cause() {
    // Finite inputs whose product overflows: the motor inertia referred to the axis (J N^2) is
    // infinite, and so is the model side of the motor equation. Before, the NaN residual made
    // every test "not significant" and the run reported "no significant missing effect".
    use antenna_validate::finite::NonFinite;
    use antenna_validate::parameters::names;
    use antenna_validate::{equation_error::PrepareError, validate_with, ValidateOptions, ValidationError};
    let (log, mut start) = clean_case();
    start.set(names::MOTOR_INERTIA, 1e307);
    let error = validate_with(&log, &start, &ValidateOptions::default(), None).unwrap_err();
    assert!(
        matches!(&error, ValidationError::Prepare(PrepareError::NonFinite(NonFinite::Result { quantity, location, .. }))
            if quantity.contains("model side of the motor torque balance") && location.contains("analysed sample")),
        "{error:?}"
    );
}

#[test]
fn a_residual_that_overflows_is_an_error_not_a_result() {
    // Every input and every model-side value finite, but the squares of the residual overflow:
    // the RMS would be infinite, and the report would print it as a result.
    use antenna_validate::finite::NonFinite;
    use antenna_validate::parameters::names;
    use antenna_validate::{validate_with, ValidateOptions, ValidationError};
    let (log, mut start) = clean_case();
    start.set(names::UNBALANCE_TORQUE, 1e200);
    let error = validate_with(&log, &start, &ValidateOptions::default(), None).unwrap_err();
    assert!(matches!(&error, ValidationError::NonFinite(NonFinite::Result { .. })), "{error:?}");
    assert!(error.to_string().contains("torque balance"), "{error}");
}

/// A clean truth log with a load-encoder error added to its load encoder: `e(q)` of the given
/// RMS (rad) from harmonics 1, 2, 4, 8, 16 and 36 per turn.
fn with_encoder_error(rms: f64, seed: u64) -> (antenna_validate::measured_log::MeasuredLog, ParameterSet, Vec<f64>) {
    use antenna_validate::measured_log::Signal;
    let config = TruthConfig { duration: 30.0, seed, ..TruthConfig::default() };
    let start = config.plant.starting_parameters();
    let mut log = simulate(&config).log;
    let error = |q: f64| {
        [(1.0, 0.9, 0.3), (2.0, 0.6, 1.1), (4.0, 0.8, 2.0), (8.0, 0.5, 0.4), (16.0, 0.7, 2.9), (36.0, 0.9, 1.7)]
            .iter()
            .map(|(k, a, p)| a * (k * q + p).sin())
            .sum::<f64>()
    };
    let channel = log.channels.iter_mut().find(|c| c.signal == Signal::LoadPos).unwrap();
    let raw: Vec<f64> = channel.values.iter().map(|&q| error(q)).collect();
    let mean = raw.iter().sum::<f64>() / raw.len() as f64;
    let scale = rms / (raw.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / raw.len() as f64).sqrt();
    let added: Vec<f64> = raw.iter().map(|e| e * scale).collect();
    for (q, e) in channel.values.iter_mut().zip(&added) {
        *q += e;
    }
    (log, start, added)
}

#[test]
fn a_load_encoder_error_is_found_and_taken_out_before_the_search() {
    use antenna_validate::sensor_errors::load_encoder_error;
    use antenna_validate::twist::TwistOptions;
    let arcsec = std::f64::consts::PI / (180.0 * 3600.0);
    let (log, start, added) = with_encoder_error(5.0 * arcsec, 8);
    let data = prepare(&log, &start, &EquationOptions::default()).unwrap();
    let error = load_encoder_error(&data, &start, &TwistOptions::default()).expect("a 5 arcsec encoder error is found");
    // What is left of the injected error after the correction, over the logged angles (the
    // constant part is the encoders' zero offset, which the twist offset takes).
    let load = log.signal(antenna_validate::measured_log::Signal::LoadPos).unwrap();
    let left: Vec<f64> = load.iter().zip(&added).map(|(q, e)| e - error.at(*q)).collect();
    let mean = left.iter().sum::<f64>() / left.len() as f64;
    let left_rms = (left.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / left.len() as f64).sqrt();
    assert!(left_rms < 0.1 * 5.0 * arcsec, "{:.3} arcsec of 5 left", left_rms / arcsec);
    // The search on the corrected log is back at the clean log's residual.
    let corrected = prepare(&error.correct(&log), &start, &EquationOptions::default()).unwrap();
    let selection = select(&corrected, &start, &SelectionOptions::default());
    assert!(selection.found.is_empty(), "claimed {:?}", selection.found.iter().map(|f| f.kind).collect::<Vec<_>>());
    let (clean_log, _, _) = with_encoder_error(0.0, 8);
    let clean = prepare(&clean_log, &start, &EquationOptions::default()).unwrap();
    assert_eq!(load_encoder_error(&clean, &start, &TwistOptions::default()), None, "no encoder error on a clean log");
    let clean_selection = select(&clean, &start, &SelectionOptions::default());
    for channel in 0..2 {
        let (after, reference) = (selection.before.sigma[channel], clean_selection.before.sigma[channel]);
        assert!(after < 1.2 * reference, "channel {channel}: {after} against the clean log's {reference}");
    }
}

/// Two effects whose columns overlap over the trajectory, a Coulomb change (sign of the speed)
/// and an unbalance (cosine of the angle, near its extremum over the stroke), each at 10 times
/// the noise: both are named, nothing else, each within 10 % of its true size, through the
/// whole validation with the plant FMU as the judge. Neither may absorb the other: the
/// candidates are tested given the joint fit of what is already accepted, and the found ones
/// are refitted together. The packaged FMU must exist (`cargo xtask package`).
#[test]
fn an_overlapping_coulomb_and_unbalance_pair_are_both_named_within_ten_percent() {
    use antenna_truth::scoring::score;
    use antenna_truth::suite::{generate_case, SuiteConfig};
    use antenna_validate::measured_log::parse_str;
    use antenna_validate::plant_fmu::{FmuSimulator, PlantFmu};
    use antenna_validate::{validate_with, ValidateOptions};

    let base = TruthConfig { duration: 30.0, ..SuiteConfig::default().base };
    let kinds = vec![("coulomb".to_string(), 10.0), ("unbalance".to_string(), 10.0)];
    let (text, truth) = generate_case(&base, 12, &kinds, "pair.csv", &mut std::collections::BTreeMap::new()).unwrap();
    let log = parse_str(&text).unwrap();
    let start = base.plant.starting_parameters();
    let mut simulator = FmuSimulator::open(&PlantFmu::default_path()).unwrap_or_else(|e| panic!("{e}"));
    let validation = validate_with(&log, &start, &ValidateOptions::default(), Some(&mut simulator)).unwrap();
    let result = score(&truth, &validation, &start, 0.0);
    assert!(result.named, "found {:?}", result.found);
    assert!(result.extras.is_empty(), "extra effects {:?}", result.extras);
    assert!(result.parameters.iter().all(|p| p.4), "parameters out of tolerance: {:?}", result.parameters);
    // The two were estimated jointly: each found effect carries its correlation with the other.
    for found in &validation.selection.found {
        assert_eq!(found.correlations.len(), 1, "{:?}", found.correlations);
        assert!(found.correlations[0].1.abs() <= 1.0);
    }
}

/// A 15 s log at 1 kHz with a noiseless current sensor (1 mA steps), the current read
/// `skew` seconds after the encoders: the same physics as a delay of the applied torque.
fn noiseless_current_log(skew: f64, seed: u64) -> (antenna_validate::measured_log::MeasuredLog, ParameterSet) {
    let mut config = TruthConfig { duration: 15.0, seed, log_rate: 1000.0, ..TruthConfig::default() };
    config.noise.current_sigma = 0.0;
    config.noise.current_skew = skew;
    (simulate(&config).log, config.plant.starting_parameters())
}

#[test]
fn a_fractional_sample_delay_of_a_noiseless_current_is_found_over_the_unsmoothed_band() {
    use antenna_validate::{validate, ValidateOptions};
    let dt = 1e-3;
    let (log, start) = noiseless_current_log(0.3 * dt, 11);
    let v = validate(&log, &start, &ValidateOptions::default()).unwrap();
    // The truth holds the applied torque over each internal step at the current of the step's
    // start: behind the current by half a step on average, a delay of its own.
    let truth_lag = 0.5 / TruthConfig::default().internal_rate;
    let delay = 0.3 * dt + truth_lag;
    // The smoothed search cannot claim a third of a sample; the band estimate finds it.
    let found = v.selection.found.iter().find(|f| f.kind == Kind::Delay);
    let account = v.delay_band.as_ref().expect("delay is a candidate, so the band estimate runs");
    if found.is_none() {
        assert!(account.significant, "{account:?}");
        let (estimate, sigma) = (account.estimate.delay(), account.estimate.sigma);
        assert!(
            (estimate - delay).abs() < (0.1 * delay).max(2.0 * sigma),
            "{estimate:e} +- {sigma:e} s against {delay:e} s"
        );
        assert!(sigma < 0.1 * dt, "the estimate resolves a tenth of a sample: sigma {sigma:e} s");
        assert!(v.notes.iter().any(|n| n.contains("band estimate")), "the summary accounts for it: {:?}", v.notes);
    }
    // The same log without the skew: no delay claimed, and the band estimate has no floor of
    // its own beyond the truth's half-step lag (the presliding segments, which read as a
    // negative delay of up to 0.13 ms, are left out, and the friction curve's slope is in the
    // model).
    let (clean, start) = noiseless_current_log(0.0, 11);
    let v = validate(&clean, &start, &ValidateOptions::default()).unwrap();
    assert!(v.selection.found.iter().all(|f| f.kind != Kind::Delay));
    let account = v.delay_band.as_ref().expect("the band estimate runs");
    let (estimate, sigma) = (account.estimate.delay(), account.estimate.sigma);
    assert!(
        (estimate - truth_lag).abs() < 0.2 * truth_lag + 3.0 * sigma,
        "{estimate:e} +- {sigma:e} s against {truth_lag:e} s"
    );
}

/// A 60 s log at 2 kHz with a noiseless current (1 mA steps) and `effects`, on seed 49, whose
/// slowest motion runs mostly in the positive direction (tracking).
fn tracking_log(effects: Vec<Effect>) -> (antenna_validate::measured_log::MeasuredLog, ParameterSet) {
    let mut config = TruthConfig { seed: 49, log_rate: 2000.0, effects, ..TruthConfig::default() };
    config.noise.current_sigma = 0.0;
    (simulate(&config).log, config.plant.starting_parameters())
}

#[test]
fn a_hump_fitted_to_an_asymmetry_that_fades_at_low_speed_is_a_stand_in_not_a_stribeck_claim() {
    use antenna_validate::{validate, ValidateOptions};
    // The truth's asymmetry fades below a tenth of the Stribeck velocity: beside the offset it
    // leaves a remainder even in the speed, which the slow motion in one direction reads as a
    // lower hump.
    let (log, start) = tracking_log(vec![Effect::Asymmetry(330.0)]);
    let v = validate(&log, &start, &ValidateOptions::default()).unwrap();
    assert!(v.selection.found.iter().any(|f| f.kind == Kind::Offset), "{:?}", v.selection.found);
    // The hump is found beside the offset and reported as the stand-in it is, not left out.
    assert!(v.even_friction.is_some(), "no even friction term reported: {:?}", v.selection.found);
    let claimed_stribeck =
        v.selection.found.iter().any(|f| f.kind == Kind::Stribeck && !v.model_form_stand_ins().contains(&f.kind));
    assert!(!claimed_stribeck, "a Stribeck change claimed: {:?}", v.notes);
    // A real Stribeck change on the same motion is odd in the speed and is claimed.
    let (log, start) = tracking_log(vec![Effect::Stribeck(600.0)]);
    let v = validate(&log, &start, &ValidateOptions::default()).unwrap();
    assert!(v.selection.found.iter().any(|f| f.kind == Kind::Stribeck), "{:?}", v.selection.found);
    assert!(v.even_friction.is_none(), "{:?}", v.even_friction);
}
