//! FMU states of the packaged plant FMUs through the C ABI: a state taken with
//! fmi2GetFMUstate and restored with fmi2SetFMUstate replays a run bitwise, and a state
//! serialized from one instance and deserialized into another (even one that was never
//! initialised) continues bitwise as the original does. The runs use the default, nonlinear
//! configuration with inputs that make the drives stick, slip and (in azimuth) cross the
//! backlash, so the discrete modes are part of what must be restored. A state saved before an
//! fmi2Error recovers the run bitwise.

use antenna_tests::{expect_error, initialized, open, output_bits, real_inputs, set_reals, test_signal, vr, PLANTS};
use fmu_import::{Fmu, Instance};

/// A misuse that puts an instance into the Error phase.
type Provocation<'a> = dyn Fn(&mut Instance) + 'a;

/// Inputs at a millisecond index that reverse the drive every second with some noise.
fn inputs(plant: &str, ms: usize) -> Vec<(&'static str, f64)> {
    let common = 1.5 * (std::f64::consts::TAU * ms as f64 * 1e-3).sin() + 0.3 * test_signal(ms as u64, 5);
    let disturbance = 2e3 * test_signal((ms / 100) as u64, 6);
    if plant == "AzimuthPlant" {
        vec![
            ("motor1.current_command", common + 0.5),
            ("motor2.current_command", common - 0.5),
            ("load.disturbance_torque", disturbance),
        ]
    } else {
        vec![("motor.current_command", common), ("load.disturbance_torque", disturbance)]
    }
}

/// Steps from millisecond `from` to `to` with 1 ms steps and returns every output's bits at
/// every step.
fn run(fmu: &Fmu, plant: &str, instance: &mut Instance, from: usize, to: usize) -> Vec<Vec<u64>> {
    let mut record = Vec::new();
    for ms in from..to {
        set_reals(fmu, instance, &inputs(plant, ms));
        instance.do_step(ms as f64 * 1e-3, 1e-3).unwrap();
        record.push(output_bits(fmu, instance));
    }
    record
}

#[test]
fn a_restored_state_replays_the_run_bitwise() {
    for plant in PLANTS {
        let fmu = open(plant);
        let mut instance = initialized(&fmu, "replay", &[]);
        run(&fmu, plant, &mut instance, 0, 1000);
        let state = instance.get_state().unwrap();
        let first = run(&fmu, plant, &mut instance, 1000, 3000);
        instance.set_state(&state).unwrap();
        assert_eq!(instance.last_successful_time().unwrap(), 1.0, "{plant}: the restored state is not at its time");
        let second = run(&fmu, plant, &mut instance, 1000, 3000);
        assert!(first == second, "{plant}: the run after fmi2SetFMUstate differs from the first one");
        // The replay is not trivially equal: the outputs moved over the run.
        assert_ne!(first[0], first[first.len() - 1], "{plant}: the outputs did not change");
    }
}

#[test]
fn an_updated_state_overwrites_the_saved_one() {
    for plant in PLANTS {
        let fmu = open(plant);
        let mut instance = initialized(&fmu, "update", &[]);
        run(&fmu, plant, &mut instance, 0, 500);
        let mut state = instance.get_state().unwrap();
        run(&fmu, plant, &mut instance, 500, 1000);
        instance.update_state(&mut state).unwrap();
        let first = run(&fmu, plant, &mut instance, 1000, 1500);
        instance.set_state(&state).unwrap();
        let second = run(&fmu, plant, &mut instance, 1000, 1500);
        assert!(first == second, "{plant}: fmi2GetFMUstate into an existing state did not overwrite it");
        instance.free_state(state).unwrap();
    }
}

#[test]
fn a_state_deserialized_into_another_instance_continues_bitwise() {
    for plant in PLANTS {
        let fmu = open(plant);
        let mut original = initialized(&fmu, "original", &[]);
        run(&fmu, plant, &mut original, 0, 1000);
        let state = original.get_state().unwrap();
        let bytes = original.serialize_state(&state).unwrap();

        // One copy goes into an initialised instance that has run elsewhere, one into an
        // instance that was only instantiated: the state carries the phase and the time.
        let mut elsewhere = initialized(&fmu, "elsewhere", &[]);
        run(&fmu, plant, &mut elsewhere, 0, 137);
        let mut fresh = fmu.instantiate("fresh", false).unwrap();
        for copy in [&mut elsewhere, &mut fresh] {
            let restored = copy.deserialize_state(&bytes).unwrap();
            copy.set_state(&restored).unwrap();
            assert_eq!(
                copy.serialize_state(&restored).unwrap(),
                bytes,
                "{plant}: deserialize then serialize is not the identity"
            );
        }
        let expected = run(&fmu, plant, &mut original, 1000, 3000);
        assert!(
            run(&fmu, plant, &mut elsewhere, 1000, 3000) == expected,
            "{plant}: the deserialized state (into a used instance) continues differently"
        );
        assert!(
            run(&fmu, plant, &mut fresh, 1000, 3000) == expected,
            "{plant}: the deserialized state (into a new instance) continues differently"
        );
    }
}

#[test]
fn a_state_restores_parameters_and_inputs_as_well() {
    // A state saved with non-default parameters, restored into an instance with the defaults,
    // must bring the parameters with it: the continuation depends on them.
    for plant in PLANTS {
        let fmu = open(plant);
        let parameter = if plant == "AzimuthPlant" { "motor1.viscous_friction" } else { "motor.viscous_friction" };
        let mut original = initialized(&fmu, "tuned", &[(parameter, 3e-3)]);
        run(&fmu, plant, &mut original, 0, 300);
        let bytes = {
            let state = original.get_state().unwrap();
            original.serialize_state(&state).unwrap()
        };
        let mut other = initialized(&fmu, "default", &[]);
        let state = other.deserialize_state(&bytes).unwrap();
        other.set_state(&state).unwrap();
        assert_eq!(antenna_tests::real(&fmu, &mut other, parameter), 3e-3, "{plant}: {parameter} was not restored");
        assert!(
            run(&fmu, plant, &mut other, 300, 800) == run(&fmu, plant, &mut original, 300, 800),
            "{plant}: continuation differs"
        );
    }
}

#[test]
fn after_an_error_a_restored_state_continues_bitwise_as_an_uninterrupted_run() {
    // FMI 2.0 lets a master recover from fmi2Error by restoring a state saved before it; this
    // holds only if the rejected call changed nothing the state does not restore.
    for plant in PLANTS {
        let fmu = open(plant);
        let mut uninterrupted = initialized(&fmu, "uninterrupted", &[]);
        run(&fmu, plant, &mut uninterrupted, 0, 1000);
        let expected = run(&fmu, plant, &mut uninterrupted, 1000, 3000);

        let mut instance = initialized(&fmu, "recovering", &[]);
        run(&fmu, plant, &mut instance, 0, 1000);
        let state = instance.get_state().unwrap();
        let input = real_inputs(&fmu).remove(0);
        let provocations: [(&str, &Provocation); 2] = [
            ("a NaN input", &|instance| {
                expect_error(
                    instance.set_real(&[vr(&fmu, &input)], &[f64::NAN]),
                    instance,
                    &format!("{plant}: NaN {input}"),
                );
            }),
            ("a wrong communication point", &|instance| {
                let at = instance.last_successful_time().unwrap();
                expect_error(instance.do_step(at + 0.5, 1e-3), instance, &format!("{plant}: DoStep ahead of time"));
            }),
        ];
        for (what, provoke) in provocations {
            // Run on past the saved point, so that restoring has something to undo.
            run(&fmu, plant, &mut instance, 1000, 1377);
            provoke(&mut instance);
            // The instance is in the Error phase: it refuses to step until restored.
            expect_error(instance.do_step(1.377, 1e-3), &instance, &format!("{plant}: DoStep after {what}"));
            instance.set_state(&state).unwrap_or_else(|e| panic!("{plant}: fmi2SetFMUstate after {what}: {e}"));
            assert!(
                run(&fmu, plant, &mut instance, 1000, 3000) == expected,
                "{plant}: after {what} and fmi2SetFMUstate the run differs from the uninterrupted one"
            );
            instance.set_state(&state).unwrap();
        }
    }
}

#[test]
fn truncated_or_corrupt_states_are_refused_with_a_reason_never_a_panic() {
    for plant in PLANTS {
        let fmu = open(plant);
        let mut original = initialized(&fmu, "original", &[]);
        run(&fmu, plant, &mut original, 0, 500);
        let state = original.get_state().unwrap();
        let bytes = original.serialize_state(&state).unwrap();
        let mut target = fmu.instantiate("target", false).unwrap();
        for cut in 0..bytes.len() {
            let messages =
                expect_error(target.deserialize_state(&bytes[..cut]), &target, &format!("{plant}: cut at {cut}"));
            assert!(messages.iter().all(|m| !m.contains("panic")), "{plant}: cut at {cut}: {messages:?}");
        }
        // A corrupted byte may still decode (a number's bits); if it does not, the reason is
        // the decoder's or the model's, never a panic.
        for i in 0..bytes.len() {
            let mut corrupt = bytes.clone();
            corrupt[i] ^= 0xA5;
            match target.deserialize_state(&corrupt) {
                Ok(restored) => {
                    target.free_state(restored).unwrap();
                }
                Err(e) => assert!(!e.to_string().contains("panic"), "{plant}: byte {i}: {e}"),
            }
        }
    }
}
