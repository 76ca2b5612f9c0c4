//! The bodies of the 44 exported `fmi2*` functions.
//!
//! [`crate::export_fmi2!`] expands, in a model crate, into `#[no_mangle] unsafe extern "C"`
//! functions that forward here. Every function: catches panics; checks the instance pointer (after the
//! `n == 0` short-cut where the standard has one); checks that the call is legal in the
//! instance's phase (table in [`crate::phase::legal`]); checks every argument before
//! anything changes; and reports failures through the master's logger with fmi2Error. An error
//! moves the instance to the `Error` phase, from which the standard allows getters, status
//! queries, fmi2SetFMUstate, fmi2Reset and fmi2FreeInstance. The exception are the functions
//! this FMU does not provide ([`unsupported`]): they fail in every phase and change nothing.
//!
//! The functions are `pub` only for the export macro, and `unsafe`: their raw-pointer arguments
//! must be what the FMI 2.0 standard says (each function's `# Safety` section), which safe Rust
//! cannot check. The exported shims are `unsafe extern "C"` functions with the same contract,
//! kept by the C master that calls them; every `// SAFETY:` comment relies on it.

use std::cell::RefCell;
use std::ffi::{c_char, CStr, CString};
use std::panic::{self, AssertUnwindSafe};
use std::path::PathBuf;
use std::sync::Once;

use crate::call_error::{ArgumentError, CallError, InstantiateError, StepError, UriError};
use crate::ffi::*;
use crate::instance::{DynModel, Instance, InstanceError, ModelSlot, SavedState, INSTANCE_MAGIC, STATE_MAGIC};
use crate::model::{Context, Model, ModelInfo, Notes};
use crate::phase::{legal, Phase, CAT_CALLS, CAT_DISCARD, CAT_ERROR, CAT_EVENTS, CAT_WARNING, LOG_CATEGORIES};
use crate::variables::SetPhase;

/// One model a shared library can instantiate, chosen by GUID in fmi2Instantiate.
pub struct ModelEntry {
    pub info: fn() -> ModelInfo,
    pub guid: fn() -> String,
    pub create: fn(&Context) -> Result<Box<dyn DynModel>, InstanceError>,
}

impl ModelEntry {
    pub const fn of<M: Model>() -> ModelEntry {
        ModelEntry { info: M::info, guid: crate::xml::guid::<M>, create: create_model::<M> }
    }
}

fn create_model<M: Model>(context: &Context) -> Result<Box<dyn DynModel>, InstanceError> {
    Ok(Box::new(ModelSlot::<M>::create(context, crate::xml::guid::<M>())?))
}

// ---------------------------------------------------------------------------------------------
// Panics: a hook, installed once, that keeps the message of a panic for the instance's logger
// instead of printing it to stderr. The hook belongs to this shared library's own copy of the
// standard library, and this library's code runs only inside exported calls, so every panic it
// sees happened inside an FMU call: no per-call bookkeeping is needed on the happy path. It is
// installed by fmi2Instantiate, before anything else of this library can run: every other
// function that catches panics needs an instance, which only fmi2Instantiate makes, so the
// calls of the hot loop do not check it again.

thread_local! {
    static PANIC_MESSAGE: RefCell<Option<String>> = const { RefCell::new(None) };
}

static PANIC_HOOK: Once = Once::new();

fn install_panic_hook() {
    PANIC_HOOK.call_once(|| {
        // Unit tests of this crate run in a test binary whose other panics (failed assertions)
        // must still be reported, so there the previous hook runs as well.
        let previous = cfg!(test).then(panic::take_hook);
        panic::set_hook(Box::new(move |info| {
            if let Some(previous) = &previous {
                previous(info);
            }
            let payload = info
                .payload()
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| info.payload().downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "(no message)".to_string());
            let location = info.location().map(|l| format!(" at {}:{}", l.file(), l.line())).unwrap_or_default();
            let _ = PANIC_MESSAGE.try_with(|slot| {
                if let Ok(mut slot) = slot.try_borrow_mut() {
                    *slot = Some(format!("{payload}{location}"));
                }
            });
        }));
    });
}

/// A panic caught in a call, with the message (and place) the panic hook kept of it.
#[derive(Debug, thiserror::Error)]
#[error("{message}")]
struct Panicked {
    message: String,
}

/// Runs `f`, turning a panic into `Err` with its message. The panic hook must be installed
/// ([`install_panic_hook`], done by fmi2Instantiate) for the message to be kept.
#[inline(always)]
fn catch<R>(f: impl FnOnce() -> R) -> Result<R, Panicked> {
    panic::catch_unwind(AssertUnwindSafe(f)).map_err(|_| Panicked { message: panic_message() })
}

/// The message the hook kept of the panic just caught.
#[cold]
#[inline(never)]
fn panic_message() -> String {
    PANIC_MESSAGE.with(|slot| slot.borrow_mut().take()).unwrap_or_else(|| "(no message)".to_string())
}

// ---------------------------------------------------------------------------------------------
// The common frame of every function that takes an instance.

/// The instance behind a component pointer, or `None` for NULL or a pointer whose magic number
/// is not an instance's.
///
/// # Safety
///
/// `c` is NULL or points to memory that may be read as an [`Instance`]: one that
/// [`instantiate`] of this library returned and that is not yet freed (the standard allows
/// nothing else). The reference must not outlive the call it is used in.
unsafe fn instance_from<'a>(c: fmi2Component) -> Option<&'a mut Instance> {
    if c.is_null() {
        return None;
    }
    // SAFETY: non-null, and by this function's contract an instance of this library; the magic
    // number catches the commonest misuse, a pointer to something else, before any other field
    // is read.
    let instance = unsafe { &mut *(c as *mut Instance) };
    (instance.magic == INSTANCE_MAGIC).then_some(instance)
}

/// Checks the instance (from [`instance_from`]) and the phase, then runs the body with panics
/// caught. An error result moves the instance to the Error phase. Everything but the checks
/// and the body is out of line, so that the frame of a hot call stays small.
#[inline(always)]
fn with_instance(
    instance: Option<&mut Instance>,
    function: &'static str,
    allowed: u32,
    body: impl FnOnce(&mut Instance) -> Result<Status, CallError>,
) -> fmi2Status {
    let Some(instance) = instance else { return fmi2Error };
    if instance.category_enabled(CAT_CALLS) {
        log_call(instance, function);
    }
    if instance.phase as u32 & allowed == 0 {
        return illegal_call(instance, function, allowed);
    }
    let borrowed: &mut Instance = &mut *instance;
    match catch(move || body(borrowed)) {
        Ok(Ok(status)) => status as fmi2Status,
        Ok(Err(error)) => failed_call(instance, function, error),
        Err(panicked) => panicked_call(instance, function, panicked),
    }
}

/// Logs a call under logCalls.
#[cold]
#[inline(never)]
fn log_call(instance: &Instance, function: &str) {
    instance.log(Status::Ok, CAT_CALLS, &format!("{function} (phase {})", instance.phase.name()));
}

/// Refuses a call the phase does not allow: logged, and the instance moves to the Error phase
/// (a Fatal one stays Fatal).
#[cold]
#[inline(never)]
fn illegal_call(instance: &mut Instance, function: &str, allowed: u32) -> fmi2Status {
    let message = format!(
        "illegal call in phase {}: {function} is allowed in {}",
        instance.phase.name(),
        legal::describe(allowed)
    );
    instance.error(function, &message);
    if instance.phase != Phase::Fatal {
        instance.phase = Phase::Error;
    }
    fmi2Error
}

/// A call whose body failed: logged, and the instance moves to the Error phase.
#[cold]
#[inline(never)]
fn failed_call(instance: &mut Instance, function: &str, error: CallError) -> fmi2Status {
    instance.error(function, &error.to_string());
    instance.phase = Phase::Error;
    fmi2Error
}

/// A call whose body panicked: logged, and the instance moves to the Error phase.
#[cold]
#[inline(never)]
fn panicked_call(instance: &mut Instance, function: &str, panicked: Panicked) -> fmi2Status {
    instance.error(function, &format!("internal error (panic): {panicked}"));
    instance.phase = Phase::Error;
    // A step that panicked may have left notes behind; they are not the next step's.
    instance.step_notes = Notes::default();
    fmi2Error
}

/// Builds a slice from a C array after the `n == 0` short-cut and a null check.
///
/// # Safety
///
/// `pointer` is NULL or points to `n` initialised elements that stay valid and unchanged while
/// the slice is used (FMI 2.0 calling convention for arrays).
#[inline(always)]
unsafe fn slice<'a, T>(pointer: *const T, n: usize, what: &'static str) -> Result<&'a [T], ArgumentError> {
    if n == 0 {
        return Ok(&[]);
    }
    if pointer.is_null() {
        return Err(null_array(what, n));
    }
    // SAFETY: non-null, so by this function's contract `n` valid elements; n == 0 was handled
    // above.
    Ok(unsafe { std::slice::from_raw_parts(pointer, n) })
}

/// [`slice`] for a buffer the caller lends for writing.
///
/// # Safety
///
/// `pointer` is NULL or points to `n` elements that may be written and are not accessed
/// otherwise while the slice is used.
#[inline(always)]
unsafe fn slice_mut<'a, T>(pointer: *mut T, n: usize, what: &'static str) -> Result<&'a mut [T], ArgumentError> {
    if n == 0 {
        return Ok(&mut []);
    }
    if pointer.is_null() {
        return Err(null_array(what, n));
    }
    // SAFETY: non-null, so by this function's contract `n` writable elements lent to us alone.
    Ok(unsafe { std::slice::from_raw_parts_mut(pointer, n) })
}

/// Why an array argument is refused.
#[cold]
#[inline(never)]
fn null_array(what: &'static str, n: usize) -> ArgumentError {
    ArgumentError::NullArray { what, n }
}

/// Copies a C string; the caller's buffer may be freed after the call returns.
///
/// # Safety
///
/// `pointer` is NULL or a NUL-terminated string valid during the call.
unsafe fn copy_string(pointer: fmi2String, what: &str) -> Result<String, ArgumentError> {
    if pointer.is_null() {
        return Err(ArgumentError::NullString { what: what.into() });
    }
    // SAFETY: non-null, so by this function's contract a NUL-terminated string.
    let c = unsafe { CStr::from_ptr(pointer) };
    c.to_str().map(str::to_string).map_err(|_| ArgumentError::NotUtf8 { what: what.into() })
}

/// The one rule for `fmi2Boolean` arguments, the same in every call that takes one
/// (fmi2Instantiate, fmi2SetDebugLogging, fmi2SetupExperiment, fmi2SetBoolean, fmi2DoStep):
/// `fmi2False` (0) is false, `fmi2True` (1) is true, and any other value is refused with
/// fmi2Error, because FMI 2.0 defines only these two and a master that passes 2 or -1 has a bug
/// that a silent "non-zero is true" would hide.
pub fn fmi_boolean(value: fmi2Boolean, what: &str) -> Result<bool, ArgumentError> {
    match value {
        0 => Ok(false),
        1 => Ok(true),
        other => Err(ArgumentError::NotBoolean { what: what.into(), value: other }),
    }
}

fn set_phase(instance: &Instance) -> Result<SetPhase, CallError> {
    match instance.phase {
        Phase::Instantiated => Ok(SetPhase::BeforeInitialization),
        Phase::InitializationMode => Ok(SetPhase::Initialization),
        Phase::StepComplete => Ok(SetPhase::Stepping),
        other => Err(not_settable_in(other)),
    }
}

#[cold]
#[inline(never)]
fn not_settable_in(phase: Phase) -> CallError {
    CallError::NotSettableIn(phase)
}

#[inline]
fn log_notes(instance: &Instance, notes: Notes) -> Status {
    // Almost every step has nothing to say: keep that case to two comparisons.
    if notes.is_empty() {
        return Status::Ok;
    }
    log_notes_slow(instance, notes)
}

/// Logs and empties the notes a step left in [`Instance::step_notes`].
#[cold]
#[inline(never)]
fn log_step_notes(instance: &mut Instance) -> Status {
    let notes = std::mem::take(&mut instance.step_notes);
    log_notes_slow(instance, notes)
}

#[cold]
fn log_notes_slow(instance: &Instance, notes: Notes) -> Status {
    for event in &notes.events {
        instance.log(Status::Ok, CAT_EVENTS, event);
    }
    for warning in &notes.warnings {
        instance.log(Status::Warning, CAT_WARNING, warning);
    }
    if notes.warnings.is_empty() {
        Status::Ok
    } else {
        Status::Warning
    }
}

/// Brings outputs up to date before `vrs` are read: calculated values during initialisation,
/// feedthrough outputs after new inputs while stepping. The feedthrough outputs are recomputed
/// only when one of them is read: a master that reads the other outputs every step (the
/// coupled antenna never reads the azimuth plant's inertia) does not pay for them, and the
/// pending update waits, still marked, for the first get that needs it.
#[inline]
fn ensure_initialized(instance: &mut Instance, vrs: &[u32]) -> Result<Status, CallError> {
    // The common case, nothing pending, decided without a call.
    if instance.stale_feedthrough == 0 && !instance.needs_initialize {
        return Ok(Status::Ok);
    }
    ensure_initialized_slow(instance, vrs)
}

fn ensure_initialized_slow(instance: &mut Instance, vrs: &[u32]) -> Result<Status, CallError> {
    if instance.stale_feedthrough != 0 && instance.phase == Phase::StepComplete {
        let groups = instance.stale_feedthrough & instance.model.feedthrough_groups_read(vrs);
        if groups != 0 {
            instance.model.update_feedthrough(groups);
            instance.stale_feedthrough &= !groups;
        }
    }
    if instance.needs_initialize && instance.phase == Phase::InitializationMode {
        let mut notes = Notes::new(instance.category_enabled(CAT_EVENTS));
        instance.model.initialize(&instance.context, &mut notes)?;
        instance.needs_initialize = false;
        return Ok(log_notes(instance, notes));
    }
    Ok(Status::Ok)
}

// ---------------------------------------------------------------------------------------------
// Inquiry and logging.

pub fn get_types_platform() -> *const c_char {
    c"default".as_ptr()
}

pub fn get_version() -> *const c_char {
    c"2.0".as_ptr()
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed. `categories` is NULL or points to `n` NUL-terminated strings.
pub unsafe fn set_debug_logging(
    c: fmi2Component,
    logging_on: fmi2Boolean,
    n: usize,
    categories: *const fmi2String,
) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2SetDebugLogging", legal::SET_DEBUG_LOGGING, |instance| {
        let on = fmi_boolean(logging_on, "loggingOn")?;
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let names = unsafe { slice(categories, n, "categories") }?;
        if names.is_empty() {
            // All categories: debug logging on or off. The messages of failed calls (warnings,
            // discards, errors) are not debug logging and stay on, so that every fmi2Error
            // comes with its reason; a master that does not want them names their category.
            instance.logging_on = on;
            for (index, enabled) in instance.categories.iter_mut().enumerate() {
                *enabled = on || [CAT_WARNING, CAT_DISCARD, CAT_ERROR, crate::phase::CAT_FATAL].contains(&index);
            }
            return Ok(Status::Ok);
        }
        let mut indices = Vec::with_capacity(names.len());
        for &name in names {
            // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
            let name = unsafe { copy_string(name, "category name") }?;
            let index = LOG_CATEGORIES
                .iter()
                .position(|(n, _)| *n == name)
                .ok_or_else(|| CallError::UnknownCategory { name: name.clone() })?;
            indices.push(index);
        }
        for index in indices {
            instance.categories[index] = on;
        }
        instance.logging_on = on || instance.categories.iter().any(|&c| c);
        Ok(Status::Ok)
    })
}

// ---------------------------------------------------------------------------------------------
// Creation and destruction.

/// Decodes a `file:` URI (RFC 8089 forms `file:///p`, `file://localhost/p`, `file:/p`) into a
/// path, percent-decoding it. Other schemes are not usable by a shared library.
pub fn resource_path_from_uri(uri: &str) -> Result<PathBuf, UriError> {
    let rest = uri
        .strip_prefix("file://localhost/")
        .map(|r| format!("/{r}"))
        .or_else(|| uri.strip_prefix("file:///").map(|r| format!("/{r}")))
        .or_else(|| uri.strip_prefix("file:/").filter(|r| !r.starts_with('/')).map(|r| format!("/{r}")))
        .ok_or_else(|| UriError::NotAFileUri { uri: uri.into() })?;
    let bytes = rest.as_bytes();
    let mut decoded = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = bytes.get(i + 1..i + 3).and_then(|h| std::str::from_utf8(h).ok());
            let value = hex.and_then(|h| u8::from_str_radix(h, 16).ok());
            match value {
                Some(v) => {
                    decoded.push(v);
                    i += 3;
                    continue;
                }
                None => return Err(UriError::MalformedEscape { uri: uri.into() }),
            }
        }
        decoded.push(bytes[i]);
        i += 1;
    }
    let text = String::from_utf8(decoded).map_err(|_| UriError::NotUtf8 { uri: uri.into() })?;
    Ok(PathBuf::from(text))
}

/// A logger-only stand-in used to report why instantiation failed before an instance exists.
fn log_without_instance(functions: &fmi2CallbackFunctions, name: &CStr, message: &str) {
    let Some(logger) = functions.logger else { return };
    let escaped = CString::new(message.replace('%', "%%").replace('\0', " ")).unwrap_or_default();
    // SAFETY: the logger was given by the master in this very call; all strings are valid and
    // NUL-terminated, and no variadic arguments are passed (the message has no conversions).
    unsafe {
        logger(functions.componentEnvironment, name.as_ptr(), fmi2Error, c"logStatusError".as_ptr(), escaped.as_ptr());
    }
}

/// # Safety
///
/// Every string argument is NULL or a NUL-terminated string, and `functions` is NULL or points to
/// the master's callback functions (FMI 2.0, fmi2Instantiate).
#[allow(clippy::too_many_arguments)]
pub unsafe fn instantiate(
    models: &[ModelEntry],
    instance_name: fmi2String,
    fmu_type: fmi2Type,
    guid: fmi2String,
    resource_location: fmi2String,
    functions: *const fmi2CallbackFunctions,
    visible: fmi2Boolean,
    logging_on: fmi2Boolean,
) -> fmi2Component {
    if functions.is_null() {
        return std::ptr::null_mut();
    }
    // SAFETY: non-null, and the standard makes it point to the master's callback struct. It is
    // copied: FMI 2.0 asks the master to keep it alive, but a copy costs nothing and does not
    // depend on that.
    let callbacks = unsafe { *functions };
    // Before any call of this library can panic (see `install_panic_hook`).
    install_panic_hook();
    let result = catch(|| -> Result<Box<Instance>, (CString, InstantiateError)> {
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let name = match unsafe { copy_string(instance_name, "instanceName") } {
            Ok(n) if !n.is_empty() => n,
            Ok(_) => return Err((c"?".into(), InstantiateError::EmptyName)),
            Err(e) => return Err((c"?".into(), e.into())),
        };
        let c_name = CString::new(name.clone()).unwrap_or_default();
        let fail = |error: InstantiateError| (c_name.clone(), error);
        if fmu_type != fmi2CoSimulation {
            return Err(fail(InstantiateError::NotCoSimulation(fmu_type)));
        }
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let guid = unsafe { copy_string(guid, "fmuGUID") }.map_err(|e| fail(e.into()))?;
        let entry = models.iter().find(|m| (m.guid)() == guid).ok_or_else(|| {
            let known = models.iter().map(|m| format!("{} {}", (m.info)().model_identifier, (m.guid)())).collect();
            fail(InstantiateError::UnknownGuid { guid: guid.clone(), known })
        })?;
        let resource_dir = if resource_location.is_null() {
            None
        } else {
            // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
            let uri = unsafe { copy_string(resource_location, "fmuResourceLocation") }.map_err(|e| fail(e.into()))?;
            Some(resource_path_from_uri(&uri).map_err(|e| fail(e.into()))?)
        };
        fmi_boolean(visible, "visible").map_err(|e| fail(e.into()))?;
        let on = fmi_boolean(logging_on, "loggingOn").map_err(|e| fail(e.into()))?;
        let context = Context { instance_name: name, resource_dir };
        let model = (entry.create)(&context).map_err(|e| fail(e.into()))?;
        let mut categories = [on; LOG_CATEGORIES.len()];
        // Errors and warnings are reported even without debug logging: a master needs to know
        // why a call failed. A master can still switch them off with fmi2SetDebugLogging.
        for always in [CAT_WARNING, CAT_DISCARD, CAT_ERROR, crate::phase::CAT_FATAL] {
            categories[always] = true;
        }
        categories[CAT_CALLS] = false;
        Ok(Box::new(Instance {
            magic: INSTANCE_MAGIC,
            name: c_name,
            callbacks,
            logging_on: on,
            categories,
            phase: Phase::Instantiated,
            time: 0.0,
            start_time: 0.0,
            stop_time: None,
            last_successful_time: 0.0,
            last_step_status: Status::Ok,
            needs_initialize: true,
            stale_feedthrough: 0,
            grid_step_cache: ((0, 0, 0), 0.0),
            feedthrough_groups: model.feedthrough_groups(),
            step_notes: Notes::default(),
            context,
            model,
            create: entry.create,
            state_check_model: None,
            returned_strings: Vec::new(),
        }))
    });
    match result {
        Ok(Ok(instance)) => Box::into_raw(instance) as fmi2Component,
        Ok(Err((name, error))) => {
            log_without_instance(&callbacks, &name, &format!("fmi2Instantiate: {error}"));
            std::ptr::null_mut()
        }
        Err(panicked) => {
            log_without_instance(&callbacks, c"?", &format!("fmi2Instantiate: internal error (panic): {panicked}"));
            std::ptr::null_mut()
        }
    }
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed. It is not used again after this call.
pub unsafe fn free_instance(c: fmi2Component) {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let Some(instance) = (unsafe { instance_from(c) }) else { return };
    instance.magic = 0;
    let _ = catch(|| {
        // SAFETY: the pointer came from Box::into_raw in `instantiate` and the master frees each
        // instance once; the magic number was cleared above so a second free is caught.
        drop(unsafe { Box::from_raw(c as *mut Instance) });
    });
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed.
pub unsafe fn setup_experiment(
    c: fmi2Component,
    tolerance_defined: fmi2Boolean,
    _tolerance: fmi2Real,
    start_time: fmi2Real,
    stop_time_defined: fmi2Boolean,
    stop_time: fmi2Real,
) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2SetupExperiment", legal::SETUP_EXPERIMENT, |instance| {
        fmi_boolean(tolerance_defined, "toleranceDefined")?;
        let stop_defined = fmi_boolean(stop_time_defined, "stopTimeDefined")?;
        if !start_time.is_finite() {
            return Err(CallError::StartNotFinite { start: start_time });
        }
        let stop = if stop_defined {
            if !stop_time.is_finite() || stop_time < start_time {
                return Err(CallError::BadStopTime { start: start_time, stop: stop_time });
            }
            Some(stop_time)
        } else {
            None
        };
        // The tolerance is ignored on purpose: the linear parts are stepped exactly and the
        // nonlinear parts by a fixed documented scheme.
        instance.start_time = start_time;
        instance.time = start_time;
        instance.last_successful_time = start_time;
        instance.stop_time = stop;
        Ok(Status::Ok)
    })
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed.
pub unsafe fn enter_initialization_mode(c: fmi2Component) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2EnterInitializationMode", legal::ENTER_INITIALIZATION_MODE, |instance| {
        instance.phase = Phase::InitializationMode;
        instance.needs_initialize = true;
        Ok(Status::Ok)
    })
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed.
pub unsafe fn exit_initialization_mode(c: fmi2Component) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2ExitInitializationMode", legal::EXIT_INITIALIZATION_MODE, |instance| {
        let status = if instance.needs_initialize {
            let mut notes = Notes::new(instance.category_enabled(CAT_EVENTS));
            instance.model.initialize(&instance.context, &mut notes)?;
            instance.needs_initialize = false;
            log_notes(instance, notes)
        } else {
            Status::Ok
        };
        instance.phase = Phase::StepComplete;
        Ok(status)
    })
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed.
pub unsafe fn terminate(c: fmi2Component) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2Terminate", legal::TERMINATE, |instance| {
        instance.phase = Phase::Terminated;
        Ok(Status::Ok)
    })
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed.
pub unsafe fn reset(c: fmi2Component) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2Reset", legal::RESET, |instance| {
        let model = (instance.create)(&instance.context)?;
        instance.model = model;
        instance.phase = Phase::Instantiated;
        instance.time = 0.0;
        instance.start_time = 0.0;
        instance.stop_time = None;
        instance.last_successful_time = 0.0;
        instance.last_step_status = Status::Ok;
        instance.needs_initialize = true;
        instance.stale_feedthrough = 0;
        Ok(Status::Ok)
    })
}

// ---------------------------------------------------------------------------------------------
// Getting and setting values.

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed. `vr` and `value` are NULL or point to `n` elements each (they are not read when `n` is
/// 0).
pub unsafe fn get_real(c: fmi2Component, vr: *const fmi2ValueReference, n: usize, value: *mut fmi2Real) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2GetReal", legal::GET, |instance| {
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let vrs = unsafe { slice(vr, n, "vr") }?;
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let out = unsafe { slice_mut(value, n, "value") }?;
        // The feedthrough part of `ensure_initialized` is done by the model's get, which looks
        // at each reference anyway (the hottest get: no second pass over them).
        let status = if instance.needs_initialize { ensure_initialized(instance, &[])? } else { Status::Ok };
        let stale = if instance.phase == Phase::StepComplete { instance.stale_feedthrough } else { 0 };
        let refreshed = instance.model.get_real(vrs, out, stale)?;
        instance.stale_feedthrough &= !refreshed;
        Ok(status)
    })
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed. `vr` and `value` are NULL or point to `n` elements each (they are not read when `n` is
/// 0).
pub unsafe fn get_integer(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    value: *mut fmi2Integer,
) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2GetInteger", legal::GET, |instance| {
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let vrs = unsafe { slice(vr, n, "vr") }?;
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let out = unsafe { slice_mut(value, n, "value") }?;
        let status = ensure_initialized(instance, vrs)?;
        instance.model.get_integer(vrs, out)?;
        Ok(status)
    })
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed. `vr` and `value` are NULL or point to `n` elements each (they are not read when `n` is
/// 0).
pub unsafe fn get_boolean(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    value: *mut fmi2Boolean,
) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2GetBoolean", legal::GET, |instance| {
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let vrs = unsafe { slice(vr, n, "vr") }?;
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let out = unsafe { slice_mut(value, n, "value") }?;
        let status = ensure_initialized(instance, vrs)?;
        let mut values = vec![false; n];
        instance.model.get_boolean(vrs, &mut values)?;
        for (o, v) in out.iter_mut().zip(values) {
            *o = if v { fmi2True } else { fmi2False };
        }
        Ok(status)
    })
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed. `vr` and `value` are NULL or point to `n` elements each (they are not read when `n` is
/// 0).
pub unsafe fn get_string(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    value: *mut fmi2String,
) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2GetString", legal::GET, |instance| {
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let vrs = unsafe { slice(vr, n, "vr") }?;
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let out = unsafe { slice_mut(value, n, "value") }?;
        let status = ensure_initialized(instance, vrs)?;
        let strings = instance.model.get_string(vrs)?;
        instance.returned_strings =
            strings.into_iter().map(|s| CString::new(s.replace('\0', " ")).unwrap_or_default()).collect();
        for (o, s) in out.iter_mut().zip(&instance.returned_strings) {
            *o = s.as_ptr();
        }
        Ok(status)
    })
}

fn mark_changed(instance: &mut Instance) {
    if matches!(instance.phase, Phase::Instantiated | Phase::InitializationMode) {
        instance.needs_initialize = true;
    } else {
        instance.stale_feedthrough = instance.feedthrough_groups;
    }
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed. `vr` and `value` are NULL or point to `n` elements each (they are not read when `n` is
/// 0).
pub unsafe fn set_real(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    value: *const fmi2Real,
) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2SetReal", legal::SET_REAL, |instance| {
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let vrs = unsafe { slice(vr, n, "vr") }?;
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let values = unsafe { slice(value, n, "value") }?;
        let phase = set_phase(instance)?;
        instance.model.set_real(vrs, values, phase)?;
        mark_changed(instance);
        Ok(Status::Ok)
    })
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed. `vr` and `value` are NULL or point to `n` elements each (they are not read when `n` is
/// 0).
pub unsafe fn set_integer(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    value: *const fmi2Integer,
) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2SetInteger", legal::SET_OTHER, |instance| {
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let vrs = unsafe { slice(vr, n, "vr") }?;
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let values = unsafe { slice(value, n, "value") }?;
        let phase = set_phase(instance)?;
        instance.model.set_integer(vrs, values, phase)?;
        mark_changed(instance);
        Ok(Status::Ok)
    })
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed. `vr` and `value` are NULL or point to `n` elements each (they are not read when `n` is
/// 0).
pub unsafe fn set_boolean(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    value: *const fmi2Boolean,
) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2SetBoolean", legal::SET_OTHER, |instance| {
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let vrs = unsafe { slice(vr, n, "vr") }?;
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let raw = unsafe { slice(value, n, "value") }?;
        let phase = set_phase(instance)?;
        let mut values = Vec::with_capacity(raw.len());
        for (i, &b) in raw.iter().enumerate() {
            values.push(match b {
                0 => false,
                1 => true,
                other => return Err(ArgumentError::NotBoolean { what: format!("value[{i}]"), value: other }.into()),
            });
        }
        instance.model.set_boolean(vrs, &values, phase)?;
        mark_changed(instance);
        Ok(Status::Ok)
    })
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed. `vr` and `value` are NULL or point to `n` elements each (they are not read when `n` is
/// 0). Each string in `value` is NULL or NUL-terminated.
pub unsafe fn set_string(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    value: *const fmi2String,
) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2SetString", legal::SET_OTHER, |instance| {
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let vrs = unsafe { slice(vr, n, "vr") }?;
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let raw = unsafe { slice(value, n, "value") }?;
        let phase = set_phase(instance)?;
        let values = raw
            .iter()
            .enumerate()
            // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
            .map(|(i, &s)| unsafe { copy_string(s, &format!("value[{i}]")) })
            .collect::<Result<Vec<_>, _>>()?;
        let context = instance.context.clone();
        instance.model.set_string(vrs, values, phase, &context)?;
        mark_changed(instance);
        Ok(Status::Ok)
    })
}

// ---------------------------------------------------------------------------------------------
// FMU states.

/// The saved state behind an FMUstate pointer, checked by its magic number.
///
/// # Safety
///
/// `state` is NULL or a state that this library created and that is not yet freed (the
/// standard allows nothing else). The reference must not outlive the call it is used in.
unsafe fn saved_state<'a>(state: fmi2FMUstate) -> Result<&'a mut SavedState, CallError> {
    if state.is_null() {
        return Err(CallError::NullState);
    }
    // SAFETY: non-null, so by this function's contract a state created by fmi2GetFMUstate or
    // fmi2DeSerializeFMUstate of this library; the magic number catches other pointers.
    let saved = unsafe { &mut *(state as *mut SavedState) };
    if saved.magic != STATE_MAGIC {
        return Err(CallError::ForeignState);
    }
    Ok(saved)
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed. `state` is NULL or points to the master's FMUstate variable, which is NULL or a state of
/// this library.
pub unsafe fn get_fmu_state(c: fmi2Component, state: *mut fmi2FMUstate) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2GetFMUstate", legal::FMU_STATE, |instance| {
        if state.is_null() {
            return Err(CallError::NullStatePointer);
        }
        let bytes = instance.save_state()?;
        // SAFETY: `state` is a valid pointer to the master's FMUstate variable.
        let existing = unsafe { *state };
        if existing.is_null() {
            let boxed = Box::new(SavedState { magic: STATE_MAGIC, bytes });
            // SAFETY: as above; the master owns the variable and receives the new state.
            unsafe { *state = Box::into_raw(boxed) as fmi2FMUstate };
        } else {
            // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
            unsafe { saved_state(existing) }?.bytes = bytes;
        }
        Ok(Status::Ok)
    })
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed. `state` is NULL or a state that [`get_fmu_state`] or [`deserialize_fmu_state`] of this
/// library returned and that is not yet freed.
pub unsafe fn set_fmu_state(c: fmi2Component, state: fmi2FMUstate) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2SetFMUstate", legal::FMU_STATE, |instance| {
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let bytes = unsafe { saved_state(state) }?.bytes.clone();
        instance.load_state(&bytes)?;
        Ok(Status::Ok)
    })
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed. `state` is NULL or points to the master's FMUstate variable, which is NULL or a state of
/// this library not yet freed.
pub unsafe fn free_fmu_state(c: fmi2Component, state: *mut fmi2FMUstate) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2FreeFMUstate", legal::FMU_STATE, |_instance| {
        if state.is_null() {
            return Ok(Status::Ok);
        }
        // SAFETY: `state` points to the master's FMUstate variable.
        let existing = unsafe { *state };
        if existing.is_null() {
            return Ok(Status::Ok);
        }
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let saved = unsafe { saved_state(existing) }?;
        saved.magic = 0;
        // SAFETY: created by Box::into_raw in this module; the magic check above and its reset
        // make a double free an error instead of undefined behaviour in the common case.
        drop(unsafe { Box::from_raw(existing as *mut SavedState) });
        // SAFETY: as above.
        unsafe { *state = std::ptr::null_mut() };
        Ok(Status::Ok)
    })
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed. `state` is NULL or a live state of this library; `size` is NULL or points to the
/// master's variable.
pub unsafe fn serialized_fmu_state_size(c: fmi2Component, state: fmi2FMUstate, size: *mut usize) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2SerializedFMUstateSize", legal::FMU_STATE, |_instance| {
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let saved = unsafe { saved_state(state) }?;
        if size.is_null() {
            return Err(CallError::NullSize);
        }
        // SAFETY: non-null pointer to the master's size variable.
        unsafe { *size = saved.bytes.len() };
        Ok(Status::Ok)
    })
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed. `state` is NULL or a live state of this library; `bytes` is NULL or points to `size`
/// writable bytes.
pub unsafe fn serialize_fmu_state(
    c: fmi2Component,
    state: fmi2FMUstate,
    bytes: *mut fmi2Byte,
    size: usize,
) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2SerializeFMUstate", legal::FMU_STATE, |_instance| {
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let saved = unsafe { saved_state(state) }?;
        if size != saved.bytes.len() {
            return Err(CallError::BufferSize { size, needed: saved.bytes.len() });
        }
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let out = unsafe { slice_mut(bytes as *mut u8, size, "serializedState") }?;
        out.copy_from_slice(&saved.bytes);
        Ok(Status::Ok)
    })
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed. `bytes` is NULL or points to `size` bytes; `state` is NULL or points to the master's
/// FMUstate variable, which is NULL or a state of this library.
pub unsafe fn deserialize_fmu_state(
    c: fmi2Component,
    bytes: *const fmi2Byte,
    size: usize,
    state: *mut fmi2FMUstate,
) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2DeSerializeFMUstate", legal::FMU_STATE, |instance| {
        // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
        let data = unsafe { slice(bytes as *const u8, size, "serializedState") }?.to_vec();
        if state.is_null() {
            return Err(CallError::NullStatePointer);
        }
        instance.check_state(&data).map_err(CallError::StateRejected)?;
        // SAFETY: non-null pointer to the master's FMUstate variable.
        let existing = unsafe { *state };
        if existing.is_null() {
            let boxed = Box::new(SavedState { magic: STATE_MAGIC, bytes: data });
            // SAFETY: as above.
            unsafe { *state = Box::into_raw(boxed) as fmi2FMUstate };
        } else {
            // SAFETY: the pointer is the caller's, valid as this function's `# Safety` requires.
            unsafe { saved_state(existing) }?.bytes = data;
        }
        Ok(Status::Ok)
    })
}

// ---------------------------------------------------------------------------------------------
// Co-simulation.

/// Relative tolerance on the communication point and on the stop time: masters accumulate
/// `t += h` in floating point, so a point a few ulps away from the instance's time (or a step
/// that ends a few ulps after the stop time) is the same point. Relative to the time itself,
/// never to the step: the rounding of `t + h` is a few ulps of `t`, and a tolerance that grew
/// with the step would let a huge step start anywhere or run far past the stop time.
pub const TIME_TOLERANCE: f64 = 1e-9;

/// The longest communication step accepted, s: one day of simulated time.
///
/// The models cut a step into internal pieces of at most about a millisecond (the plants'
/// event check interval, the controllers' 1 kHz sample clock), so a step's cost grows with its
/// length: a step of 1e300 s would keep the call busy for ever. One day, longer than any
/// observation, costs a few seconds of computing per FMU (docs/plant-fmu-tests.md, section 5),
/// so that a master gets an answer in seconds, never a hang; longer runs take several steps.
pub const MAX_STEP_SIZE: f64 = 86_400.0;

/// The most internal pieces (sub-steps, controller samples; [`Model::step_pieces`]) one
/// `fmi2DoStep` may take: 10^8, the pieces of a one-day step at the default millisecond, which
/// cost some 4-7 s in a plant (docs/plant-fmu-tests.md, section 5). A step that would take more,
/// because its numerics parameters make the pieces short, is refused at once with the count,
/// so every accepted call answers within seconds (docs/fmu-robustness.md).
pub const MAX_STEP_PIECES: f64 = 1e8;

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed.
pub unsafe fn do_step(c: fmi2Component, current: fmi2Real, step: fmi2Real, no_set_prior: fmi2Boolean) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2DoStep", legal::DO_STEP, |instance| {
        // One test for the usual call (NaN fails every comparison); the reasons on the cold path.
        if !(step > 0.0 && step <= MAX_STEP_SIZE && current.abs() <= f64::MAX) {
            return Err(step_arguments_error(current, step).into());
        }
        if no_set_prior != fmi2True && no_set_prior != fmi2False {
            fmi_boolean(no_set_prior, "noSetFMUStatePriorToCurrentPoint")?;
        }
        if (current - instance.time).abs() > TIME_TOLERANCE * instance.time.abs().max(1.0) {
            return Err(StepError::NotContiguous { current, time: instance.time }.into());
        }
        if let Some(stop) = instance.stop_time {
            let end = current + step;
            if end > stop + TIME_TOLERANCE * stop.abs().max(1.0) {
                return Err(StepError::AfterStopTime { current, step, end, stop }.into());
            }
        }
        // The notes are the instance's, empty between calls, so that a step neither builds
        // nor drops any; the model refuses a step of more than MAX_STEP_PIECES pieces.
        instance.step_notes.enable_events(instance.category_enabled(CAT_EVENTS));
        // The rule's tolerance depends on the times only through their binary exponents.
        let key = (step.to_bits(), current.to_bits() >> 52, (current + step).to_bits() >> 52);
        let model_step = if instance.grid_step_cache.0 == key {
            instance.grid_step_cache.1
        } else {
            let model_step = grid_step(current, step);
            instance.grid_step_cache = (key, model_step);
            model_step
        };
        match instance.model.do_step(current, model_step, MAX_STEP_PIECES, &instance.context, &mut instance.step_notes)
        {
            Ok(()) => {
                // Feedthrough outputs are brought up to date lazily, before the next get that
                // reads one of them.
                instance.stale_feedthrough = instance.feedthrough_groups;
                instance.time = current + step;
                instance.last_successful_time = instance.time;
                let status = if instance.step_notes.is_empty() { Status::Ok } else { log_step_notes(instance) };
                instance.last_step_status = status;
                Ok(status)
            }
            Err(e) => {
                // What the failed step noted is not logged (the error says what happened).
                if !instance.step_notes.is_empty() {
                    instance.step_notes = Notes::default();
                }
                instance.last_step_status = Status::Error;
                Err(e.into())
            }
        }
    })
}

/// How far a master's step may lie from a short decimal step and still be taken as it, in
/// units in the last place of the communication point.
pub const STEP_GRID_ULPS: f64 = 4.0;

/// The step the models take for a master's `step` from `current`: the decimal number with the
/// fewest significant digits (at most nine) within [`STEP_GRID_ULPS`] units in the last place
/// of the time, or `step` itself when there is none. Masters that keep a time and step by
/// `h = (t + h0) - t` (OMSimulator does) pass `h0` give or take an ulp of `t`, which grows with
/// the time; the models' results depend on the exact step (a discretisation cached by its bits,
/// an encoder count that flips or not), so without this such a master drifts from one that
/// passes `h0` by a few 1e-4 arcsec on the beam. A step that is no short decimal (1/3 s) is
/// never moved: no decimal of up to nine digits lies that close to it.
pub fn grid_step(current: f64, step: f64) -> f64 {
    let ulp_of_time = |t: f64| {
        let t = t.abs().max(step.abs());
        f64::from_bits(t.to_bits() + 1) - t
    };
    let tolerance = STEP_GRID_ULPS * ulp_of_time(current).max(ulp_of_time(current + step));
    let exponent = step.abs().log10().floor() as i32;
    for digits in 1..=9 {
        let scale = 10f64.powi(digits - 1 - exponent);
        let decimal = (step * scale).round() / scale;
        if decimal > 0.0 && (decimal - step).abs() <= tolerance {
            return decimal;
        }
    }
    step
}

/// Why `fmi2DoStep`'s step size or communication point is refused (one of them is).
#[cold]
#[inline(never)]
fn step_arguments_error(current: f64, step: f64) -> StepError {
    if !step.is_finite() || step <= 0.0 {
        return StepError::StepNotPositive { step };
    }
    if step > MAX_STEP_SIZE {
        return StepError::StepTooLong { step, max: MAX_STEP_SIZE };
    }
    StepError::PointNotFinite { current }
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed.
pub unsafe fn cancel_step(c: fmi2Component) -> fmi2Status {
    // SAFETY: the caller keeps this function's contract, which is `unsupported`'s.
    unsafe { unsupported(c, "fmi2CancelStep", WHY_CANCEL_STEP) }
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed. `value` is NULL or points to the master's variable.
pub unsafe fn get_status(c: fmi2Component, kind: fmi2StatusKind, value: *mut fmi2Status) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2GetStatus", legal::STATUS, |instance| {
        if value.is_null() {
            return Err(CallError::NullValue);
        }
        if kind == fmi2DoStepStatus {
            // SAFETY: non-null pointer to the master's status variable.
            unsafe { *value = instance.last_step_status as fmi2Status };
            Ok(Status::Ok)
        } else {
            instance.log(
                Status::Discard,
                CAT_DISCARD,
                &format!("fmi2GetStatus: status kind {kind} is not provided (steps are synchronous)"),
            );
            Ok(Status::Discard)
        }
    })
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed. `value` is NULL or points to the master's variable.
pub unsafe fn get_real_status(c: fmi2Component, kind: fmi2StatusKind, value: *mut fmi2Real) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2GetRealStatus", legal::STATUS, |instance| {
        if value.is_null() {
            return Err(CallError::NullValue);
        }
        if kind == fmi2LastSuccessfulTime {
            // SAFETY: non-null pointer to the master's variable.
            unsafe { *value = instance.last_successful_time };
            Ok(Status::Ok)
        } else {
            instance.log(
                Status::Discard,
                CAT_DISCARD,
                &format!("fmi2GetRealStatus: status kind {kind} is not provided"),
            );
            Ok(Status::Discard)
        }
    })
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed. `value` is NULL or points to the master's variable.
pub unsafe fn get_integer_status(c: fmi2Component, kind: fmi2StatusKind, value: *mut fmi2Integer) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2GetIntegerStatus", legal::STATUS, |instance| {
        if value.is_null() {
            return Err(CallError::NullValue);
        }
        instance.log(
            Status::Discard,
            CAT_DISCARD,
            &format!("fmi2GetIntegerStatus: status kind {kind} is not provided"),
        );
        Ok(Status::Discard)
    })
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed. `value` is NULL or points to the master's variable.
pub unsafe fn get_boolean_status(c: fmi2Component, kind: fmi2StatusKind, value: *mut fmi2Boolean) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2GetBooleanStatus", legal::STATUS, |instance| {
        if value.is_null() {
            return Err(CallError::NullValue);
        }
        if kind == fmi2Terminated {
            // The model never asks the master to stop.
            // SAFETY: non-null pointer to the master's variable.
            unsafe { *value = fmi2False };
            Ok(Status::Ok)
        } else {
            instance.log(
                Status::Discard,
                CAT_DISCARD,
                &format!("fmi2GetBooleanStatus: status kind {kind} is not provided"),
            );
            Ok(Status::Discard)
        }
    })
}

/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed. `value` is NULL or points to the master's variable.
pub unsafe fn get_string_status(c: fmi2Component, kind: fmi2StatusKind, value: *mut fmi2String) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let instance = unsafe { instance_from(c) };
    with_instance(instance, "fmi2GetStringStatus", legal::STATUS, |instance| {
        if value.is_null() {
            return Err(CallError::NullValue);
        }
        instance.log(
            Status::Discard,
            CAT_DISCARD,
            &format!("fmi2GetStringStatus: status kind {kind} is not provided (steps are synchronous)"),
        );
        Ok(Status::Discard)
    })
}

/// Functions this FMU does not provide. In every phase they log why under logStatusError and
/// return fmi2Error, and they leave the instance exactly as it was, its phase included.
///
/// They do not go through [`with_instance`], which would move the instance to the Error phase:
/// nothing was attempted, so there is nothing to recover from, and a master that probes a
/// capability by calling the function (instead of reading the model description) must not
/// lose the instance by asking. FMI 2.0.2 (section 2.1.3) allows a master to give up on an
/// instance after fmi2Error; it does not require the FMU to refuse further calls, so a master
/// that does give up is served as well as one that carries on. A NULL or foreign instance
/// pointer is still answered with fmi2Error alone, as everywhere.
///
/// # Safety
///
/// `c` is NULL or an instance that [`instantiate`] of this library returned and that is not yet
/// freed.
pub unsafe fn unsupported(c: fmi2Component, function: &'static str, why: &'static str) -> fmi2Status {
    // SAFETY: `c` is NULL or a live instance of this library, as the caller guarantees.
    let Some(instance) = (unsafe { instance_from(c) }) else { return fmi2Error };
    // Logging formats a message and calls the master's logger; a panic there must not unwind
    // into C, and there is nothing else to report it through, so it is dropped.
    let _ = catch(|| {
        if instance.category_enabled(CAT_CALLS) {
            instance.log(Status::Ok, CAT_CALLS, &format!("{function} (phase {})", instance.phase.name()));
        }
        instance.error(function, &format!("{why}; the call changed nothing and the instance stays usable"));
    });
    fmi2Error
}

pub const WHY_MODEL_EXCHANGE: &str =
    "not supported in co-simulation: this is a model-exchange function, and this FMU implements co-simulation only";
pub const WHY_DIRECTIONAL_DERIVATIVE: &str = "not supported: providesDirectionalDerivative is false";
pub const WHY_INPUT_DERIVATIVES: &str =
    "not supported: canInterpolateInputs is false, inputs are held constant over a step";
pub const WHY_OUTPUT_DERIVATIVES: &str = "not supported: maxOutputDerivativeOrder is 0";
pub const WHY_CANCEL_STEP: &str =
    "not supported: canRunAsynchronuously is false, so every fmi2DoStep has completed when it returns and there is no step to cancel";

/// Exports the 44 `fmi2*` functions of FMI 2.0 from a cdylib, serving the listed models (the
/// GUID given to fmi2Instantiate selects one).
///
/// Each function is an `unsafe extern "C"` shim that forwards to the function of the same
/// contract in [`crate::exports`]; the standard binds the C master that calls it.
#[macro_export]
macro_rules! export_fmi2 {
    ($($model:ty),+ $(,)?) => {
        #[doc(hidden)]
        pub mod fmi2_exports {
            #![allow(non_snake_case)]
            #[allow(unused_imports)]
            use super::*;
            use $crate::ffi::*;
            use $crate::exports as x;
            use ::std::ffi::c_char;

            const MODELS: &[x::ModelEntry] = &[$(x::ModelEntry::of::<$model>()),+];

            #[no_mangle] pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char { x::get_types_platform() }
            #[no_mangle] pub extern "C" fn fmi2GetVersion() -> *const c_char { x::get_version() }
            $crate::fmi2_shim!(fmi2SetDebugLogging(c: fmi2Component, on: fmi2Boolean, n: usize, cats: *const fmi2String) -> fmi2Status = x::set_debug_logging(c, on, n, cats));
            $crate::fmi2_shim!(fmi2Instantiate(name: fmi2String, ty: fmi2Type, guid: fmi2String, res: fmi2String, f: *const fmi2CallbackFunctions, visible: fmi2Boolean, on: fmi2Boolean) -> fmi2Component = x::instantiate(MODELS, name, ty, guid, res, f, visible, on));
            $crate::fmi2_shim!(fmi2FreeInstance(c: fmi2Component) -> () = x::free_instance(c));
            $crate::fmi2_shim!(fmi2SetupExperiment(c: fmi2Component, td: fmi2Boolean, tol: fmi2Real, start: fmi2Real, sd: fmi2Boolean, stop: fmi2Real) -> fmi2Status = x::setup_experiment(c, td, tol, start, sd, stop));
            $crate::fmi2_shim!(fmi2EnterInitializationMode(c: fmi2Component) -> fmi2Status = x::enter_initialization_mode(c));
            $crate::fmi2_shim!(fmi2ExitInitializationMode(c: fmi2Component) -> fmi2Status = x::exit_initialization_mode(c));
            $crate::fmi2_shim!(fmi2Terminate(c: fmi2Component) -> fmi2Status = x::terminate(c));
            $crate::fmi2_shim!(fmi2Reset(c: fmi2Component) -> fmi2Status = x::reset(c));
            $crate::fmi2_shim!(fmi2GetReal(c: fmi2Component, vr: *const fmi2ValueReference, n: usize, v: *mut fmi2Real) -> fmi2Status = x::get_real(c, vr, n, v));
            $crate::fmi2_shim!(fmi2GetInteger(c: fmi2Component, vr: *const fmi2ValueReference, n: usize, v: *mut fmi2Integer) -> fmi2Status = x::get_integer(c, vr, n, v));
            $crate::fmi2_shim!(fmi2GetBoolean(c: fmi2Component, vr: *const fmi2ValueReference, n: usize, v: *mut fmi2Boolean) -> fmi2Status = x::get_boolean(c, vr, n, v));
            $crate::fmi2_shim!(fmi2GetString(c: fmi2Component, vr: *const fmi2ValueReference, n: usize, v: *mut fmi2String) -> fmi2Status = x::get_string(c, vr, n, v));
            $crate::fmi2_shim!(fmi2SetReal(c: fmi2Component, vr: *const fmi2ValueReference, n: usize, v: *const fmi2Real) -> fmi2Status = x::set_real(c, vr, n, v));
            $crate::fmi2_shim!(fmi2SetInteger(c: fmi2Component, vr: *const fmi2ValueReference, n: usize, v: *const fmi2Integer) -> fmi2Status = x::set_integer(c, vr, n, v));
            $crate::fmi2_shim!(fmi2SetBoolean(c: fmi2Component, vr: *const fmi2ValueReference, n: usize, v: *const fmi2Boolean) -> fmi2Status = x::set_boolean(c, vr, n, v));
            $crate::fmi2_shim!(fmi2SetString(c: fmi2Component, vr: *const fmi2ValueReference, n: usize, v: *const fmi2String) -> fmi2Status = x::set_string(c, vr, n, v));
            $crate::fmi2_shim!(fmi2GetFMUstate(c: fmi2Component, s: *mut fmi2FMUstate) -> fmi2Status = x::get_fmu_state(c, s));
            $crate::fmi2_shim!(fmi2SetFMUstate(c: fmi2Component, s: fmi2FMUstate) -> fmi2Status = x::set_fmu_state(c, s));
            $crate::fmi2_shim!(fmi2FreeFMUstate(c: fmi2Component, s: *mut fmi2FMUstate) -> fmi2Status = x::free_fmu_state(c, s));
            $crate::fmi2_shim!(fmi2SerializedFMUstateSize(c: fmi2Component, s: fmi2FMUstate, size: *mut usize) -> fmi2Status = x::serialized_fmu_state_size(c, s, size));
            $crate::fmi2_shim!(fmi2SerializeFMUstate(c: fmi2Component, s: fmi2FMUstate, b: *mut fmi2Byte, size: usize) -> fmi2Status = x::serialize_fmu_state(c, s, b, size));
            $crate::fmi2_shim!(fmi2DeSerializeFMUstate(c: fmi2Component, b: *const fmi2Byte, size: usize, s: *mut fmi2FMUstate) -> fmi2Status = x::deserialize_fmu_state(c, b, size, s));
            $crate::fmi2_shim!(fmi2GetDirectionalDerivative(c: fmi2Component, _u: *const fmi2ValueReference, _nu: usize, _z: *const fmi2ValueReference, _nz: usize, _dv: *const fmi2Real, _dz: *mut fmi2Real) -> fmi2Status = x::unsupported(c, "fmi2GetDirectionalDerivative", x::WHY_DIRECTIONAL_DERIVATIVE));
            // Model exchange: not provided.
            $crate::fmi2_shim!(fmi2EnterEventMode(c: fmi2Component) -> fmi2Status = x::unsupported(c, "fmi2EnterEventMode", x::WHY_MODEL_EXCHANGE));
            $crate::fmi2_shim!(fmi2NewDiscreteStates(c: fmi2Component, _info: *mut ::std::ffi::c_void) -> fmi2Status = x::unsupported(c, "fmi2NewDiscreteStates", x::WHY_MODEL_EXCHANGE));
            $crate::fmi2_shim!(fmi2EnterContinuousTimeMode(c: fmi2Component) -> fmi2Status = x::unsupported(c, "fmi2EnterContinuousTimeMode", x::WHY_MODEL_EXCHANGE));
            $crate::fmi2_shim!(fmi2CompletedIntegratorStep(c: fmi2Component, _nsp: fmi2Boolean, _em: *mut fmi2Boolean, _ts: *mut fmi2Boolean) -> fmi2Status = x::unsupported(c, "fmi2CompletedIntegratorStep", x::WHY_MODEL_EXCHANGE));
            $crate::fmi2_shim!(fmi2SetTime(c: fmi2Component, _t: fmi2Real) -> fmi2Status = x::unsupported(c, "fmi2SetTime", x::WHY_MODEL_EXCHANGE));
            $crate::fmi2_shim!(fmi2SetContinuousStates(c: fmi2Component, _x: *const fmi2Real, _n: usize) -> fmi2Status = x::unsupported(c, "fmi2SetContinuousStates", x::WHY_MODEL_EXCHANGE));
            $crate::fmi2_shim!(fmi2GetDerivatives(c: fmi2Component, _dx: *mut fmi2Real, _n: usize) -> fmi2Status = x::unsupported(c, "fmi2GetDerivatives", x::WHY_MODEL_EXCHANGE));
            $crate::fmi2_shim!(fmi2GetEventIndicators(c: fmi2Component, _ei: *mut fmi2Real, _n: usize) -> fmi2Status = x::unsupported(c, "fmi2GetEventIndicators", x::WHY_MODEL_EXCHANGE));
            $crate::fmi2_shim!(fmi2GetContinuousStates(c: fmi2Component, _x: *mut fmi2Real, _n: usize) -> fmi2Status = x::unsupported(c, "fmi2GetContinuousStates", x::WHY_MODEL_EXCHANGE));
            $crate::fmi2_shim!(fmi2GetNominalsOfContinuousStates(c: fmi2Component, _x: *mut fmi2Real, _n: usize) -> fmi2Status = x::unsupported(c, "fmi2GetNominalsOfContinuousStates", x::WHY_MODEL_EXCHANGE));
            // Co-simulation.
            $crate::fmi2_shim!(fmi2SetRealInputDerivatives(c: fmi2Component, _vr: *const fmi2ValueReference, _n: usize, _o: *const fmi2Integer, _v: *const fmi2Real) -> fmi2Status = x::unsupported(c, "fmi2SetRealInputDerivatives", x::WHY_INPUT_DERIVATIVES));
            $crate::fmi2_shim!(fmi2GetRealOutputDerivatives(c: fmi2Component, _vr: *const fmi2ValueReference, _n: usize, _o: *const fmi2Integer, _v: *mut fmi2Real) -> fmi2Status = x::unsupported(c, "fmi2GetRealOutputDerivatives", x::WHY_OUTPUT_DERIVATIVES));
            $crate::fmi2_shim!(fmi2DoStep(c: fmi2Component, t: fmi2Real, h: fmi2Real, nsp: fmi2Boolean) -> fmi2Status = x::do_step(c, t, h, nsp));
            $crate::fmi2_shim!(fmi2CancelStep(c: fmi2Component) -> fmi2Status = x::cancel_step(c));
            $crate::fmi2_shim!(fmi2GetStatus(c: fmi2Component, k: fmi2StatusKind, v: *mut fmi2Status) -> fmi2Status = x::get_status(c, k, v));
            $crate::fmi2_shim!(fmi2GetRealStatus(c: fmi2Component, k: fmi2StatusKind, v: *mut fmi2Real) -> fmi2Status = x::get_real_status(c, k, v));
            $crate::fmi2_shim!(fmi2GetIntegerStatus(c: fmi2Component, k: fmi2StatusKind, v: *mut fmi2Integer) -> fmi2Status = x::get_integer_status(c, k, v));
            $crate::fmi2_shim!(fmi2GetBooleanStatus(c: fmi2Component, k: fmi2StatusKind, v: *mut fmi2Boolean) -> fmi2Status = x::get_boolean_status(c, k, v));
            $crate::fmi2_shim!(fmi2GetStringStatus(c: fmi2Component, k: fmi2StatusKind, v: *mut fmi2String) -> fmi2Status = x::get_string_status(c, k, v));
        }
    };
}

/// One exported function of [`export_fmi2!`]: an `unsafe extern "C"` shim under its C name that
/// forwards to the function of the same contract in [`crate::exports`].
#[doc(hidden)]
#[macro_export]
macro_rules! fmi2_shim {
    ($name:ident($($arg:ident: $ty:ty),*) -> $ret:ty = $call:expr) => {
        /// # Safety
        ///
        /// The FMI 2.0 contract of this function, which the C master keeps (see
        /// `fmu_runtime::exports`).
        #[no_mangle]
        pub unsafe extern "C" fn $name($($arg: $ty),*) -> $ret {
            // SAFETY: this shim's contract is the forwarded function's, and the caller keeps it.
            unsafe { $call }
        }
    };
}

#[cfg(test)]
#[path = "exports_tests.rs"]
mod tests;
