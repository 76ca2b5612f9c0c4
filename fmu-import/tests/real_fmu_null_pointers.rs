//! NULL pointers passed to the real, packaged FMUs through the C ABI: every exported function
//! must treat a NULL instance as an error (fmi2FreeInstance(NULL) as a no-op), accept NULL
//! arrays when it is told there are zero elements, and answer any other NULL with fmi2Error
//! and a message through the logger, never with a crash.
//!
//! These calls break the importer's safe API on purpose, so they need `unsafe`, which only this
//! crate may contain. The FMUs are loaded through `fmu_import` exactly as a master
//! loads them (where they are found: `common`).

mod common;

use std::ffi::{c_void, CString};

use common::{packaged_fmus, ready, Others};
use fmi2_ffi::*;
use fmu_import::{Fmu, Instance, LoggerCallbacks};

/// Asserts fmi2Error and a message about a NULL pointer in the instance's log.
fn assert_null_error(fmu: &Fmu, instance: &Instance, status: fmi2Status, call: &str) {
    let name = &fmu.description.model_identifier;
    assert_eq!(status, fmi2Error, "{name}: {call} returned {status}, expected fmi2Error");
    let log = instance.log_records();
    assert!(
        log.iter().any(|r| r.status == fmi2_ffi::Status::Error && r.message.contains("NULL")),
        "{name}: {call} logged no message about the NULL pointer: {log:?}"
    );
}

#[test]
fn free_instance_of_null_is_harmless() {
    for fmu in packaged_fmus() {
        // SAFETY: FMI 2.0 makes fmi2FreeInstance(NULL) legal; the FMU must ignore it.
        unsafe { (fmu.library.functions.free_instance)(std::ptr::null_mut()) };
        // The library still works afterwards.
        let mut instance = ready(&fmu);
        instance.do_step(0.0, 1e-3).expect("a step after fmi2FreeInstance(NULL)");
    }
}

#[test]
fn every_function_given_a_null_instance_returns_fmi2_error() {
    for fmu in packaged_fmus() {
        let f = &fmu.library.functions;
        let o = Others::load(&fmu);
        let null: fmi2Component = std::ptr::null_mut();
        let vr = [0u32];
        let mut real = [0.0f64];
        let mut integer = [0 as fmi2Integer];
        let mut string: [fmi2String; 1] = [std::ptr::null()];
        let text = CString::new("x").unwrap();
        let texts = [text.as_ptr()];
        let mut state: fmi2FMUstate = std::ptr::null_mut();
        let mut size = 0usize;
        let mut bytes = [0 as fmi2Byte; 8];
        let mut status: fmi2Status = fmi2OK;
        let mut flags = [0 as fmi2Boolean; 2];
        let orders = [1 as fmi2Integer];
        // SAFETY: every pointer but the instance is valid for the call; the NULL instance is
        // the misuse under test, which the FMU must detect before dereferencing anything.
        // SAFETY: a live instance; the NULL is the misuse under test (see above).
        let results: Vec<(&str, fmi2Status)> = unsafe {
            vec![
                ("fmi2SetDebugLogging", (f.set_debug_logging)(null, fmi2True, 0, std::ptr::null())),
                ("fmi2SetupExperiment", (f.setup_experiment)(null, fmi2False, 0.0, 0.0, fmi2False, 0.0)),
                ("fmi2EnterInitializationMode", (f.enter_initialization_mode)(null)),
                ("fmi2ExitInitializationMode", (f.exit_initialization_mode)(null)),
                ("fmi2Terminate", (f.terminate)(null)),
                ("fmi2Reset", (f.reset)(null)),
                ("fmi2GetReal", (f.get_real)(null, vr.as_ptr(), 1, real.as_mut_ptr())),
                ("fmi2GetInteger", (f.get_integer)(null, vr.as_ptr(), 1, integer.as_mut_ptr())),
                ("fmi2GetBoolean", (f.get_boolean)(null, vr.as_ptr(), 1, integer.as_mut_ptr())),
                ("fmi2GetString", (f.get_string)(null, vr.as_ptr(), 1, string.as_mut_ptr())),
                ("fmi2SetReal", (f.set_real)(null, vr.as_ptr(), 1, real.as_ptr())),
                ("fmi2SetInteger", (f.set_integer)(null, vr.as_ptr(), 1, integer.as_ptr())),
                ("fmi2SetBoolean", (f.set_boolean)(null, vr.as_ptr(), 1, integer.as_ptr())),
                ("fmi2SetString", (f.set_string)(null, vr.as_ptr(), 1, texts.as_ptr())),
                ("fmi2GetFMUstate", (f.get_fmu_state)(null, &mut state)),
                ("fmi2SetFMUstate", (f.set_fmu_state)(null, state)),
                ("fmi2FreeFMUstate", (f.free_fmu_state)(null, &mut state)),
                ("fmi2SerializedFMUstateSize", (f.serialized_fmu_state_size)(null, state, &mut size)),
                ("fmi2SerializeFMUstate", (f.serialize_fmu_state)(null, state, bytes.as_mut_ptr(), bytes.len())),
                ("fmi2DeSerializeFMUstate", (f.deserialize_fmu_state)(null, bytes.as_ptr(), bytes.len(), &mut state)),
                (
                    "fmi2GetDirectionalDerivative",
                    (o.get_directional_derivative)(
                        null,
                        vr.as_ptr(),
                        1,
                        vr.as_ptr(),
                        1,
                        real.as_ptr(),
                        real.as_mut_ptr(),
                    ),
                ),
                ("fmi2EnterEventMode", (f.enter_event_mode)(null)),
                ("fmi2NewDiscreteStates", (o.new_discrete_states)(null, bytes.as_mut_ptr() as *mut c_void)),
                ("fmi2EnterContinuousTimeMode", (o.enter_continuous_time_mode)(null)),
                (
                    "fmi2CompletedIntegratorStep",
                    (o.completed_integrator_step)(null, fmi2True, &mut flags[0], &mut flags[1]),
                ),
                ("fmi2SetTime", (o.set_time)(null, 0.0)),
                ("fmi2SetContinuousStates", (o.set_continuous_states)(null, real.as_ptr(), 1)),
                (o.get_arrays[0].0, (o.get_arrays[0].1)(null, real.as_mut_ptr(), 1)),
                (o.get_arrays[1].0, (o.get_arrays[1].1)(null, real.as_mut_ptr(), 1)),
                (o.get_arrays[2].0, (o.get_arrays[2].1)(null, real.as_mut_ptr(), 1)),
                (o.get_arrays[3].0, (o.get_arrays[3].1)(null, real.as_mut_ptr(), 1)),
                (
                    "fmi2SetRealInputDerivatives",
                    (o.set_real_input_derivatives)(null, vr.as_ptr(), 1, orders.as_ptr(), real.as_ptr()),
                ),
                (
                    "fmi2GetRealOutputDerivatives",
                    (o.get_real_output_derivatives)(null, vr.as_ptr(), 1, orders.as_ptr(), real.as_mut_ptr()),
                ),
                ("fmi2DoStep", (f.do_step)(null, 0.0, 1e-3, fmi2True)),
                ("fmi2CancelStep", (f.cancel_step)(null)),
                ("fmi2GetStatus", (f.get_status)(null, fmi2DoStepStatus, &mut status)),
                ("fmi2GetRealStatus", (f.get_real_status)(null, fmi2LastSuccessfulTime, real.as_mut_ptr())),
                ("fmi2GetIntegerStatus", (f.get_integer_status)(null, fmi2DoStepStatus, integer.as_mut_ptr())),
                ("fmi2GetBooleanStatus", (f.get_boolean_status)(null, fmi2Terminated, integer.as_mut_ptr())),
                ("fmi2GetStringStatus", (f.get_string_status)(null, fmi2PendingStatus, string.as_mut_ptr())),
            ]
        };
        // 44 functions less the two without an instance, fmi2Instantiate and fmi2FreeInstance.
        assert_eq!(results.len(), 40);
        for (name, status) in results {
            assert_eq!(status, fmi2Error, "{}: {name}(NULL, ...) returned {status}", fmu.description.model_identifier);
        }
        assert!(state.is_null(), "a call with a NULL instance wrote a state");
    }
}

#[test]
fn null_arrays_are_accepted_when_no_elements_are_announced() {
    for fmu in packaged_fmus() {
        let mut instance = ready(&fmu);
        let c = instance.component();
        let f = instance.functions();
        // SAFETY: n == 0, so the FMU must not touch the (NULL) arrays: the standard's short-cut.
        let results = unsafe {
            [
                ("fmi2GetReal", (f.get_real)(c, std::ptr::null(), 0, std::ptr::null_mut())),
                ("fmi2GetInteger", (f.get_integer)(c, std::ptr::null(), 0, std::ptr::null_mut())),
                ("fmi2GetBoolean", (f.get_boolean)(c, std::ptr::null(), 0, std::ptr::null_mut())),
                ("fmi2GetString", (f.get_string)(c, std::ptr::null(), 0, std::ptr::null_mut())),
                ("fmi2SetReal", (f.set_real)(c, std::ptr::null(), 0, std::ptr::null())),
                ("fmi2SetInteger", (f.set_integer)(c, std::ptr::null(), 0, std::ptr::null())),
                ("fmi2SetBoolean", (f.set_boolean)(c, std::ptr::null(), 0, std::ptr::null())),
                ("fmi2SetString", (f.set_string)(c, std::ptr::null(), 0, std::ptr::null())),
                ("fmi2SetDebugLogging", (f.set_debug_logging)(c, fmi2False, 0, std::ptr::null())),
            ]
        };
        for (name, status) in results {
            assert_eq!(
                status, fmi2OK,
                "{}: {name} with n = 0 and NULL arrays returned {status}",
                fmu.description.model_identifier
            );
        }
        instance.do_step(0.0, 1e-3).expect("the instance is still usable");
    }
}

#[test]
fn null_arrays_with_elements_announced_are_errors_with_a_message() {
    for fmu in packaged_fmus() {
        let vr = [fmu.description.variables[0].value_reference];
        let null_vr: *const u32 = std::ptr::null();
        let mut real = [0.0f64];
        let mut integer = [0 as fmi2Integer];
        let mut string: [fmi2String; 1] = [std::ptr::null()];
        let text = CString::new("x").unwrap();
        let texts = [text.as_ptr()];
        type Call<'a> = Box<dyn Fn(&Functions, fmi2Component) -> fmi2Status + 'a>;
        use fmu_import::Functions;
        // Each call gets a fresh instance: after the first error the instance is in the Error
        // phase, where setters are refused for that reason instead.
        let (real_ptr, integer_ptr, string_ptr) = (real.as_mut_ptr(), integer.as_mut_ptr(), string.as_mut_ptr());
        // SAFETY (for every closure): the component is a live instance and every non-NULL
        // pointer points to one element; the NULL one is the misuse under test.
        let calls: Vec<(&str, Call)> = vec![
            // SAFETY: a live instance; the NULL is the misuse under test (see above).
            ("fmi2GetReal(vr = NULL)", Box::new(|f, c| unsafe { (f.get_real)(c, null_vr, 1, real_ptr) })),
            (
                "fmi2GetReal(value = NULL)",
                // SAFETY: a live instance; the NULL is the misuse under test (see above).
                Box::new(|f, c| unsafe { (f.get_real)(c, vr.as_ptr(), 1, std::ptr::null_mut()) }),
            ),
            // SAFETY: a live instance; the NULL is the misuse under test (see above).
            ("fmi2GetInteger(vr = NULL)", Box::new(|f, c| unsafe { (f.get_integer)(c, null_vr, 1, integer_ptr) })),
            (
                "fmi2GetInteger(value = NULL)",
                // SAFETY: a live instance; the NULL is the misuse under test (see above).
                Box::new(|f, c| unsafe { (f.get_integer)(c, vr.as_ptr(), 1, std::ptr::null_mut()) }),
            ),
            // SAFETY: a live instance; the NULL is the misuse under test (see above).
            ("fmi2GetBoolean(vr = NULL)", Box::new(|f, c| unsafe { (f.get_boolean)(c, null_vr, 1, integer_ptr) })),
            (
                "fmi2GetBoolean(value = NULL)",
                // SAFETY: a live instance; the NULL is the misuse under test (see above).
                Box::new(|f, c| unsafe { (f.get_boolean)(c, vr.as_ptr(), 1, std::ptr::null_mut()) }),
            ),
            // SAFETY: a live instance; the NULL is the misuse under test (see above).
            ("fmi2GetString(vr = NULL)", Box::new(|f, c| unsafe { (f.get_string)(c, null_vr, 1, string_ptr) })),
            (
                "fmi2GetString(value = NULL)",
                // SAFETY: a live instance; the NULL is the misuse under test (see above).
                Box::new(|f, c| unsafe { (f.get_string)(c, vr.as_ptr(), 1, std::ptr::null_mut()) }),
            ),
            // SAFETY: a live instance; the NULL is the misuse under test (see above).
            ("fmi2SetReal(vr = NULL)", Box::new(|f, c| unsafe { (f.set_real)(c, null_vr, 1, real.as_ptr()) })),
            (
                "fmi2SetReal(value = NULL)",
                // SAFETY: a live instance; the NULL is the misuse under test (see above).
                Box::new(|f, c| unsafe { (f.set_real)(c, vr.as_ptr(), 1, std::ptr::null()) }),
            ),
            // SAFETY: a live instance; the NULL is the misuse under test (see above).
            ("fmi2SetInteger(vr = NULL)", Box::new(|f, c| unsafe { (f.set_integer)(c, null_vr, 1, integer.as_ptr()) })),
            (
                "fmi2SetInteger(value = NULL)",
                // SAFETY: a live instance; the NULL is the misuse under test (see above).
                Box::new(|f, c| unsafe { (f.set_integer)(c, vr.as_ptr(), 1, std::ptr::null()) }),
            ),
            // SAFETY: a live instance; the NULL is the misuse under test (see above).
            ("fmi2SetBoolean(vr = NULL)", Box::new(|f, c| unsafe { (f.set_boolean)(c, null_vr, 1, integer.as_ptr()) })),
            (
                "fmi2SetBoolean(value = NULL)",
                // SAFETY: a live instance; the NULL is the misuse under test (see above).
                Box::new(|f, c| unsafe { (f.set_boolean)(c, vr.as_ptr(), 1, std::ptr::null()) }),
            ),
            // SAFETY: a live instance; the NULL is the misuse under test (see above).
            ("fmi2SetString(vr = NULL)", Box::new(|f, c| unsafe { (f.set_string)(c, null_vr, 1, texts.as_ptr()) })),
            (
                "fmi2SetString(value = NULL)",
                // SAFETY: a live instance; the NULL is the misuse under test (see above).
                Box::new(|f, c| unsafe { (f.set_string)(c, vr.as_ptr(), 1, std::ptr::null()) }),
            ),
            (
                "fmi2SetString(value[0] = NULL)",
                // SAFETY: a live instance; the NULL is the misuse under test (see above).
                Box::new(|f, c| unsafe { (f.set_string)(c, vr.as_ptr(), 1, [std::ptr::null()].as_ptr()) }),
            ),
            (
                "fmi2SetDebugLogging(categories = NULL)",
                // SAFETY: a live instance; the NULL is the misuse under test (see above).
                Box::new(|f, c| unsafe { (f.set_debug_logging)(c, fmi2True, 1, std::ptr::null()) }),
            ),
            (
                "fmi2SetDebugLogging(categories[0] = NULL)",
                // SAFETY: a live instance; the NULL is the misuse under test (see above).
                Box::new(|f, c| unsafe { (f.set_debug_logging)(c, fmi2True, 1, [std::ptr::null()].as_ptr()) }),
            ),
        ];
        for (name, call) in calls {
            let instance = ready(&fmu);
            let status = call(instance.functions(), instance.component());
            assert_null_error(&fmu, &instance, status, name);
        }
    }
}

#[test]
fn null_state_pointers_are_errors_with_a_message_and_freeing_null_is_harmless() {
    for fmu in packaged_fmus() {
        let fresh = || {
            let mut instance = ready(&fmu);
            instance.do_step(0.0, 1e-3).unwrap();
            let state = instance.get_state().unwrap();
            (instance, state)
        };
        let mut size = 0usize;
        let mut bytes = [0 as fmi2Byte; 16];
        let mut out: fmi2FMUstate = std::ptr::null_mut();

        // fmi2FreeFMUstate with a NULL pointer, or a pointer to NULL, frees nothing.
        let (instance, _) = fresh();
        let f = instance.functions();
        // SAFETY: a live instance; the standard makes freeing a NULL state a no-op.
        let statuses = unsafe {
            [
                (f.free_fmu_state)(instance.component(), std::ptr::null_mut()),
                (f.free_fmu_state)(instance.component(), &mut out),
            ]
        };
        assert_eq!(statuses, [fmi2OK, fmi2OK], "{}: freeing a NULL state", fmu.description.model_identifier);

        let (instance, _) = fresh();
        // SAFETY: a live instance; the NULL output pointer is the misuse.
        let status = unsafe { (instance.functions().get_fmu_state)(instance.component(), std::ptr::null_mut()) };
        assert_null_error(&fmu, &instance, status, "fmi2GetFMUstate(state = NULL)");

        let (instance, _) = fresh();
        // SAFETY: as above.
        let status = unsafe { (instance.functions().set_fmu_state)(instance.component(), std::ptr::null_mut()) };
        assert_null_error(&fmu, &instance, status, "fmi2SetFMUstate(NULL)");

        let (instance, _) = fresh();
        // SAFETY: as above.
        let status = unsafe {
            (instance.functions().serialized_fmu_state_size)(instance.component(), std::ptr::null_mut(), &mut size)
        };
        assert_null_error(&fmu, &instance, status, "fmi2SerializedFMUstateSize(state = NULL)");

        // The remaining calls need a real state; the importer's handle is private, so the state
        // is made here with a raw call and freed by the instance's own fmi2FreeFMUstate.
        for (name, which) in [
            ("fmi2SerializedFMUstateSize(size = NULL)", 0),
            ("fmi2SerializeFMUstate(buffer = NULL)", 1),
            ("fmi2DeSerializeFMUstate(buffer = NULL)", 2),
            ("fmi2DeSerializeFMUstate(state = NULL)", 3),
        ] {
            let (instance, _) = fresh();
            let (f, c) = (instance.functions(), instance.component());
            let mut state: fmi2FMUstate = std::ptr::null_mut();
            // SAFETY: a live instance and a pointer to a NULL state, which asks for a new one.
            assert_eq!(unsafe { (f.get_fmu_state)(c, &mut state) }, fmi2OK);
            // SAFETY: the state is valid; only the pointer named in the case is NULL.
            let status = unsafe {
                match which {
                    0 => (f.serialized_fmu_state_size)(c, state, std::ptr::null_mut()),
                    1 => {
                        // The right size, so that only the NULL buffer is wrong.
                        assert_eq!((f.serialized_fmu_state_size)(c, state, &mut size), fmi2OK);
                        (f.serialize_fmu_state)(c, state, std::ptr::null_mut(), size)
                    }
                    2 => (f.deserialize_fmu_state)(c, std::ptr::null(), 16, &mut out),
                    _ => (f.deserialize_fmu_state)(c, bytes.as_mut_ptr(), bytes.len(), std::ptr::null_mut()),
                }
            };
            assert_null_error(&fmu, &instance, status, name);
            // SAFETY: the state was made by this instance and is freed once.
            assert_eq!(unsafe { (f.free_fmu_state)(c, &mut state) }, fmi2OK);
        }
        // An empty buffer is no state either; the n == 0 short-cut must not make it one.
        let (instance, _) = fresh();
        // SAFETY: size 0 with a NULL buffer touches no memory.
        let status = unsafe {
            (instance.functions().deserialize_fmu_state)(instance.component(), std::ptr::null(), 0, &mut out)
        };
        assert_eq!(status, fmi2Error, "{}: an empty serialized state was accepted", fmu.description.model_identifier);
        assert!(out.is_null());
    }
}

#[test]
fn null_status_outputs_are_errors_with_a_message() {
    for fmu in packaged_fmus() {
        let kinds: [(&str, fmi2StatusKind); 5] = [
            ("fmi2GetStatus", fmi2DoStepStatus),
            ("fmi2GetRealStatus", fmi2LastSuccessfulTime),
            ("fmi2GetIntegerStatus", fmi2DoStepStatus),
            ("fmi2GetBooleanStatus", fmi2Terminated),
            ("fmi2GetStringStatus", fmi2PendingStatus),
        ];
        for (k, (name, kind)) in kinds.into_iter().enumerate() {
            let mut instance = ready(&fmu);
            instance.do_step(0.0, 1e-3).unwrap();
            let (f, c) = (instance.functions(), instance.component());
            // SAFETY: a live instance after a step; the NULL output is the misuse.
            let status = unsafe {
                match k {
                    0 => (f.get_status)(c, kind, std::ptr::null_mut()),
                    1 => (f.get_real_status)(c, kind, std::ptr::null_mut()),
                    2 => (f.get_integer_status)(c, kind, std::ptr::null_mut()),
                    3 => (f.get_boolean_status)(c, kind, std::ptr::null_mut()),
                    _ => (f.get_string_status)(c, kind, std::ptr::null_mut()),
                }
            };
            assert_null_error(&fmu, &instance, status, &format!("{name}(value = NULL)"));
        }
    }
}

#[test]
fn unsupported_functions_with_null_arrays_are_errors_with_a_message() {
    for fmu in packaged_fmus() {
        let o = Others::load(&fmu);
        let null_vr: *const u32 = std::ptr::null();
        for k in 0..10 {
            // A fresh instance per call, so that each log holds one call's message only.
            let instance = ready(&fmu);
            let c = instance.component();
            // SAFETY: a live instance; these functions are not provided and must refuse before
            // touching the NULL arrays.
            // SAFETY: a live instance; the NULL is the misuse under test (see above).
            let status = unsafe {
                match k {
                    0 => (o.get_directional_derivative)(
                        c,
                        null_vr,
                        1,
                        null_vr,
                        1,
                        std::ptr::null(),
                        std::ptr::null_mut(),
                    ),
                    1 => (o.new_discrete_states)(c, std::ptr::null_mut()),
                    2 => (o.completed_integrator_step)(c, fmi2True, std::ptr::null_mut(), std::ptr::null_mut()),
                    3 => (o.set_continuous_states)(c, std::ptr::null(), 3),
                    4..=7 => (o.get_arrays[k - 4].1)(c, std::ptr::null_mut(), 3),
                    8 => (o.set_real_input_derivatives)(c, null_vr, 1, std::ptr::null(), std::ptr::null()),
                    _ => (o.get_real_output_derivatives)(c, null_vr, 1, std::ptr::null(), std::ptr::null_mut()),
                }
            };
            let id = &fmu.description.model_identifier;
            assert_eq!(status, fmi2Error, "{id}: unsupported function #{k} returned {status}");
            let log = instance.log_records();
            assert!(
                log.iter().any(|r| r.status == fmi2_ffi::Status::Error && !r.message.is_empty()),
                "{id}: function #{k} logged nothing"
            );
        }
    }
}

#[test]
fn instantiate_with_null_arguments_returns_null_and_says_why() {
    for fmu in packaged_fmus() {
        let f = &fmu.library.functions;
        let name = CString::new("null-arguments").unwrap();
        let guid = CString::new(fmu.description.guid.clone()).unwrap();
        let uri = CString::new(fmu.resource_uri()).unwrap();
        let callbacks = LoggerCallbacks::new(false);
        // SAFETY: every pointer is valid or NULL; NULL callbacks, name and GUID are the misuse.
        let (no_callbacks, no_name, no_guid) = unsafe {
            (
                (f.instantiate)(
                    name.as_ptr(),
                    fmi2CoSimulation,
                    guid.as_ptr(),
                    uri.as_ptr(),
                    std::ptr::null(),
                    fmi2False,
                    fmi2False,
                ),
                (f.instantiate)(
                    std::ptr::null(),
                    fmi2CoSimulation,
                    guid.as_ptr(),
                    uri.as_ptr(),
                    callbacks.functions(),
                    fmi2False,
                    fmi2False,
                ),
                (f.instantiate)(
                    name.as_ptr(),
                    fmi2CoSimulation,
                    std::ptr::null(),
                    uri.as_ptr(),
                    callbacks.functions(),
                    fmi2False,
                    fmi2False,
                ),
            )
        };
        let id = &fmu.description.model_identifier;
        assert!(
            no_callbacks.is_null() && no_name.is_null() && no_guid.is_null(),
            "{id}: an instance was made from NULL arguments"
        );
        let messages = callbacks.book.records();
        assert!(messages.iter().any(|r| r.message.contains("instanceName is NULL")), "{id}: {messages:?}");
        assert!(messages.iter().any(|r| r.message.contains("fmuGUID is NULL")), "{id}: {messages:?}");
    }
}

#[test]
fn an_instance_without_a_logger_or_resource_location_fails_quietly_instead_of_crashing() {
    for fmu in packaged_fmus() {
        let f = &fmu.library.functions;
        let name = CString::new("no-logger").unwrap();
        let guid = CString::new(fmu.description.guid.clone()).unwrap();
        let callbacks = fmi2CallbackFunctions {
            logger: None,
            allocateMemory: None,
            freeMemory: None,
            stepFinished: None,
            componentEnvironment: std::ptr::null_mut(),
        };
        // SAFETY: valid name, GUID and callback struct; a NULL logger and a NULL resource
        // location are what is tested (a master without resources may pass NULL).
        // SAFETY: a live instance; the NULL is the misuse under test (see above).
        let c = unsafe {
            (f.instantiate)(
                name.as_ptr(),
                fmi2CoSimulation,
                guid.as_ptr(),
                std::ptr::null(),
                &callbacks,
                fmi2False,
                fmi2True,
            )
        };
        let id = &fmu.description.model_identifier;
        assert!(!c.is_null(), "{id}: no instance without a logger and a resource location");
        // SAFETY: `c` is a live instance of this library, freed once at the end.
        unsafe {
            assert_eq!((f.do_step)(c, 0.0, 1e-3, fmi2True), fmi2Error, "{id}: DoStep before initialisation");
            assert_eq!((f.reset)(c), fmi2OK);
            assert_eq!((f.setup_experiment)(c, fmi2False, 0.0, 0.0, fmi2False, 0.0), fmi2OK);
            assert_eq!((f.enter_initialization_mode)(c), fmi2OK);
            assert_eq!((f.exit_initialization_mode)(c), fmi2OK);
            assert_eq!((f.do_step)(c, 0.0, 1e-3, fmi2True), fmi2OK);
            (f.free_instance)(c);
        }
    }
}
