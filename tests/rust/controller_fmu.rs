//! The packaged controller FMUs (`AzimuthController`, `ElevationController`) through the C ABI:
//!
//! * misuse, as for the plants (tests/rust/plant_misuse.rs): DoStep before initialisation and
//!   after Terminate, a second Terminate, a wrong GUID, NaN inputs, unknown value references,
//!   bad step sizes and a wrong communication point all return fmi2Error (fmi2Instantiate: NULL)
//!   with a logged message, and change nothing;
//! * FMU states: a restored (or serialized and deserialized) state replays a run bitwise, also
//!   with outputs still queued in the computation delay;
//! * the sample clock of docs/controller.md section 3: the controller samples on its own grid
//!   `t0 + k Ts` (Ts = 1 ms) whatever the master's step. With 1 ms steps each step's output is
//!   the sample taken at its start; with 0.5 ms steps (smaller than Ts) an output appears exactly
//!   `Ts` after its sample and holds over the step in between, whose inputs are never sampled;
//!   with 2.5 ms steps (not a multiple) a step holds 3, 2, 3, 2 ... samples, all taking the
//!   inputs held over it, and the output is the newest one due, nothing interpolated. Each is
//!   checked bitwise against a 1 ms run fed the inputs the samples see.

use antenna_tests::{expect_error, initialized, open, output_bits, real, real_inputs, set_reals, test_signal, vr};
use fmu_import::{Fmu, ImportError, Instance};

const CONTROLLERS: [&str; 2] = ["AzimuthController", "ElevationController"];

/// The controllers' sample time, s (the FMUs' default, which these tests rely on).
const TS: f64 = 1e-3;

#[test]
fn the_controllers_sample_every_millisecond_by_default() {
    // The sample-clock tests below are built on Ts = 1 ms.
    for controller in CONTROLLERS {
        let fmu = open(controller);
        let mut instance = initialized(&fmu, "defaults", &[]);
        assert_eq!(real(&fmu, &mut instance, "sampling.sample_time"), TS, "{controller}");
    }
}

// ---------------------------------------------------------------------------------------------
// Misuse

#[test]
fn stepping_outside_the_stepping_phase_and_terminating_twice_are_errors() {
    for controller in CONTROLLERS {
        let fmu = open(controller);
        let mut instance = fmu.instantiate("before-init", false).unwrap();
        expect_error(instance.do_step(0.0, TS), &instance, &format!("{controller}: DoStep when instantiated"));
        let mut instance = fmu.instantiate("in-init", false).unwrap();
        instance.setup_experiment(0.0, None).unwrap();
        instance.enter_initialization_mode().unwrap();
        expect_error(instance.do_step(0.0, TS), &instance, &format!("{controller}: DoStep in initialisation mode"));

        let mut instance = initialized(&fmu, "after-terminate", &[]);
        instance.do_step(0.0, TS).unwrap();
        instance.terminate().unwrap();
        let messages =
            expect_error(instance.do_step(TS, TS), &instance, &format!("{controller}: DoStep after Terminate"));
        assert!(
            messages.iter().any(|m| m.contains("Terminated")),
            "{controller}: the message does not name the phase: {messages:?}"
        );
        // The outputs stay readable for diagnosis.
        real(&fmu, &mut instance, "status.torque_command");
        expect_error(instance.terminate(), &instance, &format!("{controller}: second Terminate"));
    }
}

#[test]
fn a_wrong_guid_gives_null_with_a_logged_message() {
    for controller in CONTROLLERS {
        let fmu = open(controller);
        // The two controllers share one library: the other controller's GUID must not give this
        // model, nor must a malformed one give any.
        let other = open(CONTROLLERS.iter().find(|c| **c != controller).unwrap());
        for guid in ["{00000000-0000-0000-0000-000000000000}", "", "not a guid at all"] {
            match fmu.instantiate_with("wrong-guid", guid, false, false) {
                Err(ImportError::Instantiate { messages }) => {
                    assert!(
                        messages.iter().any(|m| m.contains("GUID")),
                        "{controller}: the message does not mention the GUID: {messages:?}"
                    );
                }
                Err(other) => panic!("{controller}: expected NULL from fmi2Instantiate, got {other}"),
                Ok(_) => panic!("{controller}: fmi2Instantiate accepted the GUID '{guid}'"),
            }
        }
        assert_ne!(fmu.description.guid, other.description.guid, "the two controllers share a GUID");
        let mut instance = initialized(&fmu, "after-wrong-guid", &[]);
        instance.do_step(0.0, TS).unwrap();
    }
}

#[test]
fn nan_and_infinite_inputs_are_rejected_and_change_nothing() {
    for controller in CONTROLLERS {
        let fmu = open(controller);
        let inputs = real_inputs(&fmu);
        assert!(inputs.len() >= 6, "{controller}: only {inputs:?}");
        for input in inputs {
            for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                let mut instance = initialized(&fmu, "bad-input", &[]);
                instance.do_step(0.0, TS).unwrap();
                let before = real(&fmu, &mut instance, &input);
                let messages = expect_error(
                    instance.set_real(&[vr(&fmu, &input)], &[bad]),
                    &instance,
                    &format!("{controller}: {input} = {bad}"),
                );
                assert!(
                    messages.iter().any(|m| m.contains(&input)),
                    "{controller}: the message does not name {input}: {messages:?}"
                );
                assert_eq!(
                    real(&fmu, &mut instance, &input).to_bits(),
                    before.to_bits(),
                    "{controller}: the rejected {input} = {bad} changed it"
                );
            }
        }
        // A parameter too, during initialisation.
        let mut instance = fmu.instantiate("bad-parameter", false).unwrap();
        instance.setup_experiment(0.0, None).unwrap();
        instance.enter_initialization_mode().unwrap();
        expect_error(
            instance.set_real(&[vr(&fmu, "sampling.sample_time")], &[f64::NAN]),
            &instance,
            &format!("{controller}: NaN sample time"),
        );
    }
}

#[test]
fn unknown_value_references_are_rejected() {
    for controller in CONTROLLERS {
        let fmu = open(controller);
        let unknown = fmu.description.variables.iter().map(|v| v.value_reference).max().unwrap() + 1;
        for reference in [unknown, u32::MAX] {
            let mut instance = initialized(&fmu, "unknown-vr", &[]);
            expect_error(
                instance.get_real(&[reference], &mut [0.0]),
                &instance,
                &format!("{controller}: GetReal of {reference}"),
            );
            let mut instance = initialized(&fmu, "unknown-vr", &[]);
            expect_error(
                instance.set_real(&[reference], &[1.0]),
                &instance,
                &format!("{controller}: SetReal of {reference}"),
            );
            let mut instance = initialized(&fmu, "unknown-vr", &[]);
            expect_error(
                instance.get_boolean(&[reference], &mut [false]),
                &instance,
                &format!("{controller}: GetBoolean of {reference}"),
            );
        }
        // The mode is an enumeration (Integer calls); reading it as a Real is as wrong.
        let mut instance = initialized(&fmu, "wrong-type", &[]);
        expect_error(
            instance.get_real(&[vr(&fmu, "mode")], &mut [0.0]),
            &instance,
            &format!("{controller}: GetReal of the mode"),
        );
    }
}

#[test]
fn negative_zero_and_non_finite_step_sizes_are_rejected() {
    for controller in CONTROLLERS {
        let fmu = open(controller);
        for h in [-TS, 0.0, f64::NAN, f64::INFINITY] {
            let mut instance = initialized(&fmu, "bad-step", &[]);
            set_reals(&fmu, &mut instance, &[("command.position", 1.0)]);
            let before = output_bits(&fmu, &mut instance);
            expect_error(instance.do_step(0.0, h), &instance, &format!("{controller}: step {h}"));
            assert_eq!(
                instance.last_successful_time().unwrap(),
                0.0,
                "{controller}: a rejected step {h} moved the time"
            );
            assert_eq!(
                output_bits(&fmu, &mut instance),
                before,
                "{controller}: a rejected step {h} changed the outputs"
            );
        }
    }
}

#[test]
fn a_wrong_communication_point_is_rejected() {
    for controller in CONTROLLERS {
        let fmu = open(controller);
        for (steps_done, point) in [(0, 0.5), (0, -TS), (10, 5.0 * TS), (10, 11.0 * TS)] {
            let mut instance = initialized(&fmu, "wrong-point", &[]);
            for k in 0..steps_done {
                instance.do_step(k as f64 * TS, TS).unwrap();
            }
            let messages = expect_error(
                instance.do_step(point, TS),
                &instance,
                &format!("{controller}: DoStep at {point} after {steps_done} steps"),
            );
            assert!(messages.iter().any(|m| m.contains("currentCommunicationPoint")), "{controller}: {messages:?}");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Inputs used by the state and sample-clock tests

/// The inputs of the `n`-th input set: a 0.2 deg position step (the profiler, the loops and the
/// integrators all move), an encoder and motor speeds that wander (deterministic noise), so
/// every output changes at every sample.
fn inputs(controller: &str, n: u64, seed: u64) -> Vec<(&'static str, f64)> {
    let speed = |s: u64| 2.0 + 0.5 * test_signal(n, seed + s);
    let mut values = vec![
        ("command.position", 45.2),
        ("command.velocity", 0.0),
        ("measured.position", 45.0 + 1e-3 * test_signal(n, seed + 10)),
    ];
    if controller == "AzimuthController" {
        values.extend([("measured.motor1_speed", speed(1)), ("measured.motor2_speed", speed(2))]);
    } else {
        values.push(("measured.motor_speed", speed(1)));
    }
    values
}

const START: [(&str, f64); 2] = [("command.position", 45.0), ("measured.position", 45.0)];

/// Steps with `h` from `from` to `to` (step indices), feeding input set `input_of(step)`, and
/// returns every output's bits after every step.
fn run(
    fmu: &Fmu,
    controller: &str,
    instance: &mut Instance,
    h: f64,
    steps: std::ops::Range<u64>,
    input_of: impl Fn(u64) -> u64,
) -> Vec<Vec<u64>> {
    steps
        .map(|n| {
            set_reals(fmu, instance, &inputs(controller, input_of(n), 7));
            instance.do_step(n as f64 * h, h).unwrap_or_else(|e| panic!("{controller}: step {n} of {h} s: {e}"));
            output_bits(fmu, instance)
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------
// FMU states

#[test]
fn a_restored_state_replays_the_run_bitwise_also_with_outputs_in_the_delay_queue() {
    for controller in CONTROLLERS {
        let fmu = open(controller);
        // 1 ms steps with the default delay; 0.5 ms steps with a 3-sample delay, so that the
        // state is taken between samples with three computed outputs not yet in force.
        for (h, delay) in [(TS, 1), (0.5 * TS, 3)] {
            let mut instance = controller_with_delay(&fmu, delay);
            run(&fmu, controller, &mut instance, h, 0..501, |n| n);
            let state = instance.get_state().unwrap();
            let bytes = instance.serialize_state(&state).unwrap();
            let first = run(&fmu, controller, &mut instance, h, 501..1500, |n| n);
            instance.set_state(&state).unwrap();
            let second = run(&fmu, controller, &mut instance, h, 501..1500, |n| n);
            assert!(first == second, "{controller}, h = {h}, delay {delay}: the run after fmi2SetFMUstate differs");
            // Into another instance, through the serialized bytes.
            let mut other = initialized(&fmu, "other", &[]);
            let restored = other.deserialize_state(&bytes).unwrap();
            other.set_state(&restored).unwrap();
            let third = run(&fmu, controller, &mut other, h, 501..1500, |n| n);
            assert!(
                first == third,
                "{controller}, h = {h}, delay {delay}: the deserialized state does not continue the run"
            );
            assert_ne!(first[0], first[first.len() - 1], "{controller}: the outputs did not change");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The sample clock

/// A controller instance at rest at 45 deg, with the given delay.
fn controller_with_delay(fmu: &Fmu, delay: i32) -> Instance {
    let mut instance = fmu.instantiate("clock", false).unwrap();
    instance.setup_experiment(0.0, None).unwrap();
    instance.enter_initialization_mode().unwrap();
    set_reals(fmu, &mut instance, &START);
    instance.set_integer(&[vr(fmu, "sampling.delay_samples")], &[delay]).unwrap();
    instance.exit_initialization_mode().unwrap();
    instance
}

#[test]
fn with_steps_of_one_sample_each_output_is_the_sample_taken_at_the_steps_start_delayed_by_the_parameter() {
    for controller in CONTROLLERS {
        let fmu = open(controller);
        let mut one = controller_with_delay(&fmu, 1);
        let idle = output_bits(&fmu, &mut one);
        let d1 = run(&fmu, controller, &mut one, TS, 0..300, |n| n);
        // Every step brings a new sample's output.
        for n in 1..d1.len() {
            assert_ne!(d1[n], d1[n - 1], "{controller}: output unchanged over step {n}");
        }
        // An input set fed at t_n acts in the output at t_n+1 (one sample: the delay of 1 and
        // the co-simulation step coincide); with a 3-sample delay, at t_n+3: the same outputs,
        // two steps later, and the idle output until then.
        let mut three = controller_with_delay(&fmu, 3);
        let d3 = run(&fmu, controller, &mut three, TS, 0..300, |n| n);
        assert_eq!(d3[0], idle, "{controller}: delay 3, output at 1 ms");
        assert_eq!(d3[1], idle, "{controller}: delay 3, output at 2 ms");
        for n in 2..d3.len() {
            assert_eq!(d3[n], d1[n - 2], "{controller}: delay 3 is not delay 1 shifted by two samples at step {n}");
        }
    }
}

#[test]
fn with_half_sample_steps_outputs_change_only_at_sample_instants_and_inputs_between_samples_are_not_seen() {
    for controller in CONTROLLERS {
        let fmu = open(controller);
        let reference = run(&fmu, controller, &mut controller_with_delay(&fmu, 1), TS, 0..300, |n| n);
        let mut half = controller_with_delay(&fmu, 1);
        let idle = output_bits(&fmu, &mut half);
        // Steps [k, k + 0.5) ms hold sample k and get input set k; steps [k + 0.5, k + 1) ms
        // hold no sample and get an input set the 1 ms run never sees (1000 + k).
        let outputs =
            run(&fmu, controller, &mut half, 0.5 * TS, 0..600, |n| if n % 2 == 0 { n / 2 } else { 1000 + n / 2 });
        // outputs[n] is the output at (n + 1) / 2 ms.
        assert_eq!(outputs[0], idle, "{controller}: at 0.5 ms no output is due yet");
        for k in 0..299 {
            let at_whole = &outputs[2 * k + 1]; // (k + 1) ms
            let at_half = &outputs[2 * k + 2]; // (k + 1.5) ms
            assert_eq!(at_whole, &reference[k], "{controller}: at {} ms the output is not sample {k}'s", k + 1);
            assert_eq!(
                at_half,
                at_whole,
                "{controller}: the output changed between sample instants at {} ms",
                k as f64 + 1.5
            );
        }
    }
}

#[test]
fn with_steps_of_two_and_a_half_samples_each_step_executes_the_samples_on_its_span_with_its_inputs() {
    for controller in CONTROLLERS {
        let fmu = open(controller);
        // Step j spans [2.5 j, 2.5 j + 2.5) ms and holds input set j. Sample k (at k ms) lies in
        // step floor(k / 2.5) = floor(2k / 5): the 1 ms run fed that input set at sample k is what
        // the 2.5 ms run must reproduce.
        let reference = run(&fmu, controller, &mut controller_with_delay(&fmu, 1), TS, 0..300, |k| 2 * k / 5);
        let outputs = run(&fmu, controller, &mut controller_with_delay(&fmu, 1), 2.5 * TS, 0..100, |j| j);
        // (Step j holds the samples ceil(2.5 j) .. ceil(2.5 j + 2.5) - 1: 3, 2, 3, 2 ... of them;
        // matching the 1 ms run at every step end shows that exactly those ran, with the step's
        // inputs, and that the output in force is the newest due.)
        for (j, output) in outputs.iter().enumerate() {
            // At the end of step j, T = 2.5 (j + 1) ms, the newest output due is the one of the
            // sample at floor(T) - 1 ms, which the 1 ms run shows after its step floor(T) - 1.
            let end_ms = 5 * (j + 1) / 2;
            assert_eq!(output, &reference[end_ms - 1], "{controller}: output at {} ms", 2.5 * (j + 1) as f64);
        }
    }
}
