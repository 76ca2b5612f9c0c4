//! In-process tests of the exported functions: the same code the `#[no_mangle]` wrappers call,
//! driven through raw pointers exactly as a C master would, with a small test model.

use std::ffi::{CStr, CString};
use std::ptr::{null, null_mut};

use super::*;
use crate::state::{StateError, STATE_TAG};
use crate::variables::{BaseType, EnumerationType, Values, VariableSet};
use crate::{declare_variables, DefaultExperiment};
use fmu_import::LoggerCallbacks;
use via_c::{
    cancel_step, deserialize_fmu_state, do_step, enter_initialization_mode, exit_initialization_mode, free_fmu_state,
    free_instance, get_fmu_state, get_real, get_real_status, get_string, instance_from, instantiate, reset,
    serialize_fmu_state, serialized_fmu_state_size, set_boolean, set_debug_logging, set_fmu_state, set_integer,
    set_real, set_string, setup_experiment, terminate, unsupported,
};

/// The exported functions as the tests call them, each as its C master would. The tests pass
/// NULL, instances of a live [`Master`] (or deliberately freed ones, caught by the magic
/// number), states these functions returned, and pointers to their own locals with the
/// announced lengths: what each function's `# Safety` section asks.
mod via_c {
    use super::super as x;
    use super::*;

    pub(super) fn instance_from(c: fmi2Component) -> Option<&'static mut Instance> {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::instance_from(c) }
    }

    // The eight arguments of fmi2Instantiate (and the model table), as the C function has them.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn instantiate(
        models: &[ModelEntry],
        name: fmi2String,
        ty: fmi2Type,
        guid: fmi2String,
        res: fmi2String,
        f: *const fmi2CallbackFunctions,
        visible: fmi2Boolean,
        on: fmi2Boolean,
    ) -> fmi2Component {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::instantiate(models, name, ty, guid, res, f, visible, on) }
    }

    pub(super) fn free_instance(c: fmi2Component) {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::free_instance(c) }
    }

    pub(super) fn setup_experiment(
        c: fmi2Component,
        td: fmi2Boolean,
        tol: fmi2Real,
        start: fmi2Real,
        sd: fmi2Boolean,
        stop: fmi2Real,
    ) -> fmi2Status {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::setup_experiment(c, td, tol, start, sd, stop) }
    }

    pub(super) fn enter_initialization_mode(c: fmi2Component) -> fmi2Status {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::enter_initialization_mode(c) }
    }

    pub(super) fn exit_initialization_mode(c: fmi2Component) -> fmi2Status {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::exit_initialization_mode(c) }
    }

    pub(super) fn terminate(c: fmi2Component) -> fmi2Status {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::terminate(c) }
    }

    pub(super) fn reset(c: fmi2Component) -> fmi2Status {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::reset(c) }
    }

    pub(super) fn get_real(c: fmi2Component, vr: *const fmi2ValueReference, n: usize, v: *mut fmi2Real) -> fmi2Status {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::get_real(c, vr, n, v) }
    }

    pub(super) fn get_string(
        c: fmi2Component,
        vr: *const fmi2ValueReference,
        n: usize,
        v: *mut fmi2String,
    ) -> fmi2Status {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::get_string(c, vr, n, v) }
    }

    pub(super) fn set_real(
        c: fmi2Component,
        vr: *const fmi2ValueReference,
        n: usize,
        v: *const fmi2Real,
    ) -> fmi2Status {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::set_real(c, vr, n, v) }
    }

    pub(super) fn set_integer(
        c: fmi2Component,
        vr: *const fmi2ValueReference,
        n: usize,
        v: *const fmi2Integer,
    ) -> fmi2Status {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::set_integer(c, vr, n, v) }
    }

    pub(super) fn set_boolean(
        c: fmi2Component,
        vr: *const fmi2ValueReference,
        n: usize,
        v: *const fmi2Boolean,
    ) -> fmi2Status {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::set_boolean(c, vr, n, v) }
    }

    pub(super) fn set_string(
        c: fmi2Component,
        vr: *const fmi2ValueReference,
        n: usize,
        v: *const fmi2String,
    ) -> fmi2Status {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::set_string(c, vr, n, v) }
    }

    pub(super) fn get_fmu_state(c: fmi2Component, s: *mut fmi2FMUstate) -> fmi2Status {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::get_fmu_state(c, s) }
    }

    pub(super) fn set_fmu_state(c: fmi2Component, s: fmi2FMUstate) -> fmi2Status {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::set_fmu_state(c, s) }
    }

    pub(super) fn free_fmu_state(c: fmi2Component, s: *mut fmi2FMUstate) -> fmi2Status {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::free_fmu_state(c, s) }
    }

    pub(super) fn serialized_fmu_state_size(c: fmi2Component, s: fmi2FMUstate, size: *mut usize) -> fmi2Status {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::serialized_fmu_state_size(c, s, size) }
    }

    pub(super) fn serialize_fmu_state(c: fmi2Component, s: fmi2FMUstate, b: *mut fmi2Byte, size: usize) -> fmi2Status {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::serialize_fmu_state(c, s, b, size) }
    }

    pub(super) fn deserialize_fmu_state(
        c: fmi2Component,
        b: *const fmi2Byte,
        size: usize,
        s: *mut fmi2FMUstate,
    ) -> fmi2Status {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::deserialize_fmu_state(c, b, size, s) }
    }

    pub(super) fn do_step(c: fmi2Component, t: fmi2Real, h: fmi2Real, nsp: fmi2Boolean) -> fmi2Status {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::do_step(c, t, h, nsp) }
    }

    pub(super) fn cancel_step(c: fmi2Component) -> fmi2Status {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::cancel_step(c) }
    }

    pub(super) fn get_real_status(c: fmi2Component, k: fmi2StatusKind, v: *mut fmi2Real) -> fmi2Status {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::get_real_status(c, k, v) }
    }

    pub(super) fn unsupported(c: fmi2Component, function: &'static str, why: &'static str) -> fmi2Status {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::unsupported(c, function, why) }
    }

    pub(super) fn set_debug_logging(
        c: fmi2Component,
        on: fmi2Boolean,
        n: usize,
        cats: *const fmi2String,
    ) -> fmi2Status {
        // SAFETY: the tests keep the contract (see the module documentation).
        unsafe { x::set_debug_logging(c, on, n, cats) }
    }
}

static MODE: EnumerationType = EnumerationType {
    name: "TestMode",
    description: "Test enumeration.",
    items: &[("plain", "Plain integration."), ("doubled", "Integrates twice the input.")],
};

declare_variables! {
    pub enum TestVar {
        Gain = Var::real("gain", "1").parameter().start(2.0).min(0.0).max(100.0).description("Fixed gain k."),
        Tunable = Var::real("offset", "1").parameter().tunable().start(0.0).description("Tunable offset added to the input."),
        Input = Var::real("u", "1").input().start(0.0).description("Input."),
        Output = Var::real("y", "1").output().description("Integral of k (u + offset)."),
        Feedthrough = Var::real("u_echo", "1").output().depends_on(&[TestVar::Input as u32]).description("The input, echoed within the step."),
        DoubleGain = Var::real("gain2", "1").calculated_parameter().description("2 k."),
        Mode = Var::enumeration("mode", &MODE).parameter().start_integer(1).description("Mode."),
        PanicOnStep = Var::boolean("panic_on_step").parameter().tunable().start_boolean(false).description("Panics in the next step (tests panic capture)."),
        ParameterFile = Var::string("parameter_file").parameter().start_string("").description("Parameter file to load."),
        Count = Var::integer("count").parameter().start_integer(3).range_integer(0, 10).description("An integer parameter."),
        Square = Var::real("u_squared", "1").output().depends_on(&[TestVar::Input as u32]).description("The input squared: a feedthrough output of a second group."),
        SquareUpdates = Var::real("u_squared_updates", "1").output().description("How many times the square's group was brought up to date."),
    }
}

struct TestModel {
    state: f64,
}

/// The test model's own refusals.
#[derive(Debug, thiserror::Error)]
enum TestError {
    #[error("13 is unlucky")]
    Unlucky,
    #[error(transparent)]
    Params(#[from] crate::params::ParamsError),
}

impl Model for TestModel {
    type Var = TestVar;

    type Error = TestError;

    fn info() -> ModelInfo {
        ModelInfo {
            model_identifier: "TestModel",
            model_name: "TestModel",
            description: "An integrator for runtime tests.",
            author: "tests",
            version: "1",
            default_experiment: DefaultExperiment { start_time: 0.0, stop_time: 1.0, step_size: 0.01 },
        }
    }

    fn new(_values: &Values<TestVar>, _context: &Context) -> Result<Self, TestError> {
        Ok(TestModel { state: 0.0 })
    }

    fn initialize(
        &mut self,
        values: &mut Values<TestVar>,
        _context: &Context,
        notes: &mut Notes,
    ) -> Result<(), TestError> {
        values.set_real(TestVar::DoubleGain, 2.0 * values.real(TestVar::Gain));
        values.set_real(TestVar::Output, self.state);
        notes.event("initialised with 100% of the gain");
        Ok(())
    }

    fn do_step(
        &mut self,
        values: &mut Values<TestVar>,
        _time: f64,
        step: f64,
        notes: &mut Notes,
    ) -> Result<(), TestError> {
        if values.boolean(TestVar::PanicOnStep) {
            notes.warning("about to panic");
            panic!("deliberate panic with 50% probability");
        }
        if values.real(TestVar::Input) == 7.0 {
            notes.warning("an input of 7 is noted");
        }
        let factor = if values.integer(TestVar::Mode) == 2 { 2.0 } else { 1.0 };
        let u = values.real(TestVar::Input) + values.real(TestVar::Tunable);
        self.state += factor * values.real(TestVar::Gain) * u * step;
        values.set_real(TestVar::Output, self.state);
        values.set_real(TestVar::Feedthrough, values.real(TestVar::Input));
        Ok(())
    }

    fn update_feedthrough(&mut self, values: &mut Values<TestVar>) {
        self.update_feedthrough_groups(values, u32::MAX);
    }

    fn feedthrough_group(var: TestVar) -> u32 {
        u32::from(var == TestVar::Square)
    }

    fn update_feedthrough_groups(&mut self, values: &mut Values<TestVar>, groups: u32) {
        let u = values.real(TestVar::Input);
        if groups & 1 != 0 {
            values.set_real(TestVar::Feedthrough, u);
        }
        if groups & 2 != 0 {
            values.set_real(TestVar::Square, u * u);
            values.set_real(TestVar::SquareUpdates, values.real(TestVar::SquareUpdates) + 1.0);
        }
    }

    fn check_real(var: TestVar, value: f64, _values: &Values<TestVar>) -> Result<(), TestError> {
        if var == TestVar::Gain && value == 13.0 {
            return Err(TestError::Unlucky);
        }
        Ok(())
    }

    fn string_changed(
        &mut self,
        var: TestVar,
        values: &mut Values<TestVar>,
        _context: &Context,
    ) -> Result<(), TestError> {
        if var == TestVar::ParameterFile && !values.string(var).is_empty() {
            let text = values.string(var).replace(';', "\n");
            crate::params::apply::<TestModel>(&text, "inline", values)?;
        }
        Ok(())
    }

    type State = f64;

    fn save_state(&self) -> f64 {
        self.state
    }

    fn load_state(&mut self, state: f64, _values: &Values<TestVar>) -> Result<(), StateError> {
        self.state = state;
        Ok(())
    }
}

const MODELS: &[ModelEntry] = &[ModelEntry::of::<TestModel>()];

/// A test master around the in-process functions.
struct Master {
    callbacks: LoggerCallbacks,
    c: fmi2Component,
}

const U: u32 = TestVar::Input as u32;
const Y: u32 = TestVar::Output as u32;

impl Master {
    fn try_new(guid: &str) -> (Option<Master>, LoggerCallbacks) {
        let callbacks = LoggerCallbacks::new(false);
        let name = CString::new("test").unwrap();
        let guid = CString::new(guid).unwrap();
        let uri = CString::new("file:///tmp/some%20folder/resources").unwrap();
        let c = instantiate(
            MODELS,
            name.as_ptr(),
            fmi2CoSimulation,
            guid.as_ptr(),
            uri.as_ptr(),
            callbacks.functions(),
            0,
            0,
        );
        if c.is_null() {
            (None, callbacks)
        } else {
            (Some(Master { callbacks: LoggerCallbacks::new(false), c }), callbacks)
        }
    }

    fn new() -> Master {
        let callbacks = LoggerCallbacks::new(false);
        let name = CString::new("test").unwrap();
        let guid = CString::new(crate::xml::guid::<TestModel>()).unwrap();
        let c =
            instantiate(MODELS, name.as_ptr(), fmi2CoSimulation, guid.as_ptr(), null(), callbacks.functions(), 0, 0);
        assert!(!c.is_null());
        Master { callbacks, c }
    }

    fn initialized() -> Master {
        let m = Master::new();
        assert_eq!(setup_experiment(m.c, 0, 0.0, 0.0, 0, 0.0), fmi2OK);
        assert_eq!(enter_initialization_mode(m.c), fmi2OK);
        assert_eq!(exit_initialization_mode(m.c), fmi2OK);
        m
    }

    fn errors(&self) -> Vec<String> {
        self.callbacks.book.records().into_iter().filter(|r| r.status == Status::Error).map(|r| r.message).collect()
    }

    fn last_error(&self) -> String {
        self.errors().last().cloned().unwrap_or_default()
    }

    fn set(&self, vr: u32, value: f64) -> fmi2Status {
        set_real(self.c, &vr, 1, &value)
    }

    fn get(&self, vr: u32) -> f64 {
        let mut value = f64::NAN;
        assert_eq!(get_real(self.c, &vr, 1, &mut value), fmi2OK, "{}", self.last_error());
        value
    }

    fn phase(&self) -> Phase {
        instance_from(self.c).unwrap().phase
    }
}

impl Drop for Master {
    fn drop(&mut self) {
        free_instance(self.c);
    }
}

#[test]
fn a_wrong_guid_returns_null_and_logs_both_guids() {
    let (master, callbacks) = Master::try_new("{not-the-guid}");
    assert!(master.is_none());
    let records = callbacks.book.records();
    assert_eq!(records.len(), 1);
    assert!(records[0].message.contains("{not-the-guid}"));
    assert!(records[0].message.contains(&crate::xml::guid::<TestModel>()));
}

#[test]
fn instantiate_rejects_model_exchange_and_missing_names() {
    let callbacks = LoggerCallbacks::new(false);
    let guid = CString::new(crate::xml::guid::<TestModel>()).unwrap();
    let name = CString::new("x").unwrap();
    let empty = CString::new("").unwrap();
    assert!(instantiate(MODELS, name.as_ptr(), fmi2ModelExchange, guid.as_ptr(), null(), callbacks.functions(), 0, 0)
        .is_null());
    assert!(instantiate(MODELS, null(), fmi2CoSimulation, guid.as_ptr(), null(), callbacks.functions(), 0, 0).is_null());
    assert!(instantiate(MODELS, empty.as_ptr(), fmi2CoSimulation, guid.as_ptr(), null(), callbacks.functions(), 0, 0)
        .is_null());
    assert!(instantiate(MODELS, name.as_ptr(), fmi2CoSimulation, guid.as_ptr(), null(), null(), 0, 0).is_null());
    let messages: Vec<String> = callbacks.book.records().into_iter().map(|r| r.message).collect();
    assert_eq!(messages.len(), 3, "{messages:?}");
    assert!(messages[0].contains("co-simulation"));
}

#[test]
fn resource_uris_are_percent_decoded() {
    assert_eq!(resource_path_from_uri("file:///tmp/some%20folder/res").unwrap(), PathBuf::from("/tmp/some folder/res"));
    assert_eq!(resource_path_from_uri("file://localhost/a/b").unwrap(), PathBuf::from("/a/b"));
    assert_eq!(resource_path_from_uri("file:/a/%C3%A9").unwrap(), PathBuf::from("/a/é"));
    assert!(resource_path_from_uri("http://x/y").is_err());
    assert!(resource_path_from_uri("file:///a%2").is_err());
    let (master, _) = Master::try_new(&crate::xml::guid::<TestModel>());
    let master = master.unwrap();
    let context = &instance_from(master.c).unwrap().context;
    assert_eq!(context.resource_dir.as_deref(), Some(std::path::Path::new("/tmp/some folder/resources")));
}

#[test]
fn a_null_instance_is_harmless_everywhere() {
    free_instance(null_mut());
    let vr = 0u32;
    let mut x = 0.0;
    assert_eq!(do_step(null_mut(), 0.0, 0.1, 0), fmi2Error);
    assert_eq!(get_real(null_mut(), &vr, 1, &mut x), fmi2Error);
    assert_eq!(set_real(null_mut(), &vr, 1, &x), fmi2Error);
    assert_eq!(terminate(null_mut()), fmi2Error);
    assert_eq!(set_debug_logging(null_mut(), 1, 0, null()), fmi2Error);
    assert_eq!(get_fmu_state(null_mut(), null_mut()), fmi2Error);
}

#[test]
fn zero_length_arrays_may_be_null_but_announced_elements_may_not() {
    let m = Master::initialized();
    assert_eq!(get_real(m.c, null(), 0, null_mut()), fmi2OK);
    assert_eq!(set_real(m.c, null(), 0, null()), fmi2OK);
    assert_eq!(get_real(m.c, null(), 1, null_mut()), fmi2Error);
    assert!(m.last_error().contains("vr is NULL"), "{}", m.last_error());
}

#[test]
fn do_step_before_initialisation_is_an_illegal_call() {
    let m = Master::new();
    assert_eq!(do_step(m.c, 0.0, 0.1, 0), fmi2Error);
    assert!(m.last_error().contains("illegal call in phase Instantiated"), "{}", m.last_error());
    assert_eq!(m.phase(), Phase::Error);
}

#[test]
fn do_step_after_terminate_and_a_second_terminate_are_illegal() {
    let m = Master::initialized();
    assert_eq!(terminate(m.c), fmi2OK);
    assert_eq!(do_step(m.c, 0.0, 0.1, 0), fmi2Error);
    let m2 = Master::initialized();
    assert_eq!(terminate(m2.c), fmi2OK);
    assert_eq!(terminate(m2.c), fmi2Error);
    assert!(m2.last_error().contains("fmi2Terminate: illegal call in phase Terminated"));
}

#[test]
fn non_finite_inputs_are_rejected_and_change_nothing() {
    let m = Master::initialized();
    assert_eq!(m.set(U, 1.5), fmi2OK);
    let vrs = [U, TestVar::Tunable as u32];
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let m = Master::initialized();
        assert_eq!(m.set(U, 1.5), fmi2OK);
        assert_eq!(set_real(m.c, vrs.as_ptr(), 2, [0.5, bad].as_ptr()), fmi2Error);
        assert!(m.last_error().contains("must be finite"));
        // The first value of the rejected call did not land either.
        assert_eq!(m.get(U), 1.5);
    }
}

#[test]
fn unknown_value_references_and_wrong_types_are_errors() {
    let m = Master::initialized();
    let vr = 999u32;
    let mut x = 0.0;
    assert_eq!(get_real(m.c, &vr, 1, &mut x), fmi2Error);
    assert!(m.last_error().contains("unknown value reference 999"));
    let m = Master::initialized();
    let mode = TestVar::Mode as u32;
    assert_eq!(get_real(m.c, &mode, 1, &mut x), fmi2Error);
    assert!(m.last_error().contains("is of type Integer, not Real"));
}

#[test]
fn outputs_fixed_and_calculated_parameters_cannot_be_set_while_stepping() {
    for vr in [Y, TestVar::Gain as u32, TestVar::DoubleGain as u32] {
        let m = Master::initialized();
        assert_eq!(m.set(vr, 1.0), fmi2Error, "vr {vr}");
        assert!(m.last_error().contains("cannot be set now"));
    }
    let m = Master::initialized();
    assert_eq!(m.set(TestVar::Tunable as u32, 1.0), fmi2OK);
}

#[test]
fn ranges_enumerations_and_model_checks_are_enforced() {
    let m = Master::new();
    assert_eq!(m.set(TestVar::Gain as u32, 101.0), fmi2Error);
    assert!(m.last_error().contains("above its maximum 100"));
    let m = Master::new();
    assert_eq!(m.set(TestVar::Gain as u32, 13.0), fmi2Error);
    assert!(m.last_error().contains("unlucky"));
    let m = Master::new();
    let mode = TestVar::Mode as u32;
    assert_eq!(set_integer(m.c, &mode, 1, &3), fmi2Error);
    assert!(m.last_error().contains("not an item of TestMode"));
    let m = Master::new();
    let count = TestVar::Count as u32;
    assert_eq!(set_integer(m.c, &count, 1, &11), fmi2Error);
}

#[test]
fn steps_must_be_positive_and_contiguous() {
    let m = Master::initialized();
    assert_eq!(do_step(m.c, 0.0, -0.1, 0), fmi2Error);
    assert!(m.last_error().contains("must be positive"));
    let m = Master::initialized();
    assert_eq!(do_step(m.c, 0.0, 0.0, 0), fmi2Error);
    let m = Master::initialized();
    assert_eq!(do_step(m.c, 0.0, 0.1, 0), fmi2OK);
    assert_eq!(do_step(m.c, 0.2, 0.1, 0), fmi2Error);
    assert!(m.last_error().contains("not where the instance is"));
    // Accumulated rounding is tolerated.
    let m = Master::initialized();
    let mut t = 0.0;
    for _ in 0..1000 {
        assert_eq!(do_step(m.c, t, 0.1, 0), fmi2OK, "{}", m.last_error());
        t += 0.1;
    }
    assert_eq!(do_step(m.c, 100.0 + 1e-9, 0.1, 0), fmi2OK, "{}", m.last_error());
}

#[test]
fn a_panic_in_the_model_becomes_an_error_with_its_message() {
    let m = Master::initialized();
    let vr = TestVar::PanicOnStep as u32;
    assert_eq!(set_boolean(m.c, &vr, 1, &1), fmi2OK);
    assert_eq!(do_step(m.c, 0.0, 0.1, 0), fmi2Error);
    let error = m.last_error();
    assert!(error.contains("internal error (panic): deliberate panic with 50% probability"), "{error}");
    assert_eq!(m.phase(), Phase::Error);
    // Getters still work for diagnosis, and the last successful time is reported.
    let _ = m.get(Y);
    let mut t = f64::NAN;
    assert_eq!(get_real_status(m.c, fmi2LastSuccessfulTime, &mut t), fmi2OK);
    assert_eq!(t, 0.0);
}

#[test]
fn percent_signs_reach_the_logger_unchanged_after_printf_formatting() {
    let callbacks = LoggerCallbacks::new(false);
    let name = CString::new("pct").unwrap();
    let guid = CString::new(crate::xml::guid::<TestModel>()).unwrap();
    let c = instantiate(MODELS, name.as_ptr(), fmi2CoSimulation, guid.as_ptr(), null(), callbacks.functions(), 0, 1);
    assert_eq!(enter_initialization_mode(c), fmi2OK);
    assert_eq!(exit_initialization_mode(c), fmi2OK);
    let events: Vec<String> =
        callbacks.book.records().into_iter().filter(|r| r.category == "logEvents").map(|r| r.message).collect();
    assert_eq!(events, vec!["initialised with 100% of the gain".to_string()]);
    free_instance(c);
}

#[test]
fn debug_logging_categories_filter_messages() {
    let m = Master::new();
    let events = CString::new("logEvents").unwrap();
    let errors = CString::new("logStatusError").unwrap();
    let unknown = CString::new("logNothing").unwrap();
    assert_eq!(set_debug_logging(m.c, 1, 1, &events.as_ptr()), fmi2OK);
    assert_eq!(set_debug_logging(m.c, 0, 1, &errors.as_ptr()), fmi2OK);
    assert_eq!(do_step(m.c, 0.0, 0.1, 0), fmi2Error);
    assert!(m.errors().is_empty(), "errors were switched off");
    let m = Master::new();
    assert_eq!(set_debug_logging(m.c, 1, 1, &unknown.as_ptr()), fmi2Error);
    assert!(m.last_error().contains("unknown log category 'logNothing'"));
}

#[test]
fn restoring_a_saved_state_recovers_from_an_error() {
    let m = Master::initialized();
    m.set(U, 1.0);
    assert_eq!(do_step(m.c, 0.0, 0.5, 0), fmi2OK);
    let mut state: fmi2FMUstate = null_mut();
    assert_eq!(get_fmu_state(m.c, &mut state), fmi2OK);
    let y_saved = m.get(Y);
    assert_eq!(do_step(m.c, 0.5, 0.5, 0), fmi2OK);
    assert_eq!(do_step(m.c, 0.0, 0.5, 0), fmi2Error);
    assert_eq!(m.phase(), Phase::Error);
    assert_eq!(set_fmu_state(m.c, state), fmi2OK);
    assert_eq!(m.phase(), Phase::StepComplete);
    assert_eq!(m.get(Y), y_saved);
    assert_eq!(do_step(m.c, 0.5, 0.5, 0), fmi2OK);
    assert_eq!(m.get(Y), 2.0);
    assert_eq!(free_fmu_state(m.c, &mut state), fmi2OK);
    assert!(state.is_null());
}

#[test]
fn serialized_states_restore_into_another_instance() {
    let a = Master::initialized();
    a.set(U, 3.0);
    assert_eq!(do_step(a.c, 0.0, 0.25, 0), fmi2OK);
    let mut state: fmi2FMUstate = null_mut();
    assert_eq!(get_fmu_state(a.c, &mut state), fmi2OK);
    let mut size = 0usize;
    assert_eq!(serialized_fmu_state_size(a.c, state, &mut size), fmi2OK);
    let mut bytes = vec![0 as fmi2Byte; size];
    assert_eq!(serialize_fmu_state(a.c, state, bytes.as_mut_ptr(), size), fmi2OK);

    let b = Master::new();
    let mut restored: fmi2FMUstate = null_mut();
    assert_eq!(deserialize_fmu_state(b.c, bytes.as_ptr(), size, &mut restored), fmi2OK, "{}", b.last_error());
    assert_eq!(set_fmu_state(b.c, restored), fmi2OK);
    assert_eq!(b.get(Y), a.get(Y));
    assert_eq!(b.get(U), 3.0);
    assert_eq!(do_step(a.c, 0.25, 0.25, 0), fmi2OK);
    assert_eq!(do_step(b.c, 0.25, 0.25, 0), fmi2OK);
    assert_eq!(a.get(Y).to_bits(), b.get(Y).to_bits());

    // A corrupt or truncated state is rejected with a reason.
    let c = Master::new();
    let mut other: fmi2FMUstate = null_mut();
    assert_eq!(deserialize_fmu_state(c.c, bytes.as_ptr(), size - 3, &mut other), fmi2Error);
    assert!(c.last_error().contains("truncated") || c.last_error().contains("rejected"), "{}", c.last_error());
    free_fmu_state(a.c, &mut state);
    free_fmu_state(b.c, &mut restored);
}

#[test]
fn truncated_corrupt_or_foreign_states_are_refused_with_the_reason_never_a_panic() {
    let a = Master::initialized();
    a.set(U, 3.0);
    assert_eq!(do_step(a.c, 0.0, 0.25, 0), fmi2OK);
    let bytes = crate::state::InstanceState::<TestModel>::decode(&serialized(&a)).unwrap().encode().unwrap();
    assert_eq!(bytes, serialized(&a), "decode then encode is not the identity");
    let b = Master::new();
    let deserialize = |bytes: &[u8]| {
        let mut state: fmi2FMUstate = null_mut();
        let status = deserialize_fmu_state(b.c, bytes.as_ptr().cast(), bytes.len(), &mut state);
        if !state.is_null() {
            free_fmu_state(b.c, &mut state);
        }
        (status, b.last_error())
    };
    for cut in 0..bytes.len() {
        let (status, error) = deserialize(&bytes[..cut]);
        assert_eq!(status, fmi2Error, "a state cut at {cut} bytes was accepted");
        assert!(error.contains("serialized state rejected") && !error.contains("panic"), "cut at {cut}: {error}");
    }
    // A flipped byte anywhere is refused: the checksum sees every single-byte change.
    for i in 0..bytes.len() {
        let mut flipped = bytes.clone();
        flipped[i] ^= 0xA5;
        let (status, error) = deserialize(&flipped);
        assert!(status == fmi2Error && !error.contains("panic"), "byte {i}: {error}");
    }
    let mut other_version = bytes.clone();
    other_version[STATE_TAG.len()] = 7;
    assert!(deserialize(&other_version).1.contains("state format version 7 is not supported"));
    let mut not_a_state = bytes.clone();
    not_a_state[0] = b'X';
    assert!(deserialize(&not_a_state).1.contains("not an FMU state of this project"));
    let mut foreign = crate::state::InstanceState::<TestModel>::decode(&bytes).unwrap();
    foreign.header.model_identifier = "OtherModel".into();
    assert!(deserialize(&foreign.encode().unwrap()).1.contains("state belongs to model 'OtherModel'"));
    let mut trailing = bytes.clone();
    trailing.push(0);
    assert!(deserialize(&trailing).1.contains("state is damaged: its checksum"));
    // Values that pass the checksum are checked one by one: time, ranges, finiteness.
    let mut nan_time = crate::state::InstanceState::<TestModel>::decode(&bytes).unwrap();
    nan_time.header.time = f64::NAN;
    assert!(deserialize(&nan_time.encode().unwrap()).1.contains("time = NaN is not finite"));
    let mut infinite_value = crate::state::InstanceState::<TestModel>::decode(&bytes).unwrap();
    infinite_value.values.set_real(TestVar::Output, f64::INFINITY);
    assert!(deserialize(&infinite_value.encode().unwrap()).1.contains("'y' = inf is not finite"));
}

/// The serialized bytes of an instance's current state.
fn serialized(m: &Master) -> Vec<u8> {
    let mut state: fmi2FMUstate = null_mut();
    assert_eq!(get_fmu_state(m.c, &mut state), fmi2OK);
    let mut size = 0usize;
    assert_eq!(serialized_fmu_state_size(m.c, state, &mut size), fmi2OK);
    let mut bytes = vec![0 as fmi2Byte; size];
    assert_eq!(serialize_fmu_state(m.c, state, bytes.as_mut_ptr(), size), fmi2OK);
    assert_eq!(free_fmu_state(m.c, &mut state), fmi2OK);
    bytes.into_iter().map(|b| b as u8).collect()
}

#[test]
fn a_string_parameter_can_load_values_atomically() {
    let m = Master::new();
    let vr = TestVar::ParameterFile as u32;
    let good = CString::new("gain = 4;mode = \"doubled\"").unwrap();
    assert_eq!(set_string(m.c, &vr, 1, &good.as_ptr()), fmi2OK, "{}", m.last_error());
    assert_eq!(enter_initialization_mode(m.c), fmi2OK);
    assert_eq!(m.get(TestVar::DoubleGain as u32), 8.0);
    let m = Master::new();
    let bad = CString::new("gain = 5;count = 99").unwrap();
    assert_eq!(set_string(m.c, &vr, 1, &bad.as_ptr()), fmi2Error);
    assert!(m.last_error().contains("inline:2"), "{}", m.last_error());
    // Nothing of the failed file landed: restore is by recreating from the state machine's view.
    let instance = instance_from(m.c).unwrap();
    let mut out = [0.0];
    instance.model.get_real(&[TestVar::Gain as u32], &mut out, 0).unwrap();
    assert_eq!(out[0], 2.0);
}

#[test]
fn calculated_values_follow_parameters_during_initialisation() {
    let m = Master::new();
    assert_eq!(enter_initialization_mode(m.c), fmi2OK);
    assert_eq!(m.get(TestVar::DoubleGain as u32), 4.0);
    assert_eq!(m.set(TestVar::Gain as u32, 5.0), fmi2OK);
    assert_eq!(m.get(TestVar::DoubleGain as u32), 10.0);
}

#[test]
fn get_string_returns_copies_valid_until_the_next_call() {
    let m = Master::initialized();
    let vr = TestVar::ParameterFile as u32;
    let mut out: fmi2String = null();
    assert_eq!(get_string(m.c, &vr, 1, &mut out), fmi2OK);
    // SAFETY: the FMU keeps the string alive until the next fmi2GetString.
    assert_eq!(unsafe { CStr::from_ptr(out) }.to_str().unwrap(), "");
}

#[test]
fn feedthrough_outputs_see_inputs_set_after_the_last_step() {
    let m = Master::initialized();
    assert_eq!(do_step(m.c, 0.0, 0.1, 0), fmi2OK);
    m.set(U, 7.0);
    assert_eq!(m.get(TestVar::Feedthrough as u32), 7.0);
    // The state-only output did not move: it changes only by stepping.
    assert_eq!(m.get(Y), 0.0);
}

#[test]
fn a_feedthrough_update_waits_through_gets_of_other_outputs_for_the_get_that_reads_it() {
    let m = Master::initialized();
    assert_eq!(do_step(m.c, 0.0, 0.1, 0), fmi2OK);
    m.set(U, 7.0);
    // Reading only other variables leaves the feedthrough update pending, not lost.
    assert_eq!(m.get(Y), 0.0);
    assert_eq!(m.get(U), 7.0);
    assert_eq!(m.get(TestVar::Feedthrough as u32), 7.0);
    m.set(U, -3.0);
    assert_eq!(m.get(Y), 0.0);
    assert_eq!(m.get(TestVar::Feedthrough as u32), -3.0);
}

#[test]
fn a_get_brings_up_to_date_only_the_feedthrough_groups_it_reads_and_leaves_the_others_pending() {
    let m = Master::initialized();
    assert_eq!(do_step(m.c, 0.0, 0.1, 0), fmi2OK);
    let (echo, square, updates) = (TestVar::Feedthrough as u32, TestVar::Square as u32, TestVar::SquareUpdates as u32);
    m.set(U, 3.0);
    let before = m.get(updates);
    // The echo's group alone: the square's is not computed.
    assert_eq!(m.get(echo), 3.0);
    assert_eq!(m.get(updates), before);
    // Still pending, not lost: the square follows the input set before the echo was read.
    assert_eq!(m.get(square), 9.0);
    assert_eq!(m.get(updates), before + 1.0);
    // Up to date now: a second read computes nothing.
    assert_eq!(m.get(square), 9.0);
    assert_eq!(m.get(updates), before + 1.0);
    // A new input marks both groups again; each is brought up to date by its own read.
    m.set(U, -4.0);
    assert_eq!(m.get(square), 16.0);
    assert_eq!(m.get(echo), -4.0);
    // A step marks them too.
    assert_eq!(do_step(m.c, 0.1, 0.1, 0), fmi2OK);
    m.set(U, 5.0);
    let mut both = [0.0; 2];
    assert_eq!(get_real(m.c, [echo, square].as_ptr(), 2, both.as_mut_ptr()), fmi2OK);
    assert_eq!(both, [5.0, 25.0]);
}

#[test]
fn reset_returns_to_the_instantiated_phase_with_start_values() {
    let m = Master::initialized();
    m.set(U, 1.0);
    assert_eq!(do_step(m.c, 0.0, 1.0, 0), fmi2OK);
    assert_eq!(reset(m.c), fmi2OK);
    assert_eq!(m.phase(), Phase::Instantiated);
    assert_eq!(enter_initialization_mode(m.c), fmi2OK);
    assert_eq!(exit_initialization_mode(m.c), fmi2OK);
    assert_eq!(m.get(Y), 0.0);
    assert_eq!(m.get(U), 0.0);
}

#[test]
fn unsupported_functions_log_why_fail_and_leave_the_instance_in_its_phase() {
    // Before initialisation, while stepping and after termination: each call fails with its
    // reason and the instance carries on in the phase it was in.
    let instantiated = Master::new();
    let stepping = Master::initialized();
    let terminated = Master::initialized();
    assert_eq!(terminate(terminated.c), fmi2OK);
    for (m, phase) in
        [(&instantiated, Phase::Instantiated), (&stepping, Phase::StepComplete), (&terminated, Phase::Terminated)]
    {
        assert_eq!(unsupported(m.c, "fmi2SetTime", WHY_MODEL_EXCHANGE), fmi2Error);
        assert!(m.last_error().contains("fmi2SetTime: not supported in co-simulation"), "{}", m.last_error());
        assert_eq!(unsupported(m.c, "fmi2GetDirectionalDerivative", WHY_DIRECTIONAL_DERIVATIVE), fmi2Error);
        assert!(m.last_error().contains("providesDirectionalDerivative is false"), "{}", m.last_error());
        assert_eq!(cancel_step(m.c), fmi2Error);
        assert!(m.last_error().contains("fmi2CancelStep: not supported"), "{}", m.last_error());
        assert_eq!(m.phase(), phase, "an unsupported call moved the instance out of {phase:?}");
    }
    // The instance that was stepping still steps, from where it was.
    assert_eq!(do_step(stepping.c, 0.0, 0.1, 0), fmi2OK, "{}", stepping.last_error());
    // A NULL instance gets fmi2Error and nothing else.
    assert_eq!(unsupported(null_mut(), "fmi2SetTime", WHY_MODEL_EXCHANGE), fmi2Error);
    assert_eq!(cancel_step(null_mut()), fmi2Error);
}

#[test]
fn a_step_longer_than_the_maximum_is_rejected_without_being_computed() {
    let m = Master::initialized();
    let vr = TestVar::PanicOnStep as u32;
    // The model would panic if it were asked to step: the rejection must come first.
    assert_eq!(set_boolean(m.c, &vr, 1, &1), fmi2OK);
    assert_eq!(do_step(m.c, 0.0, 1e300, 0), fmi2Error);
    assert!(m.last_error().contains("longer than the longest step"), "{}", m.last_error());
    let m = Master::initialized();
    assert_eq!(do_step(m.c, 0.0, MAX_STEP_SIZE * (1.0 + 1e-15), 0), fmi2Error);
    // The maximum itself is a legal step.
    let m = Master::initialized();
    assert_eq!(do_step(m.c, 0.0, MAX_STEP_SIZE, 0), fmi2OK, "{}", m.last_error());
}

#[test]
fn a_step_that_ends_after_the_stop_time_is_rejected_but_rounding_is_tolerated() {
    let with_stop = |stop: f64| {
        let m = Master::new();
        assert_eq!(setup_experiment(m.c, 0, 0.0, 0.0, 1, stop), fmi2OK);
        assert_eq!(enter_initialization_mode(m.c), fmi2OK);
        assert_eq!(exit_initialization_mode(m.c), fmi2OK);
        m
    };
    let m = with_stop(1.0);
    assert_eq!(do_step(m.c, 0.0, 1.5, 0), fmi2Error);
    assert!(m.last_error().contains("after the stopTime 1"), "{}", m.last_error());
    assert_eq!(m.get(Y), 0.0, "the rejected step changed the output");
    // A huge step cannot hide behind a tolerance that grows with it.
    let m = with_stop(1.0);
    assert_eq!(do_step(m.c, 0.0, 1e4, 0), fmi2Error);
    assert!(m.last_error().contains("stopTime"), "{}", m.last_error());
    // Ten steps of 0.1 accumulated in floating point end a few ulps from 1.0: accepted, as is
    // a step that ends within the relative tolerance of 1e-9; one beyond it is not.
    let m = with_stop(1.0);
    let mut t = 0.0;
    for _ in 0..10 {
        assert_eq!(do_step(m.c, t, 0.1, 0), fmi2OK, "{}", m.last_error());
        t += 0.1;
    }
    assert_ne!(t, 1.0, "the accumulated time is expected to be off by rounding");
    let m = with_stop(1.0);
    assert_eq!(do_step(m.c, 0.0, 1.0 + 0.5e-9, 0), fmi2OK, "{}", m.last_error());
    let m = with_stop(1.0);
    assert_eq!(do_step(m.c, 0.0, 1.0 + 2e-9, 0), fmi2Error);
}

#[test]
fn instances_run_independently_on_several_threads() {
    let handles: Vec<_> = (0..4)
        .map(|k| {
            std::thread::spawn(move || {
                let m = Master::initialized();
                m.set(U, k as f64);
                let mut t = 0.0;
                for _ in 0..1000 {
                    assert_eq!(do_step(m.c, t, 0.001, 0), fmi2OK);
                    t += 0.001;
                }
                m.get(Y)
            })
        })
        .collect();
    for (k, h) in handles.into_iter().enumerate() {
        let y = h.join().unwrap();
        assert!((y - 2.0 * k as f64).abs() < 1e-9, "thread {k}: {y}");
    }
}

#[test]
fn the_model_description_is_valid_and_declares_feedthrough() {
    crate::xml::validate::<TestModel>().unwrap();
    let xml = crate::xml::model_description::<TestModel>();
    let md = fmu_import::ModelDescription::parse(&xml).unwrap();
    assert_eq!(md.guid, crate::xml::guid::<TestModel>());
    let echo = md.variables.iter().position(|v| v.name == "u_echo").unwrap() + 1;
    let input = md.variables.iter().position(|v| v.name == "u").unwrap() + 1;
    let deps: Vec<_> = md.output_dependencies.iter().filter(|(i, _)| *i == echo).collect();
    assert_eq!(deps[0].1.as_deref(), Some(&[input][..]));
    let y = md.variables.iter().position(|v| v.name == "y").unwrap() + 1;
    let deps: Vec<_> = md.output_dependencies.iter().filter(|(i, _)| *i == y).collect();
    assert_eq!(deps[0].1.as_deref(), Some(&[][..]));
}

#[test]
fn a_step_that_would_give_infinity_is_undone_and_refused_with_the_variable() {
    let m = Master::initialized();
    // y grows by gain u h = 2 * 5e307 * 0.5 per step: it overflows within a few steps.
    assert_eq!(m.set(U, 5e307), fmi2OK);
    let mut t = 0.0;
    let (y, failed_at) = loop {
        assert!(t < 5.0, "no overflow");
        let y = m.get(Y);
        if do_step(m.c, t, 0.5, 0) == fmi2Error {
            break (y, t);
        }
        t += 0.5;
    };
    assert!(y.is_finite() && failed_at > 0.0);
    assert!(m.last_error().contains("would give y = inf") && m.last_error().contains("undone"), "{}", m.last_error());
    assert_eq!(m.get(Y), y, "the refused step changed the output");
    assert_eq!(instance_from(m.c).unwrap().time, failed_at, "the refused step moved the time");
}

#[test]
fn booleans_other_than_zero_and_one_are_refused_in_every_call() {
    let m = Master::new();
    let vr = TestVar::PanicOnStep as u32;
    assert_eq!(set_boolean(m.c, &vr, 1, &2), fmi2Error);
    assert!(m.last_error().contains("value[0] = 2 is not an fmi2Boolean"), "{}", m.last_error());
    let m = Master::new();
    assert_eq!(setup_experiment(m.c, 0, 0.0, 0.0, -1, 1.0), fmi2Error);
    assert!(m.last_error().contains("stopTimeDefined = -1"), "{}", m.last_error());
    let m = Master::new();
    assert_eq!(set_debug_logging(m.c, 7, 0, null()), fmi2Error);
    assert!(m.last_error().contains("loggingOn = 7"), "{}", m.last_error());
    let m = Master::initialized();
    assert_eq!(do_step(m.c, 0.0, 0.1, 3), fmi2Error);
    assert!(m.last_error().contains("noSetFMUStatePriorToCurrentPoint = 3"), "{}", m.last_error());
    for (value, expected) in [(0, fmi2OK), (1, fmi2OK)] {
        let m = Master::new();
        assert_eq!(set_boolean(m.c, &vr, 1, &value), expected);
    }
}

#[test]
fn subnormal_values_are_refused_like_non_finite_ones() {
    let m = Master::new();
    assert_eq!(m.set(TestVar::Gain as u32, 5e-324), fmi2Error);
    assert!(m.last_error().contains("subnormal"), "{}", m.last_error());
    let m = Master::new();
    assert_eq!(m.set(TestVar::Gain as u32, 0.0), fmi2OK);
}

#[test]
fn error_messages_are_logged_after_debug_logging_is_switched_off() {
    let m = Master::initialized();
    assert_eq!(set_debug_logging(m.c, 0, 0, null()), fmi2OK);
    let before = m.errors().len();
    assert_eq!(do_step(m.c, 0.0, -1.0, 0), fmi2Error);
    assert_eq!(m.errors().len(), before + 1, "the error was not logged");
}

#[test]
fn values_store_the_variables_a_step_writes_first_in_table_order() {
    let (table, slots) = (TestVar::TABLE, TestVar::SLOTS);
    let mut sorted = slots.to_vec();
    sorted.sort_unstable();
    assert_eq!(sorted, (0..table.len() as u16).collect::<Vec<_>>(), "the slots are not a permutation");
    let mut by_slot: Vec<usize> = (0..table.len()).collect();
    by_slot.sort_by_key(|&i| slots[i]);
    let written = crate::variables::WrittenIndices::of(table);
    let (first, rest) = by_slot.split_at(written.count);
    assert!(first.iter().all(|&i| table[i].written_by_step()) && rest.iter().all(|&i| !table[i].written_by_step()));
    assert!(first.windows(2).chain(rest.windows(2)).all(|w| w[0] < w[1]), "table order is not kept");
    // The test table declares parameters before outputs, so the order really changes.
    assert!(!first.is_empty() && first[0] != 0);
}

#[test]
fn a_step_warning_is_logged_once_and_a_panicking_step_leaves_none_for_the_next() {
    let m = Master::initialized();
    let warnings = || m.callbacks.book.records().into_iter().filter(|r| r.status == Status::Warning).count();
    assert_eq!(m.set(U, 7.0), fmi2OK);
    assert_eq!(do_step(m.c, 0.0, 0.1, 0), fmi2Warning);
    assert_eq!(warnings(), 1);
    assert_eq!(m.set(U, 0.0), fmi2OK);
    assert_eq!(do_step(m.c, 0.1, 0.1, 0), fmi2OK, "the warning was carried to the next step");
    assert_eq!(warnings(), 1);
    let mut state: fmi2FMUstate = null_mut();
    assert_eq!(get_fmu_state(m.c, &mut state), fmi2OK);
    let panic_vr = TestVar::PanicOnStep as u32;
    assert_eq!(set_boolean(m.c, &panic_vr, 1, &1), fmi2OK);
    assert_eq!(do_step(m.c, 0.2, 0.1, 0), fmi2Error);
    assert_eq!(set_fmu_state(m.c, state), fmi2OK);
    assert_eq!(do_step(m.c, 0.2, 0.1, 0), fmi2OK, "the panicking step's warning was carried over");
    assert_eq!(warnings(), 1);
    assert_eq!(free_fmu_state(m.c, &mut state), fmi2OK);
}

#[test]
fn saved_values_list_each_type_in_table_order_whatever_the_storage_order() {
    let mut values = Values::<TestVar>::at_start();
    // Distinct values, so that any other order shows.
    let reals: Vec<usize> =
        (0..TestVar::TABLE.len()).filter(|&i| TestVar::TABLE[i].base_type() == BaseType::Real).collect();
    for (k, &i) in reals.iter().enumerate() {
        values.set_real(TestVar::from_index(i).unwrap(), k as f64 + 0.5);
    }
    let bytes = postcard::to_allocvec(&values).unwrap();
    let (saved, _, _, _): (Vec<f64>, Vec<i32>, Vec<bool>, Vec<String>) = postcard::from_bytes(&bytes).unwrap();
    assert_eq!(saved, (0..reals.len()).map(|k| k as f64 + 0.5).collect::<Vec<_>>());
    let back: Values<TestVar> = postcard::from_bytes(&bytes).unwrap();
    assert_eq!(back, values);
}

#[test]
fn a_step_within_a_few_ulps_of_the_time_from_a_short_decimal_is_that_decimal() {
    // OMSimulator's arithmetic: the time accumulates by the step, and each step is the
    // difference of two communication points, the step give or take an ulp of the time.
    for nominal in [1e-3, 2.5e-4, 0.02, 0.1] {
        let mut time = 0.0_f64;
        let mut moved = 0;
        while time < 1000.0 {
            let next = time + nominal;
            let step = next - time;
            moved += usize::from(step != nominal);
            assert_eq!(grid_step(time, step).to_bits(), nominal.to_bits(), "{nominal} at {time}: {step}");
            time = next;
        }
        // The arithmetic does move the steps: the rule is not vacuous.
        assert!(moved > 1000, "{nominal}: only {moved} steps differ from the nominal");
    }
    // Steps that are no short decimal, or lie further away than a few ulps, stay as they are.
    for (time, step) in [(0.0, 1.0 / 3.0), (0.0, 1e-3 * (1.0 + 1e-9)), (5.0, 0.001_234_567_890_123), (0.0, 86_400.0)] {
        assert_eq!(grid_step(time, step).to_bits(), step.to_bits(), "{step} at {time}");
    }
}
