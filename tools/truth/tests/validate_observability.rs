//! Tests of what `validate` says a log cannot carry: the final "no improvement" verdict, the
//! candidates a log's signals cannot observe, the effects a log's range cannot tell apart, the
//! state a coarse load encoder cannot give, and the variants of the truth generator that
//! exercise them.

use antenna_truth::{simulate, CurrentLog, Effect, TruthConfig};
use antenna_validate::candidates::Kind;
use antenna_validate::equation_error::{prepare, EquationOptions};
use antenna_validate::measured_log::{parse_str, Signal};
use antenna_validate::output_error::OutputData;
use antenna_validate::parameters::names;
use antenna_validate::selection::{select, SelectionOptions};
use antenna_validate::{observability, observable_candidates, withdraw_without_improvement, ValidateOptions};

#[test]
fn a_final_verdict_of_no_improvement_withdraws_every_claim() {
    let config = TruthConfig {
        duration: 30.0,
        effects: vec![Effect::Unbalance { amplitude: 3000.0, phase: 0.4 }],
        seed: 6,
        ..TruthConfig::default()
    };
    let start = config.plant.starting_parameters();
    let data = prepare(&simulate(&config).log, &start, &EquationOptions::default()).unwrap();
    let selection = select(&data, &start, &SelectionOptions::default());
    assert!(!selection.found.is_empty());
    // The verdict on the clean log: 1.006 of the starting model's score, p = 1.
    let mut not_better = antenna_validate::output_error::Comparison {
        windows: 50,
        better: 20,
        alike: 0,
        rank_sum: 300.0,
        p_value: 1.0,
        score_before: 1.0,
        score_after: 1.006,
        log_likelihood_gain: -0.3,
        bic_gain: -0.3,
        confirmed: false,
        reason: "output error 1.000 -> 1.006 of the baseline".into(),
    };
    let mut withdrawn = selection.clone();
    let withdrawal = withdraw_without_improvement(&mut withdrawn, &start, &not_better, 0.01).expect("withdrawn");
    assert!(withdrawn.found.is_empty());
    assert_eq!(withdrawn.corrected, start);
    assert_eq!(withdrawal.kinds, selection.found.iter().map(|f| f.kind).collect::<Vec<_>>());
    assert!(withdrawn.removed.iter().any(|(_, why)| why.contains("does not predict the log better")));
    // Better but not significantly so is no improvement either; a significant improvement
    // keeps the claims.
    not_better.score_after = 0.9;
    not_better.log_likelihood_gain = 5.0;
    not_better.p_value = 0.2;
    assert!(withdraw_without_improvement(&mut selection.clone(), &start, &not_better, 0.01).is_some());
    not_better.p_value = 1e-6;
    let mut kept = selection.clone();
    assert!(withdraw_without_improvement(&mut kept, &start, &not_better, 0.01).is_none());
    assert_eq!(kept.corrected, selection.corrected);
    // The verdict is on the likelihood gain over the windows, not on the mean score, which one
    // window whose simulation diverged can carry: a mean above the start's with a gain keeps
    // the claims, a mean below it without one withdraws them.
    not_better.score_after = 3.0;
    assert!(withdraw_without_improvement(&mut selection.clone(), &start, &not_better, 0.01).is_none());
    not_better.score_after = 0.9;
    not_better.log_likelihood_gain = -1.0;
    assert!(withdraw_without_improvement(&mut selection.clone(), &start, &not_better, 0.01).is_some());
}

#[test]
fn effects_a_log_cannot_observe_are_not_candidates() {
    let options = ValidateOptions::default();
    let torque_log = parse_str("time_s,motor_torque_Nm,load_pos_deg\n0,1,0\n1,1,0\n").unwrap();
    let (searched, notes) = observable_candidates(&torque_log, &options);
    assert!(!searched.selection.candidates.contains(&Kind::TorqueConstant));
    assert!(searched.selection.candidates.contains(&Kind::Unbalance));
    assert!(notes.iter().any(|n| n.contains("torque_constant")), "{notes:?}");
    let linear_log = parse_str("time_s,motor_current_A,load_pos_m\n0,1,0\n1,1,0\n").unwrap();
    let (searched, _) = observable_candidates(&linear_log, &options);
    assert!(!searched.selection.candidates.contains(&Kind::Unbalance));
    assert!(searched.selection.candidates.contains(&Kind::TorqueConstant));
    let current_log = parse_str("time_s,motor_current_A,load_pos_deg\n0,1,0\n1,1,0\n").unwrap();
    let (searched, notes) = observable_candidates(&current_log, &options);
    assert_eq!(searched.selection.candidates, options.selection.candidates);
    assert!(notes.is_empty());
}

#[test]
fn an_offset_over_a_short_stroke_is_reported_as_offset_or_unbalance() {
    let mut config =
        TruthConfig { duration: 30.0, effects: vec![Effect::TorqueOffset(1500.0)], seed: 8, ..TruthConfig::default() };
    config.trajectory.min_position = 40f64.to_radians();
    config.trajectory.max_position = 46f64.to_radians();
    let start = config.plant.starting_parameters();
    let data = prepare(&simulate(&config).log, &start, &EquationOptions::default()).unwrap();
    let options = SelectionOptions::default();
    let selection = select(&data, &start, &options);
    let found: Vec<Kind> = selection.found.iter().map(|f| f.kind).collect();
    assert!(found.contains(&Kind::Offset) || found.contains(&Kind::Unbalance), "{found:?}");
    let alike = observability::indistinct(&data, &start, &selection, &options);
    let pairs: Vec<(Kind, Kind)> = alike.iter().map(|a| (a.found, a.alternative)).collect();
    assert!(
        pairs.contains(&(Kind::Offset, Kind::Unbalance)) || pairs.contains(&(Kind::Unbalance, Kind::Offset)),
        "offset and unbalance over 6 deg: {pairs:?}"
    );
    assert!(alike.iter().all(|a| a.misfit <= observability::REPRODUCTION_TOLERANCE));
    // Over the full stroke an unbalance is not a constant: nothing reproduces it.
    let full = TruthConfig {
        duration: 30.0,
        effects: vec![Effect::Unbalance { amplitude: 3000.0, phase: 0.4 }],
        seed: 6,
        ..TruthConfig::default()
    };
    let data = prepare(&simulate(&full).log, &start, &EquationOptions::default()).unwrap();
    let selection = select(&data, &start, &options);
    assert_eq!(selection.found.first().map(|f| f.kind), Some(Kind::Unbalance));
    let alike = observability::indistinct(&data, &start, &selection, &options);
    assert!(alike.is_empty(), "{:?}", alike.iter().map(|a| a.alternative).collect::<Vec<_>>());
}

#[test]
fn window_states_come_through_the_motor_encoder_only_where_the_load_encoder_cannot_resolve_the_twist() {
    let state_route = |config: &TruthConfig| {
        let start = config.starting_parameters();
        let log = simulate(config).log;
        let data = prepare(&log, &start, &EquationOptions::default()).unwrap();
        OutputData::new(&log, &data, &start).unwrap().state_through_motor
    };
    let suite = TruthConfig { duration: 20.0, seed: 3, ..TruthConfig::default() };
    assert!(!state_route(&suite), "the suite's 25-bit load encoder resolves a 3.5 arcsec twist");
    let mut coarse = suite.clone();
    coarse.noise.load_encoder_counts = 2f64.powi(22);
    coarse.plant.set_anti_resonance(18.0);
    assert!(state_route(&coarse), "a 22-bit load encoder does not resolve a 0.23 arcsec twist");
}

#[test]
fn truth_variants_log_a_command_a_noiseless_current_and_a_linear_axis() {
    let plain = TruthConfig { duration: 4.0, seed: 2, ..TruthConfig::default() };
    let mut command = plain.clone();
    command.noise.current_log = CurrentLog::Command;
    command.noise.current_sigma = 0.0;
    let run = simulate(&command);
    assert!(run.log.signal(Signal::MotorCurrent).is_none());
    let logged = run.log.signal(Signal::MotorCurrentCommand).expect("the command column");
    // No sensor noise: the command is rounded to the current step and nothing else.
    let step = command.noise.current_step;
    assert!(logged.iter().all(|v| ((v / step) - (v / step).round()).abs() < 1e-6));
    assert_eq!(command.starting_parameters().value(names::CURRENT_LOOP_BANDWIDTH), command.current_bandwidth);
    assert_eq!(plain.starting_parameters().get(names::CURRENT_LOOP_BANDWIDTH), None);
    // The written log declares the command and a linear axis in its column names, and reads back.
    let mut linear = command.clone();
    linear.linear = true;
    let text = simulate(&linear).log.to_csv(linear.log_units());
    let header = text.lines().find(|l| !l.starts_with('#')).unwrap();
    assert!(header.contains("motor_current_command_A") && header.contains("load_pos_mm"), "{header}");
    let read = parse_str(&text).unwrap();
    assert!(read.is_linear() && read.current_is_commanded());
    // Sizes of a noiseless log are measured against the noise named for them.
    let mut noiseless = plain.clone();
    noiseless.noise.current_sigma = 0.0;
    noiseless.noise.size_current_sigma = Some(plain.noise.current_sigma);
    let torque = noiseless.noise.size_torque_sigma(&noiseless.plant);
    assert!((torque / plain.noise.torque_sigma(&plain.plant) - 1.0).abs() < 1e-12);
    assert!(noiseless.noise.torque_sigma(&noiseless.plant) < 0.1 * torque);
}

#[test]
fn the_corrected_set_keeps_the_simpler_law_where_the_data_cannot_tell_two_apart() {
    // An offset over 6 deg of stroke: the search names the offset, and an unbalance reproduces
    // it over the log ("offset or unbalance: the data cannot tell"). The offset is the simpler
    // law (one parameter against two), so the corrected set is the search's own.
    let mut config =
        TruthConfig { duration: 30.0, effects: vec![Effect::TorqueOffset(1500.0)], seed: 8, ..TruthConfig::default() };
    config.trajectory.min_position = 40f64.to_radians();
    config.trajectory.max_position = 46f64.to_radians();
    let start = config.plant.starting_parameters();
    let mut validation =
        antenna_validate::validate_with(&simulate(&config).log, &start, &ValidateOptions::default(), None).unwrap();
    let found: Vec<Kind> = validation.selection.found.iter().map(|f| f.kind).collect();
    assert_eq!(found, [Kind::Offset]);
    let unbalance = validation
        .indistinct
        .iter()
        .position(|a| a.alternative == Kind::Unbalance)
        .expect("an unbalance reproduces the offset over 6 deg");
    let kept = validation.kept_parameters();
    assert!(kept.cannot_tell.is_empty(), "{:?}", kept.cannot_tell);
    assert_eq!(kept.parameters, validation.selection.corrected);
    // The other reading goes with the corrected set: the offset kept, the unbalance's fit listed.
    assert_eq!(kept.also_fits.len(), 1, "{:?}", kept.also_fits);
    assert!(kept.also_fits[0].starts_with("offset or unbalance: the data cannot tell"), "{}", kept.also_fits[0]);
    assert!(kept.also_fits[0].contains("offset (1 parameter) is kept"), "{}", kept.also_fits[0]);
    assert!(kept.also_fits[0].contains(names::UNBALANCE_TORQUE), "{}", kept.also_fits[0]);

    // Had the search named the unbalance (its fitted set, the offset as the alternative that
    // reproduces it), the corrected set would keep the offset and list the unbalance.
    let offset_set = validation.selection.corrected.clone();
    let alternative = validation.indistinct.remove(unbalance);
    validation.selection.corrected = alternative.parameters.clone();
    validation.selection.found[0].kind = Kind::Unbalance;
    validation.indistinct = vec![observability::Indistinct {
        found: Kind::Unbalance,
        alternative: Kind::Offset,
        parameters: offset_set.clone(),
        ..alternative
    }];
    let kept = validation.kept_parameters();
    assert_eq!(kept.cannot_tell.len(), 1, "{:?}", kept.cannot_tell);
    assert!(kept.cannot_tell[0].starts_with("unbalance or offset: the data cannot tell"), "{}", kept.cannot_tell[0]);
    assert!(kept.cannot_tell[0].contains("offset (1 parameter) is kept"), "{}", kept.cannot_tell[0]);
    assert!(
        kept.cannot_tell[0].contains(names::UNBALANCE_TORQUE),
        "the unbalance's fit is listed: {}",
        kept.cannot_tell[0]
    );
    assert_eq!(kept.parameters, offset_set, "the offset's set, the unbalance at its starting value");
    assert_eq!(kept.parameters.value(names::UNBALANCE_TORQUE), start.value(names::UNBALANCE_TORQUE));
}
