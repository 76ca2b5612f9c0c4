//! The coupled antenna (two plants, two controllers and the wind unit, loaded from their packaged
//! `.fmu` files through the C ABI by `antenna_sim`) against the seed paper's
//! requirements, and the controller features of Fig. 3 switched off one at a time on the plant
//! with its default friction and backlash:
//!
//! * every optimal-wind requirement scenario (Req. 1-4 at 15, 45 and 88 deg) meets its limit,
//!   the step settling times also when counted from the command instead of from the profile's
//!   arrival;
//! * profiler off: a 4 deg step overshoots by what the position loop's velocity and acceleration
//!   limits predict (thousands of arcsec) instead of not at all;
//! * torque bias off: the pinions change flank at every reversal of a slow azimuth track and the
//!   backlash shows in the azimuth error there;
//! * friction feedforward off: the elevation error grows where a sidereal-rate track starts
//!   from rest and where it reverses.
//!
//! The feature comparisons run in calm air, so that the difference is the feature's alone. Every
//! measured figure is printed (`--nocapture`); docs/coupled-antenna-tests.md quotes them.

use antenna_sim::report::{run_scenario, Outcome};
use antenna_sim::scenario::{
    requirement_scenarios, step_table, Analysis, Requirement, JITTER_LIMIT_ARCSEC, SETTLE_HOLD_S,
    SIDEREAL_RATE_DEG_PER_S, TABLE_INTERVAL_S,
};
use antenna_sim::{
    AntennaConfig, CommandPoint, CommandTable, Configuration, CoupledAntenna, FmuSet, Overrides, ParameterValue, Trace,
};
use fmu_import::{Fmu, Instance};

const ARCSEC_PER_DEG: f64 = 3600.0;

/// The seed paper's model (no structure, ideal sensors, no Stribeck friction): the controller
/// features below are judged on the plant they were designed for, where their effect is not
/// hidden by encoder errors or a structure.
fn paper_model() -> AntennaConfig {
    Configuration::Paper.antenna_config()
}

fn fmus() -> FmuSet {
    let directory = antenna_fmus::fmu_directory();
    FmuSet::open(&directory).unwrap_or_else(|e| {
        panic!("cannot open the FMUs in {}: {e}; package them first (cargo xtask package)", directory.display())
    })
}

/// One Boolean parameter switched off.
fn switched_off(name: &str) -> Overrides {
    vec![(name.to_string(), ParameterValue::Boolean(false))]
}

/// A Real variable of an instance, read by name.
fn real(fmu: &Fmu, instance: &mut Instance, name: &str) -> f64 {
    let mut value = [f64::NAN];
    instance.get_real(&[fmu.description.vr(name).unwrap()], &mut value).unwrap_or_else(|e| panic!("get {name}: {e}"));
    value[0]
}

/// A coupled run with its trace and, for azimuth, how often each pinion moved from one flank to
/// the other (a pinion in the gap counts with the flank it last touched).
struct Run {
    trace: Trace,
    flank_changes: [usize; 2],
    antenna: CoupledAntenna,
}

fn run(fmus: &FmuSet, config: &AntennaConfig, table: &CommandTable, end_s: f64) -> Run {
    let mut antenna = CoupledAntenna::new(fmus, config, table).unwrap_or_else(|e| panic!("coupled antenna: {e}"));
    let flank_vrs = fmus.azimuth_plant.description.vrs(&["pinion1.flank", "pinion2.flank"]).unwrap();
    let mut trace = Trace::default();
    let mut flanks = [0i32; 2];
    let mut last_contact = [0i32; 2];
    let mut flank_changes = [0; 2];
    let steps = (end_s / config.step_s).round() as usize;
    for _ in 0..steps {
        antenna.step(table, Some(&mut trace)).unwrap_or_else(|e| panic!("step: {e}"));
        antenna.azimuth_plant.get_integer(&flank_vrs, &mut flanks).unwrap();
        for k in 0..2 {
            if flanks[k] != 0 {
                if last_contact[k] != 0 && flanks[k] != last_contact[k] {
                    flank_changes[k] += 1;
                }
                last_contact[k] = flanks[k];
            }
        }
    }
    Run { trace, flank_changes, antenna }
}

/// A pointing table at the table interval, `azimuth(t)` and `elevation(t)` in deg.
fn table_of(end_s: f64, azimuth: impl Fn(f64) -> f64, elevation: impl Fn(f64) -> f64) -> CommandTable {
    let rows = (end_s / TABLE_INTERVAL_S).round() as usize;
    let points = (0..=rows)
        .map(|k| {
            let t = k as f64 * TABLE_INTERVAL_S;
            CommandPoint { time_s: t, azimuth_deg: azimuth(t), elevation_deg: elevation(t) }
        })
        .collect();
    CommandTable::new(points).expect("test tables stay inside the travel")
}

fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

fn peak(x: &[f64]) -> f64 {
    x.iter().fold(0.0, |m, v| m.max(v.abs()))
}

// ---------------------------------------------------------------------------------------------
// Requirements

/// When the pointing error enters the 15 arcsec band for good (to stay there for the hold time)
/// after the command jumps at `jump_s`, counted from the jump, s. Unlike the report's settling
/// time this does not wait for the profile to arrive: the error can be inside the band during
/// the profile's final approach.
fn band_entry_after_command_s(trace: &Trace, jump_s: f64) -> Option<f64> {
    let error = trace.pointing_error_arcsec();
    let dt = trace.time_s[1] - trace.time_s[0];
    let hold = (SETTLE_HOLD_S / dt).round() as usize;
    let first = trace.time_s.partition_point(|&t| t < jump_s);
    let mut candidate = first;
    for (k, &e) in error.iter().enumerate().skip(first) {
        if e > JITTER_LIMIT_ARCSEC {
            candidate = k + 1;
        } else if k + 1 - candidate >= hold {
            return Some(trace.time_s[candidate] - jump_s);
        }
    }
    None
}

fn figure(outcome: &Outcome) -> String {
    let entry = match outcome.scenario.analysis {
        Analysis::Settling { jump_s, .. } => {
            band_entry_after_command_s(&outcome.trace, jump_s).map_or("never".into(), |t| format!("{t:.2} s"))
        }
        Analysis::Jitter { .. } => String::new(),
    };
    match outcome.settling {
        Some(s) => format!(
            "{:.2} s after the profile, {:.2} s after the command (in the band for good {entry} after the command), {:.2} s after the slew, peak {:.2} arcsec after arrival",
            s.after_profile_s, s.after_command_s, s.after_braking_s, s.peak_error_after_arrival_arcsec
        ),
        None if outcome.figure.is_finite() => format!("{:.3} arcsec RMS", outcome.figure),
        None => "never settled".to_string(),
    }
}

#[test]
fn every_optimal_wind_requirement_scenario_meets_its_limit() {
    let fmus = fmus();
    let scenarios: Vec<_> = requirement_scenarios().into_iter().filter(|s| s.wind_label == "optimal").collect();
    // Req. 1-4 at three elevations: a scenario lost from the list must not pass silently.
    assert_eq!(scenarios.len(), 12, "expected Req. 1-4 at 15, 45 and 88 deg");
    let started = std::time::Instant::now();
    let mut simulated = 0.0;
    let mut failures = Vec::new();
    for scenario in &scenarios {
        let outcome =
            run_scenario(&fmus, &AntennaConfig::default(), scenario, &mut |_| {}).unwrap_or_else(|e| panic!("{e}"));
        simulated += scenario.end_s;
        let requirement = scenario.requirement;
        println!("{} {:<22} {}", requirement.label(), scenario.name, figure(&outcome));
        let mut check = |ok: bool, what: String| {
            if !ok {
                failures.push(format!("{}: {what}", scenario.name));
            }
        };
        match requirement {
            Requirement::TrackingJitter => {
                // Req. 1: under 15 arcsec RMS over every 10 s window of the track.
                check(
                    outcome.figure < JITTER_LIMIT_ARCSEC,
                    format!("jitter {:.3} arcsec RMS >= {JITTER_LIMIT_ARCSEC}", outcome.figure),
                );
            }
            Requirement::SlewSettling | Requirement::LargeStepSettling | Requirement::SmallStepSettling => {
                let limit = requirement.limit();
                match outcome.settling {
                    None => check(false, "never settled within 15 arcsec".into()),
                    Some(s) => {
                        // The judged figure: Req. 3 and 4 from the command (the profile's own
                        // duration included), Req. 2 from the end of the slew at maximum speed
                        // (a 90 deg slew at 2 deg/s alone takes 45 s).
                        let (figure, from) = requirement.judged_settling(&s);
                        check(figure < limit, format!("settled {figure:.2} s {from}, limit {limit} s"));
                        check(
                            figure == outcome.figure,
                            format!("the report judges {} s, the metric gives {figure} s", outcome.figure),
                        );
                        // The issue's own figure, from the profile's arrival, must hold too.
                        check(
                            s.after_profile_s < limit,
                            format!("settled {:.2} s after the profile, limit {limit} s", s.after_profile_s),
                        );
                        // The end of the slew comes after the command and before the arrival.
                        check(
                            s.braking_start_s > 0.0 && s.braking_start_s <= s.profile_arrival_s,
                            format!(
                                "slew end {:.2} s outside (command, arrival {:.2} s]",
                                s.braking_start_s, s.profile_arrival_s
                            ),
                        );
                    }
                }
            }
            Requirement::TrackingNormalWind => unreachable!("filtered out"),
        }
    }
    let wall = started.elapsed().as_secs_f64();
    println!(
        "{} scenarios, {simulated:.0} s simulated in {wall:.2} s wall-clock ({:.0} x real time)",
        scenarios.len(),
        simulated / wall
    );
    assert!(failures.is_empty(), "requirements not met:\n{}", failures.join("\n"));
}

// ---------------------------------------------------------------------------------------------
// Profiler

/// How far an axis went past `target` coming from `from`, arcsec (negative if it never
/// reached it).
fn overshoot_arcsec(position_deg: &[f64], from: f64, target: f64) -> f64 {
    let direction = (target - from).signum();
    position_deg.iter().map(|p| direction * (p - target)).fold(f64::NEG_INFINITY, f64::max) * ARCSEC_PER_DEG
}

/// The overshoot of a step that goes straight into the position loop, deg. The loop asks
/// `Kp e`, clamped to `v_max` and rate-limited to `a_max`: far from the target the reference
/// cruises at `v_max`; it starts to fall only where `Kp e < v_max`, i.e. at `e = v_max / Kp`,
/// and then falls no faster than `a_max`, so the axis needs another `v_max^2 / (2 a_max)` to
/// stop. With the velocity loop following the reference (10-15 Hz against 0.75 Hz), the
/// overshoot is `v_max^2 / (2 a_max) - v_max / Kp`.
fn predicted_overshoot_deg(max_velocity: f64, max_acceleration: f64, position_gain_per_s: f64) -> f64 {
    max_velocity * max_velocity / (2.0 * max_acceleration) - max_velocity / position_gain_per_s
}

#[test]
fn without_the_profiler_a_4_deg_step_overshoots_as_the_position_loop_limits_predict() {
    let fmus = fmus();
    let (from, target) = ((34.0, 49.0), (30.0, 45.0));
    let (jump_s, end_s) = (2.0, 22.0);
    let table = step_table(from, target, jump_s, end_s);
    let off = AntennaConfig {
        azimuth_controller: switched_off("profiler.enabled"),
        elevation_controller: switched_off("profiler.enabled"),
        ..paper_model()
    };
    let with = run(&fmus, &paper_model(), &table, end_s);
    let mut without = run(&fmus, &off, &table, end_s);

    let axes = [
        ("azimuth", &fmus.azimuth_controller, from.0, target.0),
        ("elevation", &fmus.elevation_controller, from.1, target.1),
    ];
    for (axis, fmu, start, goal) in axes {
        let positions =
            |r: &Run| if axis == "azimuth" { r.trace.azimuth_deg.clone() } else { r.trace.elevation_deg.clone() };
        let over_with = overshoot_arcsec(&positions(&with), start, goal);
        let over_without = overshoot_arcsec(&positions(&without), start, goal);
        // The limits the position loop works with, read back from the controller instance.
        let instance = if axis == "azimuth" {
            &mut without.antenna.azimuth_controller
        } else {
            &mut without.antenna.elevation_controller
        };
        let v_max = real(fmu, instance, "position_loop.max_velocity");
        let a_max = real(fmu, instance, "position_loop.max_acceleration");
        let kp = std::f64::consts::TAU * real(fmu, instance, "position_loop.bandwidth");
        let predicted = predicted_overshoot_deg(v_max, a_max, kp) * ARCSEC_PER_DEG;
        println!(
            "{axis}: 4 deg step overshoot {over_with:.3} arcsec with the profiler, {over_without:.1} arcsec without (predicted {predicted:.1} arcsec from v_max {v_max} deg/s, a_max {a_max} deg/s^2, Kp {kp:.3} /s)"
        );
        // With the profiler the axis arrives without passing the target by more than a small
        // fraction of the 15 arcsec band (the profiler is designed not to overshoot at all).
        assert!(over_with < 1.0, "{axis}: {over_with} arcsec overshoot with the profiler");
        // Without it, the overshoot is the one the loop's limits imply, to 10 % (the velocity
        // loop's lag and the sampling add a little).
        assert!(
            (over_without / predicted - 1.0).abs() < 0.1,
            "{axis}: {over_without} arcsec overshoot, predicted {predicted}"
        );
        assert!(over_without > 100.0 * over_with.max(0.01), "{axis}: {over_without} vs {over_with} arcsec");
    }
}

// ---------------------------------------------------------------------------------------------
// Torque bias

#[test]
fn without_the_torque_bias_the_pinion_backlash_shows_at_azimuth_reversals() {
    let fmus = fmus();
    // A slow azimuth oscillation, 30 +/- 0.05 deg with a 20 s period (at most 0.016 deg/s, a
    // tracking rate): it reverses every 10 s, at t = 5, 15, ..., 55 s.
    let (amplitude, period, periods) = (0.05, 20.0, 3.0);
    let end_s = periods * period;
    let w = std::f64::consts::TAU / period;
    let table = table_of(end_s, |t| 30.0 + amplitude * (w * t).sin(), |_| 45.0);
    let reversals: Vec<f64> = (0..(2.0 * periods) as usize).map(|k| period / 4.0 + k as f64 * period / 2.0).collect();

    let off = AntennaConfig { azimuth_controller: switched_off("torque_bias.enabled"), ..paper_model() };
    let mut with = run(&fmus, &paper_model(), &table, end_s);
    let without = run(&fmus, &off, &table, end_s);

    // Peak azimuth error (command - true, axis arcsec) within a quarter period of each reversal.
    let reversal_peaks = |r: &Run| -> Vec<f64> {
        let t = &r.trace;
        reversals
            .iter()
            .map(|&tr| {
                let e: Vec<f64> = (0..t.time_s.len())
                    .filter(|&k| (t.time_s[k] - tr).abs() < period / 8.0)
                    .map(|k| (t.command_azimuth_deg[k] - t.azimuth_deg[k]) * ARCSEC_PER_DEG)
                    .collect();
                peak(&e)
            })
            .collect()
    };
    let (peaks_with, peaks_without) = (reversal_peaks(&with), reversal_peaks(&without));
    // The plant's free play per pinion, about the axis.
    let backlash = fmus.azimuth_plant.description.variable("pinion1.backlash").unwrap();
    assert_eq!(backlash.unit.as_deref(), Some("arcsec"), "pinion1.backlash changed its unit");
    let backlash_arcsec = real(&fmus.azimuth_plant, &mut with.antenna.azimuth_plant, "pinion1.backlash");
    println!(
        "azimuth reversals (pinion backlash {backlash_arcsec:.1} arcsec): peak error {:.2?} arcsec with the torque bias, {:.2?} without; flank changes {:?} with, {:?} without over {} reversals",
        peaks_with,
        peaks_without,
        with.flank_changes,
        without.flank_changes,
        reversals.len()
    );
    // With the bias each pinion stays on its own flank through every reversal ...
    assert_eq!(with.flank_changes, [0, 0], "a pinion changed flank with the torque bias on");
    // ... without it both cross the gap at every reversal.
    for k in 0..2 {
        assert!(
            without.flank_changes[k] >= reversals.len(),
            "pinion {}: {} flank changes over {} reversals",
            k + 1,
            without.flank_changes[k],
            reversals.len()
        );
    }
    // The gap shows in the error: a sizable fraction of it at every reversal without the bias,
    // a small one with it (what is left is the friction reversal the loops absorb).
    for (i, (&a, &b)) in peaks_with.iter().zip(&peaks_without).enumerate() {
        assert!(a < 0.1 * backlash_arcsec, "reversal {i}: {a} arcsec with the bias, backlash {backlash_arcsec} arcsec");
        assert!(
            b > 0.25 * backlash_arcsec,
            "reversal {i}: {b} arcsec without the bias, backlash {backlash_arcsec} arcsec"
        );
        assert!(b > 3.0 * a, "reversal {i}: {b} arcsec without the bias against {a} with it");
    }
}

// ---------------------------------------------------------------------------------------------
// Friction feedforward

#[test]
fn without_the_friction_feedforward_the_elevation_error_grows_where_a_sidereal_track_starts_and_reverses() {
    let fmus = fmus();
    // From rest, the elevation tracks up at the sidereal rate for 10 s, then down for 10 s, and
    // so on (the rate changes by 0.008 deg/s, far below the profiler's 0.05 deg/s threshold:
    // this is tracking). The friction the integrator must supply changes at the start (from
    // stiction) and at every reversal (from +sliding to -sliding friction).
    let (rate, leg_s, end_s) = (0.004, 10.0, 60.0);
    let table = table_of(
        end_s,
        |_| 30.0,
        |t| {
            let phase = t % (2.0 * leg_s);
            45.0 + rate * if phase < leg_s { phase } else { 2.0 * leg_s - phase }
        },
    );
    let off = AntennaConfig { elevation_controller: switched_off("friction_feedforward.enabled"), ..paper_model() };
    let with = run(&fmus, &paper_model(), &table, end_s);
    let without = run(&fmus, &off, &table, end_s);

    let error = |r: &Run, from: f64, to: f64| -> Vec<f64> {
        let t = &r.trace;
        (0..t.time_s.len())
            .filter(|&k| t.time_s[k] >= from && t.time_s[k] < to)
            .map(|k| (t.command_elevation_deg[k] - t.elevation_deg[k]) * ARCSEC_PER_DEG)
            .collect()
    };
    let start = (peak(&error(&with, 0.0, 5.0)), peak(&error(&without, 0.0, 5.0)));
    let reversing = (error(&with, leg_s, end_s), error(&without, leg_s, end_s));
    let reversal = ((rms(&reversing.0), peak(&reversing.0)), (rms(&reversing.1), peak(&reversing.1)));
    // The last 2 s before the first reversal: steady sidereal tracking.
    let steady = (rms(&error(&with, leg_s - 2.0, leg_s)), rms(&error(&without, leg_s - 2.0, leg_s)));
    println!(
        "elevation, sidereal track with friction feedforward / without: start peak {:.3} / {:.3} arcsec; over the reversals RMS {:.3} / {:.3}, peak {:.3} / {:.3} arcsec; steady tracking RMS {:.3} / {:.3} arcsec",
        start.0, start.1, reversal.0 .0, reversal.1 .0, reversal.0 .1, reversal.1 .1, steady.0, steady.1
    );
    // What the feedforward takes off the integrator (plant defaults, at the motor, 45 deg):
    // sliding friction motor 0.15 + screw 8/28 + pivot 500/N = 0.46 N m, breakaway 0.2 + 10/28 +
    // 650/N = 0.59 N m, feedforward 0.40 N m. At the start the integrator must build 0.59 N m
    // without it and 0.19 with it (3.1 times); at a reversal it must swing 2 x 0.46 against
    // 2 x 0.06 (7 times). In a loop that is linear between those events the transient error
    // scales with that torque; the quantisation and inertia parts of the error do not, so the
    // ratios measured are lower: assert 2.
    assert!(start.1 > 2.0 * start.0, "start of the track: {} arcsec without against {} with", start.1, start.0);
    assert!(
        reversal.1 .0 > 2.0 * reversal.0 .0,
        "reversals: {} arcsec RMS without against {} with",
        reversal.1 .0,
        reversal.0 .0
    );
    assert!(
        reversal.1 .1 > 2.0 * reversal.0 .1,
        "reversals: peak {} arcsec without against {} with",
        reversal.1 .1,
        reversal.0 .1
    );
}

// ---------------------------------------------------------------------------------------------
// Friction at sidereal rates

/// Figures of one axis tracking at the sidereal rate through reversals: the servo's error
/// (command minus encoder reading) while tracking steadily and around the reversals, and the
/// longest time the load stood still (moved less than 1 % of the rate) around a reversal.
#[derive(Debug)]
struct TrackingFigures {
    steady_servo_rms_arcsec: f64,
    reversal_servo_peak_arcsec: f64,
    longest_stick_s: f64,
}

fn tracking_figures(
    command: &[f64],
    encoder: &[f64],
    position: &[f64],
    rate: f64,
    reversals_s: &[f64],
) -> TrackingFigures {
    let near_reversal = |k: usize| reversals_s.iter().any(|r| (k as f64 * 1e-3 - r).abs() < 3.0);
    let servo = |k: usize| (command[k] - encoder[k]) * ARCSEC_PER_DEG;
    let steady: Vec<f64> = (10_000..command.len()).filter(|&k| !near_reversal(k)).map(servo).collect();
    let reversing: Vec<f64> = (0..command.len()).filter(|&k| near_reversal(k)).map(servo).collect();
    let mut longest = 0usize;
    let mut current = 0usize;
    for k in 1..position.len() {
        let stuck = near_reversal(k) && ((position[k] - position[k - 1]) / 1e-3).abs() < 0.01 * rate;
        current = if stuck { current + 1 } else { 0 };
        longest = longest.max(current);
    }
    TrackingFigures {
        steady_servo_rms_arcsec: rms(&steady),
        reversal_servo_peak_arcsec: peak(&reversing),
        longest_stick_s: longest as f64 * 1e-3,
    }
}

#[test]
fn at_the_sidereal_rate_the_axes_track_without_hunting_and_stick_only_at_reversals() {
    let fmus = fmus();
    // Both axes track at the sidereal rate, reversing every 20 s (at 20 and 40 s), in calm air:
    // only friction and the sensors act.
    let (rate, leg_s, end_s) = (SIDEREAL_RATE_DEG_PER_S, 20.0, 60.0);
    let triangle = move |t: f64| {
        let phase = t % (2.0 * leg_s);
        rate * if phase < leg_s { phase } else { 2.0 * leg_s - phase }
    };
    let table = table_of(end_s, move |t| 30.0 + triangle(t), move |t| 45.0 + triangle(t));
    let reversals = [leg_s, 2.0 * leg_s];
    let realistic = AntennaConfig::default();
    let no_stribeck = {
        let mut c = realistic.clone();
        for plant in [&mut c.azimuth_plant, &mut c.elevation_plant] {
            for (name, value) in plant.iter_mut() {
                if name.ends_with("stribeck_velocity") {
                    *value = ParameterValue::Real(0.0);
                }
            }
        }
        c
    };
    let no_features = AntennaConfig {
        azimuth_controller: switched_off("torque_bias.enabled"),
        elevation_controller: switched_off("friction_feedforward.enabled"),
        ..realistic.clone()
    };
    let mut figures = Vec::new();
    for (label, config) in
        [("realistic", &realistic), ("no Stribeck", &no_stribeck), ("no friction features", &no_features)]
    {
        let t = run(&fmus, config, &table, end_s).trace;
        let az = tracking_figures(&t.command_azimuth_deg, &t.encoder_azimuth_deg, &t.azimuth_deg, rate, &reversals);
        let el =
            tracking_figures(&t.command_elevation_deg, &t.encoder_elevation_deg, &t.elevation_deg, rate, &reversals);
        println!("{label}: azimuth {az:?}; elevation {el:?}");
        figures.push((az, el));
    }
    let [(az, el), (az_plain, el_plain), (az_bare, el_bare)] = <[_; 3]>::try_from(figures).unwrap();
    for (axis, f, plain) in [("azimuth", &az, &az_plain), ("elevation", &el, &el_plain)] {
        // No hunting while tracking steadily: the 10 Hz velocity loop holds the Stribeck
        // friction's negative slope; the servo error stays at the tenth-of-an-arcsec level.
        assert!(f.steady_servo_rms_arcsec < 0.5, "{axis}: {f:?}");
        assert!(
            (f.steady_servo_rms_arcsec / plain.steady_servo_rms_arcsec - 1.0).abs() < 0.5,
            "{axis}: {f:?} vs {plain:?}"
        );
        // At a reversal the load sticks while the integrator swings through the breakaway band,
        // and the error there is several times the steady one.
        assert!(f.longest_stick_s > 0.01, "{axis}: {f:?}");
        assert!(f.reversal_servo_peak_arcsec > 2.0 * f.steady_servo_rms_arcsec, "{axis}: {f:?}");
    }
    // The friction features shorten the reversal's transient several times over: the torque
    // bias keeps the pinions off the backlash (azimuth), the friction feedforward hands the
    // integrator the friction step (elevation). Measured: 9.2 -> 1.5 arcsec and 3.0 -> 1.0.
    assert!(az_bare.reversal_servo_peak_arcsec > 3.0 * az.reversal_servo_peak_arcsec, "{az_bare:?} vs {az:?}");
    assert!(el_bare.reversal_servo_peak_arcsec > 2.0 * el.reversal_servo_peak_arcsec, "{el_bare:?} vs {el:?}");
    assert!(az_bare.longest_stick_s > 3.0 * az.longest_stick_s, "{az_bare:?} vs {az:?}");
}

// ---------------------------------------------------------------------------------------------
// The paper configuration

/// The requirement report of the drive-only model as printed before the realistic antenna
/// (commit 797c4ea, out/antenna/report.md): (scenario, figure as printed). The hold rows at 15
/// and 45 deg are the figures with an exactly constant command (docs/controller.md section 10:
/// the old 0.244 and 0.298 arcsec rode on rounding noise in the command).
const PAPER_REPORT: [(&str, &str); 21] = [
    ("track-sidereal-el15", "0.028"),
    ("slew-90deg-el15", "2.91"),
    ("step-4deg-el15", "6.47"),
    ("step-30arcmin-el15", "2.27"),
    ("hold-el15-normal-wind", "0.400"),
    ("track-sidereal-el15-normal-wind", "0.099"),
    ("track-0.04-el15-normal-wind", "0.098"),
    ("track-sidereal-el45", "0.027"),
    ("slew-90deg-el45", "2.85"),
    ("step-4deg-el45", "6.47"),
    ("step-30arcmin-el45", "2.27"),
    ("hold-el45-normal-wind", "0.417"),
    ("track-sidereal-el45-normal-wind", "0.123"),
    ("track-0.04-el45-normal-wind", "0.121"),
    ("track-sidereal-el88", "0.022"),
    ("slew-90deg-el88", "2.17"),
    ("step-4deg-el88", "6.46"),
    ("step-30arcmin-el88", "2.27"),
    ("hold-el88-normal-wind", "0.218"),
    ("track-sidereal-el88-normal-wind", "0.123"),
    ("track-0.04-el88-normal-wind", "0.121"),
];

#[test]
fn the_paper_configuration_reproduces_the_drive_only_report_to_its_printed_digits() {
    let fmus = fmus();
    let config = paper_model();
    let settings = Configuration::Paper.scenario_settings();
    for scenario in requirement_scenarios() {
        let (_, printed) = PAPER_REPORT.iter().find(|(name, _)| *name == scenario.name).expect("every scenario listed");
        let outcome = run_scenario(&fmus, &config, &settings.apply(&scenario), &mut |_| {})
            .unwrap_or_else(|e| panic!("{}: {e}", scenario.name));
        // That report judged the absolute error; the absolute figures are kept beside the
        // centred ones, and must still read as printed.
        let absolute = outcome.absolute_settling_s.unwrap_or(outcome.absolute_rms_arcsec);
        let decimals = printed.split('.').nth(1).map_or(0, str::len);
        let ours = format!("{:.*}", decimals, absolute);
        assert_eq!(&ours, printed, "{}: {absolute} against the printed {printed}", scenario.name);
        // Centring can only take error away from a window: a jitter is at most the absolute
        // RMS. (A settling instant may move either way by a millisecond or so.)
        if outcome.settling.is_none() {
            assert!(
                outcome.figure <= absolute,
                "{}: centred {} above absolute {absolute}",
                scenario.name,
                outcome.figure
            );
        }
        println!("{}: absolute {absolute:.3}, centred {:.3}", scenario.name, outcome.figure);
    }
}

#[test]
fn holding_in_normal_wind_the_beam_error_spectrum_shows_each_structural_mode_within_two_percent() {
    // The realistic antenna, its modes pushing back on the drives: standing still, the servo
    // holds the axes nearly as if clamped, and the beam error's spectrum peaks at the modes'
    // documented frequencies (the modes file's, with the axes clamped at the encoders).
    let fmus = fmus();
    let config = AntennaConfig::default();
    assert!(
        config.structure.is_some() && config.structure_feedback,
        "the realistic antenna couples the structure both ways"
    );
    let settings = Configuration::Realistic.scenario_settings();
    let scenario = requirement_scenarios().into_iter().find(|s| s.name == "hold-el45-normal-wind").unwrap();
    let outcome = run_scenario(&fmus, &config, &settings.apply(&scenario), &mut |_| {}).unwrap();
    let peaks = antenna_sim::report::beam_spectrum_peaks(&outcome, &config);
    assert_eq!(peaks.len(), 2, "{peaks:?}");
    for (name, documented, peak) in peaks {
        let peak = peak.unwrap_or_else(|| panic!("{name}: no spectral peak within 20 % of {documented} Hz"));
        println!("{name}: beam error spectrum peak {peak:.3} Hz, documented {documented} Hz");
        assert!((peak / documented - 1.0).abs() < 0.02, "{name}: peak {peak} Hz against {documented} Hz");
    }
}
