//! The functions the packaged FMUs do not provide (the ten model-exchange functions, the
//! directional and input/output derivatives, fmi2CancelStep), called through the C ABI with
//! valid arguments: each must return fmi2Error with a "not supported" message naming the
//! function, write nothing into the master's buffers, and leave the instance as it was, so that
//! a master probing capabilities can go on with it. FMI 2.0.2 (section 2.1.3) lets a master
//! give up on an instance after fmi2Error; it does not oblige the FMU to refuse further calls.
//!
//! The calls are made through raw function pointers, which needs `unsafe`, which only this
//! crate may contain.

mod common;

use std::ffi::c_void;

use common::{packaged_fmus, ready, Others};
use fmi2_ffi::*;
use fmu_import::{Fmu, Instance};

/// Calls every unsupported function once on `instance` with valid pointers and checks each
/// answer; returns how many were called.
fn probe_every_unsupported_function(fmu: &Fmu, instance: &Instance) -> usize {
    let id = &fmu.description.model_identifier;
    let o = Others::load(fmu);
    let f = instance.functions();
    let c = instance.component();
    let vr = [fmu.description.variables[0].value_reference];
    let orders = [1 as fmi2Integer];
    let input = [0.25f64];
    // Buffers the FMU must not write: a NaN with a payload no computation produces.
    let sentinel = f64::from_bits(0x7FF8_DEAD_BEEF_0001);
    let mut output = [sentinel];
    let mut event_info = [0xA5u8; 64];
    let mut flags = [7 as fmi2Boolean; 2];
    type Call<'a> = Box<dyn FnMut() -> fmi2Status + 'a>;
    let mut calls: Vec<(&str, Call)> = Vec::new();
    let out = output.as_mut_ptr();
    let info = event_info.as_mut_ptr() as *mut c_void;
    let (flag0, flag1) = (&mut flags[0] as *mut fmi2Boolean, &mut flags[1] as *mut fmi2Boolean);
    // SAFETY (for every closure): `c` is a live instance of this library and every pointer
    // points to a buffer of the announced length that outlives the calls.
    // SAFETY: a live instance and buffers of the announced length (see above).
    calls.push(("fmi2EnterEventMode", Box::new(|| unsafe { (f.enter_event_mode)(c) })));
    // SAFETY: a live instance and buffers of the announced length (see above).
    calls.push(("fmi2NewDiscreteStates", Box::new(|| unsafe { (o.new_discrete_states)(c, info) })));
    // SAFETY: a live instance and buffers of the announced length (see above).
    calls.push(("fmi2EnterContinuousTimeMode", Box::new(|| unsafe { (o.enter_continuous_time_mode)(c) })));
    calls.push((
        "fmi2CompletedIntegratorStep",
        // SAFETY: a live instance and buffers of the announced length (see above).
        Box::new(|| unsafe { (o.completed_integrator_step)(c, fmi2True, flag0, flag1) }),
    ));
    // SAFETY: a live instance and buffers of the announced length (see above).
    calls.push(("fmi2SetTime", Box::new(|| unsafe { (o.set_time)(c, 0.5) })));
    // SAFETY: a live instance and buffers of the announced length (see above).
    calls.push(("fmi2SetContinuousStates", Box::new(|| unsafe { (o.set_continuous_states)(c, input.as_ptr(), 1) })));
    for (name, get) in o.get_arrays {
        // SAFETY: a live instance and buffers of the announced length (see above).
        calls.push((name, Box::new(move || unsafe { get(c, out, 1) })));
    }
    calls.push((
        "fmi2GetDirectionalDerivative",
        // SAFETY: a live instance and buffers of the announced length (see above).
        Box::new(|| unsafe { (o.get_directional_derivative)(c, vr.as_ptr(), 1, vr.as_ptr(), 1, input.as_ptr(), out) }),
    ));
    calls.push((
        "fmi2SetRealInputDerivatives",
        // SAFETY: a live instance and buffers of the announced length (see above).
        Box::new(|| unsafe { (o.set_real_input_derivatives)(c, vr.as_ptr(), 1, orders.as_ptr(), input.as_ptr()) }),
    ));
    calls.push((
        "fmi2GetRealOutputDerivatives",
        // SAFETY: a live instance and buffers of the announced length (see above).
        Box::new(|| unsafe { (o.get_real_output_derivatives)(c, vr.as_ptr(), 1, orders.as_ptr(), out) }),
    ));
    // SAFETY: a live instance and buffers of the announced length (see above).
    calls.push(("fmi2CancelStep", Box::new(|| unsafe { (f.cancel_step)(c) })));
    let count = calls.len();
    for (name, call) in &mut calls {
        let before = instance.log_records().len();
        let status = call();
        assert_eq!(status, fmi2Error, "{id}: {name} returned {status}");
        let logged = instance.log_records();
        let messages: Vec<&str> =
            logged[before..].iter().filter(|r| r.category == "logStatusError").map(|r| r.message.as_str()).collect();
        assert!(
            messages.iter().any(|m| m.starts_with(&format!("{name}: not supported"))),
            "{id}: {name} did not log why it is not supported: {messages:?}"
        );
    }
    drop(calls);
    assert_eq!(output[0].to_bits(), sentinel.to_bits(), "{id}: an unsupported function wrote into the master's buffer");
    assert!(
        event_info.iter().all(|&b| b == 0xA5) && flags == [7, 7],
        "{id}: an unsupported function wrote into the master's flags"
    );
    count
}

/// Every Real output, as bits, after `steps` steps of 1 ms from `from`.
fn run(fmu: &Fmu, instance: &mut Instance, from: usize, steps: usize) -> Vec<u64> {
    for k in from..from + steps {
        instance
            .do_step(k as f64 * 1e-3, 1e-3)
            .unwrap_or_else(|e| panic!("{}: step {k}: {e}", fmu.description.model_identifier));
    }
    let vrs: Vec<u32> = fmu
        .description
        .variables
        .iter()
        .filter(|v| v.causality == "output" && v.type_name == "Real")
        .map(|v| v.value_reference)
        .collect();
    let mut values = vec![0.0; vrs.len()];
    instance.get_real(&vrs, &mut values).unwrap();
    values.iter().map(|v| v.to_bits()).collect()
}

#[test]
fn unsupported_functions_log_not_supported_and_the_instance_steps_on_as_if_never_asked() {
    for fmu in packaged_fmus() {
        let id = fmu.description.model_identifier.clone();
        let mut untouched = ready(&fmu);
        let mut probed = ready(&fmu);
        run(&fmu, &mut untouched, 0, 100);
        run(&fmu, &mut probed, 0, 100);
        assert_eq!(
            probe_every_unsupported_function(&fmu, &probed),
            14,
            "{id}: the list of unsupported functions changed"
        );
        // The probed instance is still stepping, from where it was, exactly as the other.
        assert_eq!(probed.last_successful_time().unwrap(), 0.1, "{id}");
        assert_eq!(
            run(&fmu, &mut probed, 100, 100),
            run(&fmu, &mut untouched, 100, 100),
            "{id}: probing changed the run"
        );
    }
}

#[test]
fn unsupported_functions_before_initialisation_leave_the_instance_initialisable() {
    for fmu in packaged_fmus() {
        let id = fmu.description.model_identifier.clone();
        let mut instance = fmu.instantiate("probed-early", false).unwrap();
        probe_every_unsupported_function(&fmu, &instance);
        instance.initialize(0.0, &[]).unwrap_or_else(|e| panic!("{id}: initialisation after probing: {e}"));
        run(&fmu, &mut instance, 0, 10);
    }
}
