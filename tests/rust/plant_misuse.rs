//! Misuse of the packaged plant FMUs through the C ABI: every wrong call must return fmi2Error
//! (fmi2Instantiate: NULL) with a message through the master's logger, leave the process
//! running and the instance diagnosable, and an instance in error must recover through
//! fmi2Reset. Calls with NULL pointers are tested in fmu-runtime's `real_fmu_null_pointers`
//! (they need `unsafe`, which only that crate may contain).

use antenna_tests::{expect_error, initialized, open, output_bits, real, real_inputs, set_reals, vr, PLANTS};
use fmu_import::{ImportError, Instance};

#[test]
fn do_step_before_initialisation_is_an_error_with_a_logged_message() {
    for plant in PLANTS {
        let fmu = open(plant);
        let mut instance = fmu.instantiate("before-init", false).unwrap();
        expect_error(instance.do_step(0.0, 1e-3), &instance, &format!("{plant}: DoStep when instantiated"));

        let mut instance = fmu.instantiate("in-init", false).unwrap();
        instance.setup_experiment(0.0, None).unwrap();
        instance.enter_initialization_mode().unwrap();
        expect_error(instance.do_step(0.0, 1e-3), &instance, &format!("{plant}: DoStep in initialisation mode"));
    }
}

#[test]
fn do_step_after_terminate_is_an_error_with_a_logged_message() {
    for plant in PLANTS {
        let fmu = open(plant);
        let mut instance = initialized(&fmu, "after-terminate", &[]);
        instance.do_step(0.0, 1e-3).unwrap();
        instance.terminate().unwrap();
        let messages =
            expect_error(instance.do_step(1e-3, 1e-3), &instance, &format!("{plant}: DoStep after Terminate"));
        assert!(
            messages.iter().any(|m| m.contains("Terminated")),
            "{plant}: the message does not name the phase: {messages:?}"
        );
        // The outputs stay readable after the error, for diagnosis.
        real(&fmu, &mut instance, "axis.position");
    }
}

#[test]
fn terminating_twice_is_an_error_with_a_logged_message() {
    for plant in PLANTS {
        let fmu = open(plant);
        let mut instance = initialized(&fmu, "double-terminate", &[]);
        instance.terminate().unwrap();
        expect_error(instance.terminate(), &instance, &format!("{plant}: second Terminate"));
    }
}

#[test]
fn a_wrong_guid_gives_null_with_a_logged_message() {
    for plant in PLANTS {
        let fmu = open(plant);
        for guid in ["{00000000-0000-0000-0000-000000000000}", "", "not a guid at all"] {
            match fmu.instantiate_with("wrong-guid", guid, false, false) {
                Err(ImportError::Instantiate { messages }) => {
                    assert!(
                        messages.iter().any(|m| m.contains("GUID")),
                        "{plant}: the message does not mention the GUID: {messages:?}"
                    );
                }
                Err(other) => panic!("{plant}: expected NULL from fmi2Instantiate, got {other}"),
                Ok(_) => panic!("{plant}: fmi2Instantiate accepted the GUID '{guid}'"),
            }
        }
        // The library is still usable afterwards.
        let mut instance = initialized(&fmu, "after-wrong-guid", &[]);
        instance.do_step(0.0, 1e-3).unwrap();
    }
}

#[test]
fn nan_and_infinite_inputs_are_rejected_and_change_nothing() {
    for plant in PLANTS {
        let fmu = open(plant);
        for input in real_inputs(&fmu) {
            for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                let mut instance = initialized(&fmu, "bad-input", &[]);
                instance.do_step(0.0, 1e-3).unwrap();
                let before = real(&fmu, &mut instance, &input);
                let result = instance.set_real(&[vr(&fmu, &input)], &[bad]);
                let messages = expect_error(result, &instance, &format!("{plant}: {input} = {bad}"));
                assert!(
                    messages.iter().any(|m| m.contains(&input)),
                    "{plant}: the message does not name {input}: {messages:?}"
                );
                assert_eq!(
                    real(&fmu, &mut instance, &input).to_bits(),
                    before.to_bits(),
                    "{plant}: the rejected {input} = {bad} changed it"
                );
            }
        }
        // Parameters too, during initialisation.
        let mut instance = fmu.instantiate("bad-parameter", false).unwrap();
        instance.setup_experiment(0.0, None).unwrap();
        instance.enter_initialization_mode().unwrap();
        let inertia = if plant == "AzimuthPlant" { "motor1.inertia" } else { "motor.inertia" };
        expect_error(
            instance.set_real(&[vr(&fmu, inertia)], &[f64::NAN]),
            &instance,
            &format!("{plant}: NaN {inertia}"),
        );
    }
}

#[test]
fn unknown_value_references_are_rejected() {
    for plant in PLANTS {
        let fmu = open(plant);
        let unknown = fmu.description.variables.iter().map(|v| v.value_reference).max().unwrap() + 1;
        for vr in [unknown, u32::MAX] {
            let mut instance = initialized(&fmu, "unknown-vr", &[]);
            let mut value = [0.0];
            expect_error(instance.get_real(&[vr], &mut value), &instance, &format!("{plant}: GetReal of {vr}"));
            let mut instance = initialized(&fmu, "unknown-vr", &[]);
            expect_error(instance.set_real(&[vr], &[1.0]), &instance, &format!("{plant}: SetReal of {vr}"));
            let mut instance = initialized(&fmu, "unknown-vr", &[]);
            let mut integer = [0];
            expect_error(instance.get_integer(&[vr], &mut integer), &instance, &format!("{plant}: GetInteger of {vr}"));
        }
        // A known reference of another type is as wrong as an unknown one.
        let mut instance = initialized(&fmu, "wrong-type", &[]);
        let mut integer = [0];
        expect_error(
            instance.get_integer(&[vr(&fmu, "axis.position")], &mut integer),
            &instance,
            &format!("{plant}: GetInteger of a Real"),
        );
    }
}

#[test]
fn negative_zero_and_non_finite_step_sizes_are_rejected() {
    for plant in PLANTS {
        let fmu = open(plant);
        for h in [-1e-3, 0.0, f64::NAN, f64::INFINITY] {
            let mut instance = initialized(&fmu, "bad-step", &[]);
            let before = output_bits(&fmu, &mut instance);
            expect_error(instance.do_step(0.0, h), &instance, &format!("{plant}: step {h}"));
            assert_eq!(instance.last_successful_time().unwrap(), 0.0, "{plant}: a rejected step {h} moved the time");
            assert_eq!(output_bits(&fmu, &mut instance), before, "{plant}: a rejected step {h} changed the outputs");
        }
    }
}

#[test]
fn a_step_longer_than_a_day_is_rejected_at_once_and_changes_nothing() {
    // Steps are computed in pieces of a millisecond: before the cap, a step of 1e300 s kept
    // fmi2DoStep busy for ever. The maximum, one day, is fmu_runtime::exports::MAX_STEP_SIZE.
    let day = fmu_runtime::exports::MAX_STEP_SIZE;
    assert_eq!(day, 86_400.0);
    for plant in PLANTS {
        let fmu = open(plant);
        for h in [1e300, f64::MAX, 2.0 * day, day * (1.0 + 1e-12)] {
            let mut instance = initialized(&fmu, "huge-step", &[]);
            set_reals(&fmu, &mut instance, &[(real_inputs(&fmu)[0].as_str(), 1.0)]);
            let before = output_bits(&fmu, &mut instance);
            let started = std::time::Instant::now();
            let messages = expect_error(instance.do_step(0.0, h), &instance, &format!("{plant}: step {h}"));
            // Computing even a thousandth of such a step would take seconds; a rejection
            // takes microseconds. One second leaves room for a loaded machine.
            assert!(
                started.elapsed().as_secs_f64() < 1.0,
                "{plant}: rejecting a step of {h} s took {:?}",
                started.elapsed()
            );
            assert!(messages.iter().any(|m| m.contains("longer than the longest step")), "{plant}: {messages:?}");
            assert_eq!(instance.last_successful_time().unwrap(), 0.0, "{plant}: the rejected step moved the time");
            assert_eq!(output_bits(&fmu, &mut instance), before, "{plant}: the rejected step changed the outputs");
        }
    }
}

#[test]
fn a_step_past_the_stop_time_is_rejected_and_a_run_that_ends_on_it_is_not() {
    for plant in PLANTS {
        let fmu = open(plant);
        let with_stop_time = |name: &str| {
            let mut instance = fmu.instantiate(name, false).unwrap();
            instance.setup_experiment(0.0, Some(0.1)).unwrap();
            instance.enter_initialization_mode().unwrap();
            instance.exit_initialization_mode().unwrap();
            instance
        };
        // 100 steps of 1 ms, the time accumulated as t += h, end a few ulps away from 0.1:
        // that is the stop time, not past it.
        let mut instance = with_stop_time("to-the-stop-time");
        let mut t = 0.0;
        for _ in 0..100 {
            instance.do_step(t, 1e-3).unwrap_or_else(|e| panic!("{plant}: step at {t}: {e}"));
            t += 1e-3;
        }
        assert_ne!(t, 0.1, "the accumulated time is expected to be off by rounding");
        // One more step is past it.
        let messages =
            expect_error(instance.do_step(t, 1e-3), &instance, &format!("{plant}: a step after the stop time"));
        assert!(messages.iter().any(|m| m.contains("stopTime")), "{plant}: {messages:?}");
        // So is a step that jumps over it, short or long.
        for h in [0.2, 1e4] {
            let mut instance = with_stop_time("over-the-stop-time");
            let before = output_bits(&fmu, &mut instance);
            let messages = expect_error(
                instance.do_step(0.0, h),
                &instance,
                &format!("{plant}: a step of {h} s over the stop time"),
            );
            assert!(messages.iter().any(|m| m.contains("after the stopTime 0.1")), "{plant}: {messages:?}");
            assert_eq!(output_bits(&fmu, &mut instance), before, "{plant}: the rejected step changed the outputs");
        }
    }
}

#[test]
fn a_wrong_communication_point_is_rejected() {
    for plant in PLANTS {
        let fmu = open(plant);
        let h = 1e-3;
        // Ahead of, and behind, the instance's time.
        for (steps_done, point) in [(0, 0.5), (0, -h), (10, 5.0 * h), (10, 11.0 * h)] {
            let mut instance = initialized(&fmu, "wrong-point", &[]);
            let mut t = 0.0;
            for _ in 0..steps_done {
                instance.do_step(t, h).unwrap();
                t += h;
            }
            let messages =
                expect_error(instance.do_step(point, h), &instance, &format!("{plant}: DoStep at {point} when at {t}"));
            assert!(messages.iter().any(|m| m.contains("currentCommunicationPoint")), "{plant}: {messages:?}");
        }
        // A master that accumulates t += h in floating point is a few ulps off: that is the
        // same point and must be accepted.
        let mut instance = initialized(&fmu, "accumulated-time", &[]);
        let mut t = 0.0;
        for _ in 0..1000 {
            instance.do_step(t, 0.1 * h).unwrap();
            t += 0.1 * h;
        }
        instance.do_step(0.1 + 1e-14, h).unwrap();
    }
}

#[test]
fn parameters_that_are_not_tunable_cannot_be_set_while_stepping() {
    for plant in PLANTS {
        let fmu = open(plant);
        let mut instance = initialized(&fmu, "fixed-parameter", &[]);
        instance.do_step(0.0, 1e-3).unwrap();
        let name = if plant == "AzimuthPlant" { "gear.ratio" } else { "load.inertia" };
        let before = real(&fmu, &mut instance, name);
        expect_error(
            instance.set_real(&[vr(&fmu, name)], &[2.0 * before]),
            &instance,
            &format!("{plant}: {name} while stepping"),
        );
        assert_eq!(real(&fmu, &mut instance, name), before);
    }
}

#[test]
fn out_of_range_values_and_bad_parameter_files_are_rejected_and_change_nothing() {
    for plant in PLANTS {
        let fmu = open(plant);
        let mut instance = fmu.instantiate("bad-values", false).unwrap();
        instance.setup_experiment(0.0, None).unwrap();
        instance.enter_initialization_mode().unwrap();
        // initial_position has a declared range in both plants.
        let before = real(&fmu, &mut instance, "initial_position");
        expect_error(
            instance.set_real(&[vr(&fmu, "initial_position")], &[1e6]),
            &instance,
            &format!("{plant}: initial_position out of range"),
        );
        assert_eq!(real(&fmu, &mut instance, "initial_position"), before);

        for file in ["no-such-file.params", "/nonexistent/absolute.params"] {
            let mut instance = fmu.instantiate("bad-file", false).unwrap();
            instance.setup_experiment(0.0, None).unwrap();
            instance.enter_initialization_mode().unwrap();
            let messages = expect_error(
                instance.set_string(&[vr(&fmu, "parameter_file")], &[file]),
                &instance,
                &format!("{plant}: parameter_file {file}"),
            );
            assert!(messages.iter().any(|m| m.contains("cannot read parameter file")), "{plant}: {messages:?}");
        }
    }
}

#[test]
fn the_extreme_parameters_that_gave_nan_are_now_outside_the_declared_ranges() {
    // Audit: these were within the declared ranges and made every fmi2DoStep return fmi2OK
    // with NaN outputs (from 1e50 N m/rad on, never return).
    let cases = [
        ("AzimuthPlant", "pinion1.stiffness", 1e308),
        ("AzimuthPlant", "pinion2.damping", 1e308),
        ("AzimuthPlant", "motor1.current_loop_bandwidth", 1e300),
        ("ElevationPlant", "jackscrew.series_stiffness", 1e308),
        ("ElevationPlant", "jackscrew.axial_damping", 1e308),
        ("ElevationPlant", "motor.current_loop_bandwidth", 1e300),
    ];
    for (plant, name, value) in cases {
        let fmu = open(plant);
        let mut instance = fmu.instantiate("extreme", false).unwrap();
        instance.setup_experiment(0.0, None).unwrap();
        instance.enter_initialization_mode().unwrap();
        let messages = expect_error(
            instance.set_real(&[vr(&fmu, name)], &[value]),
            &instance,
            &format!("{plant}: {name} = {value}"),
        );
        assert!(messages.iter().any(|m| m.contains("above its maximum")), "{plant}: {messages:?}");
    }
    // A damping this small beside the backlash is within its range (0 is legal without
    // backlash) but makes the drive too fast to discretise: refused at initialisation, with
    // the rate named, instead of stepping into NaN.
    let fmu = open("AzimuthPlant");
    let mut instance = fmu.instantiate("tiny-damping", false).unwrap();
    instance.setup_experiment(0.0, None).unwrap();
    instance.enter_initialization_mode().unwrap();
    instance.set_real(&[vr(&fmu, "pinion1.damping")], &[1e-100]).unwrap();
    let messages =
        expect_error(instance.exit_initialization_mode(), &instance, "AzimuthPlant: pinion1.damping = 1e-100");
    assert!(messages.iter().any(|m| m.contains("relaxation in the backlash gap")), "{messages:?}");
}

#[test]
fn a_load_torque_beyond_its_declared_maximum_is_refused_and_changes_nothing() {
    // A disturbance of 1e308 N m is finite but no load: the declared maximum (1e8 N m,
    // docs/fmu-robustness.md) refuses it at the set, with the bound named, before any step
    // could overflow; the instance is left as it was.
    for plant in PLANTS {
        let fmu = open(plant);
        let mut instance = initialized(&fmu, "overflow", &[]);
        let before = output_bits(&fmu, &mut instance);
        let vr = fmu.description.vr("load.disturbance_torque").unwrap();
        let messages = expect_error(
            instance.set_real(&[vr], &[1e308]),
            &instance,
            &format!("{plant}: a load torque of 1e308 N m"),
        );
        assert!(messages.iter().any(|m| m.contains("is above its maximum 100000000 N.m")), "{plant}: {messages:?}");
        assert_eq!(output_bits(&fmu, &mut instance), before, "{plant}: the refused set changed the outputs");
        assert_eq!(instance.last_successful_time().unwrap(), 0.0, "{plant}: the refused set moved the time");
    }
}

#[test]
fn a_state_of_another_model_is_rejected() {
    let azimuth = open("AzimuthPlant");
    let elevation = open("ElevationPlant");
    let mut az = initialized(&azimuth, "az", &[]);
    let state = az.get_state().unwrap();
    let bytes = az.serialize_state(&state).unwrap();
    let mut el = initialized(&elevation, "el", &[]);
    expect_error(el.deserialize_state(&bytes), &el, "an AzimuthPlant state into an ElevationPlant");
    // A damaged state of the right model too.
    let mut el = initialized(&elevation, "el", &[]);
    let good = el.get_state().unwrap();
    let mut damaged = el.serialize_state(&good).unwrap();
    damaged.truncate(damaged.len() / 2);
    expect_error(el.deserialize_state(&damaged), &el, "a truncated ElevationPlant state");
}

#[test]
fn an_instance_in_error_recovers_through_reset() {
    for plant in PLANTS {
        let fmu = open(plant);
        let input = real_inputs(&fmu).remove(0);
        let run = |instance: &mut Instance| {
            instance.initialize(0.0, &[]).unwrap();
            set_reals(&fmu, instance, &[(&input, 0.5)]);
            for k in 0..100 {
                instance.do_step(k as f64 * 1e-3, 1e-3).unwrap();
            }
            output_bits(&fmu, instance)
        };
        let mut fresh = fmu.instantiate("fresh", false).unwrap();
        let reference = run(&mut fresh);

        let mut broken = initialized(&fmu, "broken", &[]);
        expect_error(broken.set_real(&[vr(&fmu, &input)], &[f64::NAN]), &broken, &format!("{plant}: NaN input"));
        // In the Error phase stepping stays refused until the master resets.
        expect_error(broken.do_step(0.0, 1e-3), &broken, &format!("{plant}: DoStep in Error"));
        broken.reset().unwrap();
        assert_eq!(run(&mut broken), reference, "{plant}: after fmi2Reset the instance does not behave like a new one");
    }
}
