//! The master's side of the C API: open a `.fmu`, read its model description, load its shared
//! library and drive instances through the `fmi2*` functions, exactly as any FMI master does.
//!
//! The coupled-antenna master, the validation tool and the integration tests use this to test
//! the FMUs as they ship, not the Rust functions behind them. It is general: it loads any FMI 2.0
//! co-simulation FMU for linux64, not only this project's.

use std::collections::{HashMap, HashSet};
use std::ffi::{c_char, c_int, c_void, CStr, CString};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, Weak};

use quick_xml::events::Event;
use quick_xml::Reader;

use fmi2_ffi::*;

/// Why opening, loading or calling an FMU failed.
#[derive(Debug, Clone, thiserror::Error)]
pub enum ImportError {
    /// A file of the FMU (the archive, its model description, its library) could not be read.
    #[error("cannot read {}: {source}", path.display())]
    Read { path: PathBuf, source: Arc<std::io::Error> },
    /// The file is not a zip archive.
    #[error("{} is not a valid .fmu (zip): {source}", path.display())]
    NotAnArchive { path: PathBuf, source: Arc<zip::result::ZipError> },
    /// The archive could not be unpacked into its temporary folder.
    #[error("cannot unpack {}: {source}", path.display())]
    Unpack { path: PathBuf, source: Arc<zip::result::ZipError> },
    /// The model description does not read as an FMI 2.0 co-simulation description.
    #[error("modelDescription.xml: {0}")]
    Description(#[from] DescriptionError),
    /// A variable the caller asked for by name that the model does not declare.
    #[error("{model} has no variable named '{name}'")]
    NoVariable { model: String, name: String },
    /// A text handed to the C API (a path, an instance name, a GUID) holds a NUL byte.
    #[error("the {what} contains a NUL byte")]
    ContainsNul { what: &'static str },
    /// The dynamic loader refused the library (its own message).
    #[error("cannot load {}: {reason}", path.display())]
    Load { path: PathBuf, reason: String },
    /// The library lacks one of the 44 FMI 2.0 functions.
    #[error("{} does not export {function}", path.display())]
    MissingFunction { path: PathBuf, function: &'static str },
    /// An fmi2 call returned an error status; `messages` are what the FMU logged during the call.
    #[error("{function} returned {}{}", status.name(), logged(messages))]
    Call { function: &'static str, status: Status, messages: Vec<String> },
    #[error("fmi2Instantiate returned NULL{}", logged(messages))]
    Instantiate { messages: Vec<String> },
}

/// What an FMU logged during a failed call, as `": first | second"` (empty when nothing).
fn logged(messages: &[String]) -> String {
    if messages.is_empty() {
        String::new()
    } else {
        format!(": {}", messages.join(" | "))
    }
}

// ---------------------------------------------------------------------------------------------
// The model description, as much of it as a master needs.

#[derive(Debug, Clone, PartialEq)]
pub struct ScalarVariable {
    pub name: String,
    pub value_reference: u32,
    pub description: String,
    pub causality: String,
    pub variability: String,
    pub initial: Option<String>,
    /// Real, Integer, Boolean, String or Enumeration.
    pub type_name: String,
    pub start: Option<String>,
    pub unit: Option<String>,
    pub min: Option<String>,
    pub max: Option<String>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct ModelDescription {
    pub fmi_version: String,
    pub model_name: String,
    pub guid: String,
    pub description: String,
    pub model_identifier: String,
    pub variables: Vec<ScalarVariable>,
    pub default_step_size: Option<f64>,
    pub default_stop_time: Option<f64>,
    /// Output index (1-based in ModelVariables) -> the indices it depends on.
    pub output_dependencies: Vec<(usize, Option<Vec<usize>>)>,
    /// Initial unknown index (1-based) -> the knowns it depends on (`None`: all of them).
    pub initial_unknown_dependencies: Vec<(usize, Option<Vec<usize>>)>,
    pub capabilities: HashMap<String, String>,
}

/// Why a model description does not read as an FMI 2.0 co-simulation description.
#[derive(Debug, Clone, thiserror::Error)]
pub enum DescriptionError {
    #[error("XML error at byte {position}: {source}")]
    Xml { position: u64, source: quick_xml::Error },
    /// A variable or element whose attributes do not read.
    #[error(transparent)]
    Attributes(#[from] AttributeError),
    #[error("no guid")]
    NoGuid,
    #[error("CoSimulation has no modelIdentifier")]
    NoModelIdentifier,
    #[error("Unknown without index")]
    UnknownWithoutIndex,
    #[error("not a co-simulation FMU (no CoSimulation element)")]
    NotCoSimulation,
}

/// Why the attributes of a model description's element do not read.
#[derive(Debug, Clone, thiserror::Error)]
pub enum AttributeError {
    #[error("bad attribute: {0}")]
    Syntax(quick_xml::events::attributes::AttrError),
    #[error("bad attribute value: {0}")]
    Value(quick_xml::Error),
    #[error("ScalarVariable without name")]
    NoName,
    #[error("variable {name} has no valid valueReference")]
    NoValueReference { name: String },
}

/// The attributes of an XML element, normalised as XML 1.0 says (entities and whitespace).
fn element_attributes(e: &quick_xml::events::BytesStart) -> Result<HashMap<String, String>, AttributeError> {
    let mut attrs = HashMap::new();
    for a in e.attributes() {
        let a = a.map_err(AttributeError::Syntax)?;
        let key = a.key.into_inner().to_string();
        let value = a.normalized_value(quick_xml::XmlVersion::Explicit1_0).map_err(AttributeError::Value)?.to_string();
        attrs.insert(key, value);
    }
    Ok(attrs)
}

impl ScalarVariable {
    /// A variable from the attributes of its `ScalarVariable` element; the type element inside it
    /// fills in the type, start value, unit and range.
    fn from_attributes(attrs: &HashMap<String, String>) -> Result<ScalarVariable, AttributeError> {
        let get = |k: &str| attrs.get(k).cloned();
        let name = get("name").ok_or(AttributeError::NoName)?;
        let Some(value_reference) = get("valueReference").and_then(|s| s.parse().ok()) else {
            return Err(AttributeError::NoValueReference { name });
        };
        Ok(ScalarVariable {
            name,
            value_reference,
            description: get("description").unwrap_or_default(),
            causality: get("causality").unwrap_or_else(|| "local".into()),
            variability: get("variability").unwrap_or_else(|| "continuous".into()),
            initial: get("initial"),
            type_name: String::new(),
            start: None,
            unit: None,
            min: None,
            max: None,
        })
    }
}

impl ModelDescription {
    /// Whether the FMU's library may hold several instances in one process
    /// (`canBeInstantiatedOnlyOncePerProcess` is false, its default).
    pub fn allows_several_instances(&self) -> bool {
        self.capabilities.get("canBeInstantiatedOnlyOncePerProcess").is_none_or(|v| v != "true" && v != "1")
    }

    /// Reads a `modelDescription.xml`: the header, the co-simulation capabilities, the default
    /// experiment, the variables and the model structure's dependencies.
    pub fn parse(xml: &str) -> Result<ModelDescription, DescriptionError> {
        let mut reader = Reader::from_str(xml);
        reader.config_mut().trim_text(true);
        let mut md = ModelDescription {
            fmi_version: String::new(),
            model_name: String::new(),
            guid: String::new(),
            description: String::new(),
            model_identifier: String::new(),
            variables: Vec::new(),
            default_step_size: None,
            default_stop_time: None,
            output_dependencies: Vec::new(),
            initial_unknown_dependencies: Vec::new(),
            capabilities: HashMap::new(),
        };
        let mut current: Option<ScalarVariable> = None;
        let mut in_outputs = false;
        let mut in_initial_unknowns = false;
        loop {
            let event = reader
                .read_event()
                .map_err(|source| DescriptionError::Xml { position: reader.buffer_position(), source })?;
            let (element, is_empty) = match &event {
                Event::Start(e) => (Some(e.clone()), false),
                Event::Empty(e) => (Some(e.clone()), true),
                Event::End(e) => {
                    match e.name().into_inner() {
                        "ScalarVariable" => {
                            if let Some(v) = current.take() {
                                md.variables.push(v);
                            }
                        }
                        "Outputs" => in_outputs = false,
                        "InitialUnknowns" => in_initial_unknowns = false,
                        _ => {}
                    }
                    (None, false)
                }
                Event::Eof => break,
                _ => (None, false),
            };
            let Some(e) = element else { continue };
            let attrs = element_attributes(&e)?;
            let get = |k: &str| attrs.get(k).cloned();
            match e.name().into_inner() {
                "fmiModelDescription" => {
                    md.fmi_version = get("fmiVersion").unwrap_or_default();
                    md.model_name = get("modelName").unwrap_or_default();
                    md.guid = get("guid").ok_or(DescriptionError::NoGuid)?;
                    md.description = get("description").unwrap_or_default();
                }
                "CoSimulation" => {
                    md.model_identifier = get("modelIdentifier").ok_or(DescriptionError::NoModelIdentifier)?;
                    md.capabilities = attrs.clone();
                }
                "DefaultExperiment" => {
                    md.default_step_size = get("stepSize").and_then(|s| s.parse().ok());
                    md.default_stop_time = get("stopTime").and_then(|s| s.parse().ok());
                }
                "ScalarVariable" => {
                    let v = ScalarVariable::from_attributes(&attrs)?;
                    if is_empty {
                        md.variables.push(v);
                    } else {
                        current = Some(v);
                    }
                }
                name @ ("Real" | "Integer" | "Boolean" | "String" | "Enumeration") => {
                    if let Some(v) = current.as_mut() {
                        v.type_name = name.to_string();
                        v.start = get("start");
                        v.unit = get("unit");
                        v.min = get("min");
                        v.max = get("max");
                    }
                }
                "Outputs" => in_outputs = !is_empty,
                "InitialUnknowns" => in_initial_unknowns = !is_empty,
                "Unknown" if in_outputs || in_initial_unknowns => {
                    let index =
                        get("index").and_then(|s| s.parse().ok()).ok_or(DescriptionError::UnknownWithoutIndex)?;
                    let deps =
                        get("dependencies").map(|d| d.split_whitespace().filter_map(|x| x.parse().ok()).collect());
                    if in_outputs {
                        md.output_dependencies.push((index, deps));
                    } else {
                        md.initial_unknown_dependencies.push((index, deps));
                    }
                }
                _ => {}
            }
        }
        if md.model_identifier.is_empty() {
            return Err(DescriptionError::NotCoSimulation);
        }
        Ok(md)
    }

    pub fn variable(&self, name: &str) -> Result<&ScalarVariable, ImportError> {
        self.variables
            .iter()
            .find(|v| v.name == name)
            .ok_or_else(|| ImportError::NoVariable { model: self.model_name.clone(), name: name.to_string() })
    }

    /// The value reference of a variable, by name.
    pub fn vr(&self, name: &str) -> Result<u32, ImportError> {
        self.variable(name).map(|v| v.value_reference)
    }

    /// Value references of several variables, in order.
    pub fn vrs(&self, names: &[&str]) -> Result<Vec<u32>, ImportError> {
        names.iter().map(|n| self.vr(n)).collect()
    }
}

// ---------------------------------------------------------------------------------------------
// The shared library and its 44 functions.

type FnGetTypesPlatform = unsafe extern "C" fn() -> *const c_char;
type FnSetDebugLogging = unsafe extern "C" fn(fmi2Component, fmi2Boolean, usize, *const fmi2String) -> fmi2Status;
type FnInstantiate = unsafe extern "C" fn(
    fmi2String,
    fmi2Type,
    fmi2String,
    fmi2String,
    *const fmi2CallbackFunctions,
    fmi2Boolean,
    fmi2Boolean,
) -> fmi2Component;
type FnFreeInstance = unsafe extern "C" fn(fmi2Component);
type FnSetupExperiment =
    unsafe extern "C" fn(fmi2Component, fmi2Boolean, fmi2Real, fmi2Real, fmi2Boolean, fmi2Real) -> fmi2Status;
type FnComponent = unsafe extern "C" fn(fmi2Component) -> fmi2Status;
type FnGet<T> = unsafe extern "C" fn(fmi2Component, *const fmi2ValueReference, usize, *mut T) -> fmi2Status;
type FnSet<T> = unsafe extern "C" fn(fmi2Component, *const fmi2ValueReference, usize, *const T) -> fmi2Status;
type FnGetState = unsafe extern "C" fn(fmi2Component, *mut fmi2FMUstate) -> fmi2Status;
type FnSetState = unsafe extern "C" fn(fmi2Component, fmi2FMUstate) -> fmi2Status;
type FnStateSize = unsafe extern "C" fn(fmi2Component, fmi2FMUstate, *mut usize) -> fmi2Status;
type FnSerialize = unsafe extern "C" fn(fmi2Component, fmi2FMUstate, *mut fmi2Byte, usize) -> fmi2Status;
type FnDeserialize = unsafe extern "C" fn(fmi2Component, *const fmi2Byte, usize, *mut fmi2FMUstate) -> fmi2Status;
type FnDoStep = unsafe extern "C" fn(fmi2Component, fmi2Real, fmi2Real, fmi2Boolean) -> fmi2Status;
type FnStatus<T> = unsafe extern "C" fn(fmi2Component, fmi2StatusKind, *mut T) -> fmi2Status;

/// Every function name of the FMI 2.0 API, for checking that a binary exports all of them.
pub const ALL_FUNCTIONS: [&str; 44] = [
    "fmi2GetTypesPlatform",
    "fmi2GetVersion",
    "fmi2SetDebugLogging",
    "fmi2Instantiate",
    "fmi2FreeInstance",
    "fmi2SetupExperiment",
    "fmi2EnterInitializationMode",
    "fmi2ExitInitializationMode",
    "fmi2Terminate",
    "fmi2Reset",
    "fmi2GetReal",
    "fmi2GetInteger",
    "fmi2GetBoolean",
    "fmi2GetString",
    "fmi2SetReal",
    "fmi2SetInteger",
    "fmi2SetBoolean",
    "fmi2SetString",
    "fmi2GetFMUstate",
    "fmi2SetFMUstate",
    "fmi2FreeFMUstate",
    "fmi2SerializedFMUstateSize",
    "fmi2SerializeFMUstate",
    "fmi2DeSerializeFMUstate",
    "fmi2GetDirectionalDerivative",
    "fmi2EnterEventMode",
    "fmi2NewDiscreteStates",
    "fmi2EnterContinuousTimeMode",
    "fmi2CompletedIntegratorStep",
    "fmi2SetTime",
    "fmi2SetContinuousStates",
    "fmi2GetDerivatives",
    "fmi2GetEventIndicators",
    "fmi2GetContinuousStates",
    "fmi2GetNominalsOfContinuousStates",
    "fmi2SetRealInputDerivatives",
    "fmi2GetRealOutputDerivatives",
    "fmi2DoStep",
    "fmi2CancelStep",
    "fmi2GetStatus",
    "fmi2GetRealStatus",
    "fmi2GetIntegerStatus",
    "fmi2GetBooleanStatus",
    "fmi2GetStringStatus",
];

/// The co-simulation functions of a loaded library. Fields are public so that tests in this
/// crate can make deliberately wrong calls (NULL pointers, bad sequences); calling them needs
/// `unsafe`, which only this crate may use.
#[allow(missing_docs)]
pub struct Functions {
    pub get_types_platform: FnGetTypesPlatform,
    pub get_version: FnGetTypesPlatform,
    pub set_debug_logging: FnSetDebugLogging,
    pub instantiate: FnInstantiate,
    pub free_instance: FnFreeInstance,
    pub setup_experiment: FnSetupExperiment,
    pub enter_initialization_mode: FnComponent,
    pub exit_initialization_mode: FnComponent,
    pub terminate: FnComponent,
    pub reset: FnComponent,
    pub get_real: FnGet<fmi2Real>,
    pub get_integer: FnGet<fmi2Integer>,
    pub get_boolean: FnGet<fmi2Boolean>,
    pub get_string: FnGet<fmi2String>,
    pub set_real: FnSet<fmi2Real>,
    pub set_integer: FnSet<fmi2Integer>,
    pub set_boolean: FnSet<fmi2Boolean>,
    pub set_string: FnSet<fmi2String>,
    pub get_fmu_state: FnGetState,
    pub set_fmu_state: FnSetState,
    pub free_fmu_state: FnGetState,
    pub serialized_fmu_state_size: FnStateSize,
    pub serialize_fmu_state: FnSerialize,
    pub deserialize_fmu_state: FnDeserialize,
    pub do_step: FnDoStep,
    pub cancel_step: FnComponent,
    pub get_status: FnStatus<fmi2Status>,
    pub get_real_status: FnStatus<fmi2Real>,
    pub get_integer_status: FnStatus<fmi2Integer>,
    pub get_boolean_status: FnStatus<fmi2Boolean>,
    pub get_string_status: FnStatus<fmi2String>,
    pub enter_event_mode: FnComponent,
}

/// A `dlopen`ed shared library; closed when the last user drops it.
pub struct Library {
    handle: *mut c_void,
    /// The file it was loaded from (for a library that several FMUs share, the first one's).
    pub path: PathBuf,
    pub functions: Functions,
}

// SAFETY: the handle is only used to look up symbols at load time and to dlclose on drop;
// FMI functions are safe to call from any thread for distinct instances.
unsafe impl Send for Library {}
// SAFETY: as above; the library itself is immutable once loaded.
unsafe impl Sync for Library {}

impl Library {
    /// Loads a shared library and resolves all 44 FMI 2.0 functions; a missing one is an error
    /// (fmpy and other masters refuse such a binary too).
    pub fn load(path: &Path) -> Result<Library, ImportError> {
        let c_path = CString::new(path.as_os_str().as_encoded_bytes())
            .map_err(|_| ImportError::ContainsNul { what: "library path" })?;
        // SAFETY: dlopen with a valid NUL-terminated path; RTLD_LOCAL keeps the FMU's symbols
        // out of the global namespace so several FMUs with the same function names coexist.
        let handle = unsafe { libc::dlopen(c_path.as_ptr(), libc::RTLD_NOW | libc::RTLD_LOCAL) };
        if handle.is_null() {
            // SAFETY: dlerror returns a thread-local message or NULL.
            let reason = unsafe {
                let e = libc::dlerror();
                if e.is_null() {
                    "unknown error".to_string()
                } else {
                    CStr::from_ptr(e).to_string_lossy().to_string()
                }
            };
            return Err(ImportError::Load { path: path.to_path_buf(), reason });
        }
        let lookup = |name: &'static str| -> Result<*mut c_void, ImportError> {
            let c_name = CString::new(name).expect("function names have no NUL");
            // SAFETY: valid handle and symbol name.
            let symbol = unsafe { libc::dlsym(handle, c_name.as_ptr()) };
            if symbol.is_null() {
                Err(ImportError::MissingFunction { path: path.to_path_buf(), function: name })
            } else {
                Ok(symbol)
            }
        };
        for name in ALL_FUNCTIONS {
            if let Err(e) = lookup(name) {
                // SAFETY: the handle came from dlopen above and is not used afterwards.
                unsafe { libc::dlclose(handle) };
                return Err(e);
            }
        }
        macro_rules! resolve {
            ($name:literal) => {
                // SAFETY: the symbol exists (checked above) and has this signature by the FMI 2.0
                // standard; function pointers and data pointers have the same size on every
                // platform FMI supports.
                unsafe { function_from_symbol(lookup($name)?) }
            };
        }
        let functions = Functions {
            get_types_platform: resolve!("fmi2GetTypesPlatform"),
            get_version: resolve!("fmi2GetVersion"),
            set_debug_logging: resolve!("fmi2SetDebugLogging"),
            instantiate: resolve!("fmi2Instantiate"),
            free_instance: resolve!("fmi2FreeInstance"),
            setup_experiment: resolve!("fmi2SetupExperiment"),
            enter_initialization_mode: resolve!("fmi2EnterInitializationMode"),
            exit_initialization_mode: resolve!("fmi2ExitInitializationMode"),
            terminate: resolve!("fmi2Terminate"),
            reset: resolve!("fmi2Reset"),
            get_real: resolve!("fmi2GetReal"),
            get_integer: resolve!("fmi2GetInteger"),
            get_boolean: resolve!("fmi2GetBoolean"),
            get_string: resolve!("fmi2GetString"),
            set_real: resolve!("fmi2SetReal"),
            set_integer: resolve!("fmi2SetInteger"),
            set_boolean: resolve!("fmi2SetBoolean"),
            set_string: resolve!("fmi2SetString"),
            get_fmu_state: resolve!("fmi2GetFMUstate"),
            set_fmu_state: resolve!("fmi2SetFMUstate"),
            free_fmu_state: resolve!("fmi2FreeFMUstate"),
            serialized_fmu_state_size: resolve!("fmi2SerializedFMUstateSize"),
            serialize_fmu_state: resolve!("fmi2SerializeFMUstate"),
            deserialize_fmu_state: resolve!("fmi2DeSerializeFMUstate"),
            do_step: resolve!("fmi2DoStep"),
            cancel_step: resolve!("fmi2CancelStep"),
            get_status: resolve!("fmi2GetStatus"),
            get_real_status: resolve!("fmi2GetRealStatus"),
            get_integer_status: resolve!("fmi2GetIntegerStatus"),
            get_boolean_status: resolve!("fmi2GetBooleanStatus"),
            get_string_status: resolve!("fmi2GetStringStatus"),
            enter_event_mode: resolve!("fmi2EnterEventMode"),
        };
        Ok(Library { handle, path: path.to_path_buf(), functions })
    }

    pub fn types_platform(&self) -> String {
        // SAFETY: returns a static string by the standard.
        unsafe { CStr::from_ptr((self.functions.get_types_platform)()).to_string_lossy().to_string() }
    }

    pub fn version(&self) -> String {
        // SAFETY: as above.
        unsafe { CStr::from_ptr((self.functions.get_version)()).to_string_lossy().to_string() }
    }
}

/// A symbol of a shared library as the function pointer type `F`.
///
/// # Safety
///
/// `symbol` is a function whose signature is `F`, a function pointer type.
unsafe fn function_from_symbol<F: Copy>(symbol: *mut c_void) -> F {
    assert_eq!(std::mem::size_of::<F>(), std::mem::size_of::<*mut c_void>(), "F is not a pointer");
    // SAFETY: the sizes agree (checked) and by this function's contract the symbol is an F.
    unsafe { std::mem::transmute_copy::<*mut c_void, F>(&symbol) }
}

impl Drop for Library {
    fn drop(&mut self) {
        // SAFETY: the handle came from dlopen; every instance holds an Arc to the library, so
        // none is alive any more.
        unsafe { libc::dlclose(self.handle) };
    }
}

// ---------------------------------------------------------------------------------------------
// Logging: the C shim formats the message and calls `log_sink` with the finished text.

/// One message an FMU sent to the logger.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LogRecord {
    pub instance: String,
    pub status: Status,
    pub category: String,
    pub message: String,
}

/// Where an instance's messages go: kept for inspection, and optionally echoed to stderr (the
/// master may print; an FMU may not).
#[derive(Debug, Default)]
pub struct LogBook {
    records: Mutex<Vec<LogRecord>>,
    /// How many records were ever pushed: read on every call (to know which messages a failing
    /// call logged) without taking the lock.
    count: AtomicUsize,
    echo: bool,
}

impl LogBook {
    pub fn new(echo: bool) -> Self {
        LogBook { records: Mutex::new(Vec::new()), count: AtomicUsize::new(0), echo }
    }

    pub fn records(&self) -> Vec<LogRecord> {
        self.records.lock().map(|r| r.clone()).unwrap_or_default()
    }

    /// Removes and returns the records kept so far (the count of all records ever pushed,
    /// which [`LogBook::messages_since`] refers to, goes on).
    pub fn take(&self) -> Vec<LogRecord> {
        self.records.lock().map(|mut r| std::mem::take(&mut *r)).unwrap_or_default()
    }

    /// How many records were ever pushed (read before every call, hence inline).
    #[inline]
    pub fn len(&self) -> usize {
        self.count.load(Ordering::Acquire)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The messages pushed after the first `start` records (as counted by [`LogBook::len`]).
    pub fn messages_since(&self, start: usize) -> Vec<String> {
        let total = self.len();
        self.records
            .lock()
            .map(|r| {
                let kept_from = total - r.len();
                r.iter()
                    .skip(start.saturating_sub(kept_from))
                    .map(|m| format!("[{}] {}", m.category, m.message))
                    .collect()
            })
            .unwrap_or_default()
    }
}

#[repr(C)]
struct LogEnvironment {
    sink: unsafe extern "C" fn(*mut c_void, *const c_char, c_int, *const c_char, *const c_char),
    user: *const LogBook,
}

extern "C" {
    fn fmu_runtime_logger(
        environment: *mut c_void,
        instance: fmi2String,
        status: c_int,
        category: fmi2String,
        format: fmi2String,
        ...
    );
}

unsafe extern "C" fn log_sink(
    user: *mut c_void,
    instance: *const c_char,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    let text = |p: *const c_char| {
        if p.is_null() {
            String::new()
        } else {
            // SAFETY: the shim passes NUL-terminated strings valid during the call.
            unsafe { CStr::from_ptr(p) }.to_string_lossy().to_string()
        }
    };
    // SAFETY: `user` is the LogBook the instance keeps alive in an Arc for its whole life.
    let book = unsafe { &*(user as *const LogBook) };
    let record = LogRecord {
        instance: text(instance),
        status: Status::from_raw(status),
        category: text(category),
        message: text(message),
    };
    if book.echo {
        eprintln!("[{}] {} {}: {}", record.instance, record.status.name(), record.category, record.message);
    }
    if let Ok(mut records) = book.records.lock() {
        records.push(record);
        book.count.fetch_add(1, Ordering::Release);
    }
}

// ---------------------------------------------------------------------------------------------
// An unpacked FMU.

static UNPACK_COUNTER: AtomicU64 = AtomicU64::new(0);

/// A library this process loaded, found again by its contents.
struct LoadedLibrary {
    /// The file's bytes, kept while the library is loaded: the file itself may be gone (an FMU's
    /// folder is removed when it is dropped, while its instances keep the library), and another
    /// FMU that ships the same bytes must still find it.
    bytes: Vec<u8>,
    library: Weak<Library>,
}

/// The libraries loaded so far that may serve further FMUs (see [`load_shared`]).
static LOADED_LIBRARIES: Mutex<Vec<LoadedLibrary>> = Mutex::new(Vec::new());

/// Loads the shared library at `path`, or hands out the one already loaded from a file with the
/// same bytes. Two FMUs of one product often ship the same library under two model
/// identifiers (this project's azimuth and elevation plants are one library that serves both
/// models by their GUID, and so are the two controllers); `dlopen` maps each file on its own,
/// so a coupled run would execute two copies of the same code and fill the instruction cache
/// twice over. Sharing made a one-thread coupled step about 6 % shorter (README "Speed").
///
/// Only libraries whose FMUs allow several instances per process share (`shareable`, from
/// `canBeInstantiatedOnlyOncePerProcess`): such a library must already keep its instances
/// apart, and an FMU instance learns its model and its resources from the GUID and the
/// resource location of `fmi2Instantiate`, never from the file it was loaded from.
fn load_shared(path: &Path, shareable: bool) -> Result<Arc<Library>, ImportError> {
    if !shareable {
        return Library::load(path).map(Arc::new);
    }
    let bytes = std::fs::read(path).map_err(|e| ImportError::Read { path: path.to_path_buf(), source: Arc::new(e) })?;
    let mut loaded = LOADED_LIBRARIES.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    loaded.retain(|entry| entry.library.strong_count() > 0);
    if let Some(library) = loaded.iter().filter(|entry| entry.bytes == bytes).find_map(|entry| entry.library.upgrade())
    {
        return Ok(library);
    }
    let library = Arc::new(Library::load(path)?);
    loaded.push(LoadedLibrary { bytes, library: Arc::downgrade(&library) });
    Ok(library)
}

/// A `.fmu` unpacked into a private temporary folder (removed on drop), with its model
/// description parsed and its binary loaded.
pub struct Fmu {
    pub description: ModelDescription,
    pub library: Arc<Library>,
    pub directory: PathBuf,
    /// Whether the folder was unpacked by [`Fmu::open`] and is removed on drop.
    owns_directory: bool,
}

impl Fmu {
    /// Unpacks and loads a `.fmu` file.
    pub fn open(path: impl AsRef<Path>) -> Result<Fmu, ImportError> {
        let path = path.as_ref();
        let file = std::fs::File::open(path)
            .map_err(|e| ImportError::Read { path: path.to_path_buf(), source: Arc::new(e) })?;
        let mut archive = zip::ZipArchive::new(file)
            .map_err(|e| ImportError::NotAnArchive { path: path.to_path_buf(), source: Arc::new(e) })?;
        let directory = std::env::temp_dir().join(format!(
            "meerkat-fmu-{}-{}-{}",
            std::process::id(),
            UNPACK_COUNTER.fetch_add(1, Ordering::Relaxed),
            path.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_default()
        ));
        archive
            .extract(&directory)
            .map_err(|e| ImportError::Unpack { path: path.to_path_buf(), source: Arc::new(e) })?;
        Self::from_directory(directory, true)
    }

    /// Loads an FMU that is already unpacked (the folder is left alone on drop).
    pub fn open_unpacked(directory: impl AsRef<Path>) -> Result<Fmu, ImportError> {
        Self::from_directory(directory.as_ref().to_path_buf(), false)
    }

    fn from_directory(directory: PathBuf, owned: bool) -> Result<Fmu, ImportError> {
        let cleanup = |e: ImportError| {
            if owned {
                let _ = std::fs::remove_dir_all(&directory);
            }
            e
        };
        let description_path = directory.join("modelDescription.xml");
        let xml = std::fs::read_to_string(&description_path)
            .map_err(|e| cleanup(ImportError::Read { path: description_path, source: Arc::new(e) }))?;
        let description = ModelDescription::parse(&xml).map_err(|e| cleanup(e.into()))?;
        let binary = directory.join("binaries").join("linux64").join(format!("{}.so", description.model_identifier));
        let library = load_shared(&binary, description.allows_several_instances()).map_err(cleanup)?;
        Ok(Fmu { description, library, directory, owns_directory: owned })
    }

    /// The `file:` URI of the resources folder, percent-encoded, as masters pass it.
    pub fn resource_uri(&self) -> String {
        file_uri(&self.directory.join("resources"))
    }

    /// A new instance, with the GUID of the model description.
    pub fn instantiate(&self, name: &str, logging_on: bool) -> Result<Instance, ImportError> {
        self.instantiate_with(name, &self.description.guid.clone(), logging_on, false)
    }

    /// A new instance with full control over the GUID and echoing of log messages to stderr.
    pub fn instantiate_with(
        &self,
        name: &str,
        guid: &str,
        logging_on: bool,
        echo_log: bool,
    ) -> Result<Instance, ImportError> {
        let callbacks = LoggerCallbacks::new(echo_log);
        let nul = |what| move |_| ImportError::ContainsNul { what };
        let c_name = CString::new(name).map_err(nul("instance name"))?;
        let c_guid = CString::new(guid).map_err(nul("GUID"))?;
        let c_uri = CString::new(self.resource_uri()).map_err(nul("resource URI"))?;
        // SAFETY: every pointer is valid for the call; the callbacks and the log environment are
        // boxed and owned by the returned Instance, so they outlive the FMU instance.
        let component = unsafe {
            (self.library.functions.instantiate)(
                c_name.as_ptr(),
                fmi2CoSimulation,
                c_guid.as_ptr(),
                c_uri.as_ptr(),
                callbacks.functions(),
                fmi2False,
                if logging_on { fmi2True } else { fmi2False },
            )
        };
        if component.is_null() {
            return Err(ImportError::Instantiate { messages: callbacks.book.messages_since(0) });
        }
        Ok(Instance {
            library: Arc::clone(&self.library),
            component,
            log: Arc::clone(&callbacks.book),
            _callbacks: callbacks,
            states: HashSet::new(),
            name: name.to_string(),
        })
    }
}

/// The callback functions a master hands to fmi2Instantiate: the variadic C logger shim
/// writing into a [`LogBook`], and calloc/free. Must outlive the instance.
pub struct LoggerCallbacks {
    pub book: Arc<LogBook>,
    _environment: Box<LogEnvironment>,
    functions: Box<fmi2CallbackFunctions>,
}

impl LoggerCallbacks {
    pub fn new(echo: bool) -> Self {
        let book = Arc::new(LogBook::new(echo));
        let environment = Box::new(LogEnvironment { sink: log_sink, user: Arc::as_ptr(&book) });
        let logger: unsafe extern "C" fn(
            fmi2ComponentEnvironment,
            fmi2String,
            fmi2Status,
            fmi2String,
            fmi2String,
            ...
        ) = fmu_runtime_logger;
        let functions = Box::new(fmi2CallbackFunctions {
            logger: Some(logger),
            allocateMemory: Some(libc_calloc),
            freeMemory: Some(libc_free),
            stepFinished: None,
            componentEnvironment: &*environment as *const LogEnvironment as *mut c_void,
        });
        LoggerCallbacks { book, _environment: environment, functions }
    }

    /// The pointer to pass to fmi2Instantiate.
    pub fn functions(&self) -> *const fmi2CallbackFunctions {
        &*self.functions
    }
}

impl Drop for Fmu {
    fn drop(&mut self) {
        if self.owns_directory {
            let _ = std::fs::remove_dir_all(&self.directory);
        }
    }
}

unsafe extern "C" fn libc_calloc(n: usize, size: usize) -> *mut c_void {
    // SAFETY: plain calloc, as FMI 2.0 specifies for allocateMemory.
    unsafe { libc::calloc(n, size) }
}

unsafe extern "C" fn libc_free(p: *mut c_void) {
    // SAFETY: frees memory the FMU allocated through libc_calloc.
    unsafe { libc::free(p) }
}

/// Percent-encodes a path into a `file:///` URI (RFC 8089), as a master would.
pub fn file_uri(path: &Path) -> String {
    let mut out = String::from("file://");
    for &b in path.as_os_str().as_encoded_bytes() {
        if b.is_ascii_alphanumeric() || b"/-._~".contains(&b) {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}

// ---------------------------------------------------------------------------------------------
// An instance.

/// A saved FMU state, owned by the instance that made it (freed with it).
#[derive(Debug)]
pub struct FmuState {
    pointer: fmi2FMUstate,
}

/// One FMU instance, freed on drop.
pub struct Instance {
    library: Arc<Library>,
    component: fmi2Component,
    log: Arc<LogBook>,
    _callbacks: LoggerCallbacks,
    states: HashSet<usize>,
    pub name: String,
}

// SAFETY: an FMI instance may be used from any thread as long as calls do not overlap, which
// `&mut self` on every call guarantees.
unsafe impl Send for Instance {}

impl Instance {
    /// The call's status as a `Result`: fmi2OK, the answer of almost every call, is decided
    /// inline; anything else goes to [`Self::check_slow`].
    #[inline(always)]
    fn check(&self, function: &'static str, raw: fmi2Status, log_start: usize) -> Result<Status, ImportError> {
        if raw == fmi2OK {
            return Ok(Status::Ok);
        }
        self.check_slow(function, raw, log_start)
    }

    #[cold]
    #[inline(never)]
    fn check_slow(&self, function: &'static str, raw: fmi2Status, log_start: usize) -> Result<Status, ImportError> {
        let status = Status::from_raw(raw);
        match status {
            Status::Ok | Status::Warning => Ok(status),
            _ => Err(ImportError::Call { function, status, messages: self.log.messages_since(log_start) }),
        }
    }

    /// The raw component pointer, for tests in this crate that call functions directly.
    pub fn component(&self) -> fmi2Component {
        self.component
    }

    pub fn functions(&self) -> &Functions {
        &self.library.functions
    }

    /// Everything the FMU has logged so far.
    pub fn log_records(&self) -> Vec<LogRecord> {
        self.log.records()
    }

    pub fn take_log(&self) -> Vec<LogRecord> {
        self.log.take()
    }

    pub fn set_debug_logging(&mut self, on: bool, categories: &[&str]) -> Result<Status, ImportError> {
        let names: Vec<CString> = categories.iter().map(|c| CString::new(*c).unwrap_or_default()).collect();
        let pointers: Vec<fmi2String> = names.iter().map(|c| c.as_ptr()).collect();
        let start = self.log.len();
        // SAFETY: valid component and an array of valid strings.
        let raw = unsafe {
            (self.library.functions.set_debug_logging)(
                self.component,
                if on { fmi2True } else { fmi2False },
                pointers.len(),
                pointers.as_ptr(),
            )
        };
        self.check("fmi2SetDebugLogging", raw, start)
    }

    pub fn setup_experiment(&mut self, start_time: f64, stop_time: Option<f64>) -> Result<Status, ImportError> {
        let start = self.log.len();
        // SAFETY: valid component.
        let raw = unsafe {
            (self.library.functions.setup_experiment)(
                self.component,
                fmi2False,
                0.0,
                start_time,
                if stop_time.is_some() { fmi2True } else { fmi2False },
                stop_time.unwrap_or(0.0),
            )
        };
        self.check("fmi2SetupExperiment", raw, start)
    }

    fn simple(&mut self, function: &'static str, f: FnComponent) -> Result<Status, ImportError> {
        let start = self.log.len();
        // SAFETY: valid component.
        let raw = unsafe { f(self.component) };
        self.check(function, raw, start)
    }

    pub fn enter_initialization_mode(&mut self) -> Result<Status, ImportError> {
        self.simple("fmi2EnterInitializationMode", self.library.functions.enter_initialization_mode)
    }

    pub fn exit_initialization_mode(&mut self) -> Result<Status, ImportError> {
        self.simple("fmi2ExitInitializationMode", self.library.functions.exit_initialization_mode)
    }

    pub fn terminate(&mut self) -> Result<Status, ImportError> {
        self.simple("fmi2Terminate", self.library.functions.terminate)
    }

    pub fn reset(&mut self) -> Result<Status, ImportError> {
        self.simple("fmi2Reset", self.library.functions.reset)
    }

    /// Shorthand for setup, initialisation with the given start values and exit.
    pub fn initialize(&mut self, start_time: f64, reals: &[(u32, f64)]) -> Result<(), ImportError> {
        self.setup_experiment(start_time, None)?;
        self.enter_initialization_mode()?;
        if !reals.is_empty() {
            let (vrs, values): (Vec<u32>, Vec<f64>) = reals.iter().copied().unzip();
            self.set_real(&vrs, &values)?;
        }
        self.exit_initialization_mode()?;
        Ok(())
    }

    // Inlined into the master's loop: these are the calls of every communication step.
    #[inline(always)]
    pub fn get_real(&mut self, vrs: &[u32], values: &mut [f64]) -> Result<Status, ImportError> {
        assert_eq!(vrs.len(), values.len(), "one value per value reference");
        let start = self.log.len();
        // SAFETY: valid component; both arrays have vrs.len() elements.
        let raw =
            unsafe { (self.library.functions.get_real)(self.component, vrs.as_ptr(), vrs.len(), values.as_mut_ptr()) };
        self.check("fmi2GetReal", raw, start)
    }

    // Inlined into the master's loop: these are the calls of every communication step.
    #[inline(always)]
    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Result<Status, ImportError> {
        assert_eq!(vrs.len(), values.len(), "one value per value reference");
        let start = self.log.len();
        // SAFETY: as for get_real.
        let raw =
            unsafe { (self.library.functions.set_real)(self.component, vrs.as_ptr(), vrs.len(), values.as_ptr()) };
        self.check("fmi2SetReal", raw, start)
    }

    pub fn get_integer(&mut self, vrs: &[u32], values: &mut [i32]) -> Result<Status, ImportError> {
        assert_eq!(vrs.len(), values.len(), "one value per value reference");
        let start = self.log.len();
        // SAFETY: as for get_real.
        let raw = unsafe {
            (self.library.functions.get_integer)(self.component, vrs.as_ptr(), vrs.len(), values.as_mut_ptr())
        };
        self.check("fmi2GetInteger", raw, start)
    }

    pub fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> Result<Status, ImportError> {
        assert_eq!(vrs.len(), values.len(), "one value per value reference");
        let start = self.log.len();
        // SAFETY: as for get_real.
        let raw =
            unsafe { (self.library.functions.set_integer)(self.component, vrs.as_ptr(), vrs.len(), values.as_ptr()) };
        self.check("fmi2SetInteger", raw, start)
    }

    pub fn get_boolean(&mut self, vrs: &[u32], values: &mut [bool]) -> Result<Status, ImportError> {
        let mut raw_values = vec![0; vrs.len()];
        let start = self.log.len();
        // SAFETY: as for get_real.
        let raw = unsafe {
            (self.library.functions.get_boolean)(self.component, vrs.as_ptr(), vrs.len(), raw_values.as_mut_ptr())
        };
        for (v, r) in values.iter_mut().zip(raw_values) {
            *v = r != fmi2False;
        }
        self.check("fmi2GetBoolean", raw, start)
    }

    pub fn set_boolean(&mut self, vrs: &[u32], values: &[bool]) -> Result<Status, ImportError> {
        let raw_values: Vec<fmi2Boolean> = values.iter().map(|&b| if b { fmi2True } else { fmi2False }).collect();
        let start = self.log.len();
        // SAFETY: as for get_real.
        let raw = unsafe {
            (self.library.functions.set_boolean)(self.component, vrs.as_ptr(), vrs.len(), raw_values.as_ptr())
        };
        self.check("fmi2SetBoolean", raw, start)
    }

    /// fmi2SetBoolean with the raw fmi2Boolean values, any integer (a robustness driver passes
    /// values other than fmi2False and fmi2True on purpose).
    pub fn set_boolean_raw(&mut self, vrs: &[u32], values: &[fmi2Boolean]) -> Result<Status, ImportError> {
        assert_eq!(vrs.len(), values.len(), "one value per value reference");
        let start = self.log.len();
        // SAFETY: as for get_real.
        let raw =
            unsafe { (self.library.functions.set_boolean)(self.component, vrs.as_ptr(), vrs.len(), values.as_ptr()) };
        self.check("fmi2SetBoolean", raw, start)
    }

    /// fmi2SetupExperiment with every argument as the caller gives it, the flags raw.
    pub fn setup_experiment_raw(
        &mut self,
        tolerance_defined: fmi2Boolean,
        tolerance: f64,
        start_time: f64,
        stop_time_defined: fmi2Boolean,
        stop_time: f64,
    ) -> Result<Status, ImportError> {
        let start = self.log.len();
        // SAFETY: valid component; the other arguments are plain values.
        let raw = unsafe {
            (self.library.functions.setup_experiment)(
                self.component,
                tolerance_defined,
                tolerance,
                start_time,
                stop_time_defined,
                stop_time,
            )
        };
        self.check("fmi2SetupExperiment", raw, start)
    }

    /// fmi2DoStep with a raw noSetFMUStatePriorToCurrentPoint flag.
    pub fn do_step_raw(
        &mut self,
        current_time: f64,
        step: f64,
        no_set_prior: fmi2Boolean,
    ) -> Result<Status, ImportError> {
        let start = self.log.len();
        // SAFETY: valid component; the other arguments are plain values.
        let raw = unsafe { (self.library.functions.do_step)(self.component, current_time, step, no_set_prior) };
        self.check("fmi2DoStep", raw, start)
    }

    /// fmi2SetDebugLogging for all categories with a raw loggingOn flag.
    pub fn set_debug_logging_raw(&mut self, logging_on: fmi2Boolean) -> Result<Status, ImportError> {
        let start = self.log.len();
        // SAFETY: valid component; no categories (n = 0, the pointer is not read).
        let raw =
            unsafe { (self.library.functions.set_debug_logging)(self.component, logging_on, 0, std::ptr::null()) };
        self.check("fmi2SetDebugLogging", raw, start)
    }

    /// fmi2EnterEventMode, a model-exchange function a co-simulation FMU must refuse.
    pub fn enter_event_mode(&mut self) -> Result<Status, ImportError> {
        self.simple("fmi2EnterEventMode", self.library.functions.enter_event_mode)
    }

    /// How many messages the FMU has logged so far.
    pub fn log_len(&self) -> usize {
        self.log.len()
    }

    pub fn get_string(&mut self, vrs: &[u32]) -> Result<Vec<String>, ImportError> {
        let mut pointers: Vec<fmi2String> = vec![std::ptr::null(); vrs.len()];
        let start = self.log.len();
        // SAFETY: as for get_real.
        let raw = unsafe {
            (self.library.functions.get_string)(self.component, vrs.as_ptr(), vrs.len(), pointers.as_mut_ptr())
        };
        self.check("fmi2GetString", raw, start)?;
        Ok(pointers
            .iter()
            .map(|&p| {
                if p.is_null() {
                    String::new()
                } else {
                    // SAFETY: the FMU returns strings valid until its next call.
                    unsafe { CStr::from_ptr(p) }.to_string_lossy().to_string()
                }
            })
            .collect())
    }

    pub fn set_string(&mut self, vrs: &[u32], values: &[&str]) -> Result<Status, ImportError> {
        let owned: Vec<CString> = values.iter().map(|s| CString::new(*s).unwrap_or_default()).collect();
        let pointers: Vec<fmi2String> = owned.iter().map(|s| s.as_ptr()).collect();
        let start = self.log.len();
        // SAFETY: as for get_real; the strings outlive the call.
        let raw =
            unsafe { (self.library.functions.set_string)(self.component, vrs.as_ptr(), vrs.len(), pointers.as_ptr()) };
        self.check("fmi2SetString", raw, start)
    }

    // Inlined into the master's loop: these are the calls of every communication step.
    #[inline(always)]
    pub fn do_step(&mut self, current_time: f64, step: f64) -> Result<Status, ImportError> {
        let start = self.log.len();
        // SAFETY: valid component.
        let raw = unsafe { (self.library.functions.do_step)(self.component, current_time, step, fmi2True) };
        self.check("fmi2DoStep", raw, start)
    }

    pub fn last_successful_time(&mut self) -> Result<f64, ImportError> {
        let mut value = f64::NAN;
        let start = self.log.len();
        // SAFETY: valid component and output pointer.
        let raw =
            unsafe { (self.library.functions.get_real_status)(self.component, fmi2LastSuccessfulTime, &mut value) };
        self.check("fmi2GetRealStatus", raw, start)?;
        Ok(value)
    }

    pub fn do_step_status(&mut self) -> Result<Status, ImportError> {
        let mut value: fmi2Status = fmi2Fatal;
        let start = self.log.len();
        // SAFETY: valid component and output pointer.
        let raw = unsafe { (self.library.functions.get_status)(self.component, fmi2DoStepStatus, &mut value) };
        self.check("fmi2GetStatus", raw, start)?;
        Ok(Status::from_raw(value))
    }

    pub fn get_state(&mut self) -> Result<FmuState, ImportError> {
        let mut pointer: fmi2FMUstate = std::ptr::null_mut();
        let start = self.log.len();
        // SAFETY: valid component; a NULL state asks the FMU for a new one.
        let raw = unsafe { (self.library.functions.get_fmu_state)(self.component, &mut pointer) };
        self.check("fmi2GetFMUstate", raw, start)?;
        self.states.insert(pointer as usize);
        Ok(FmuState { pointer })
    }

    /// Overwrites an existing saved state with the current one.
    pub fn update_state(&mut self, state: &mut FmuState) -> Result<Status, ImportError> {
        let start = self.log.len();
        // SAFETY: valid component; `state` was made by this instance.
        let raw = unsafe { (self.library.functions.get_fmu_state)(self.component, &mut state.pointer) };
        self.check("fmi2GetFMUstate", raw, start)
    }

    pub fn set_state(&mut self, state: &FmuState) -> Result<Status, ImportError> {
        let start = self.log.len();
        // SAFETY: valid component and a state made by an instance of the same library.
        let raw = unsafe { (self.library.functions.set_fmu_state)(self.component, state.pointer) };
        self.check("fmi2SetFMUstate", raw, start)
    }

    pub fn free_state(&mut self, mut state: FmuState) -> Result<Status, ImportError> {
        self.states.remove(&(state.pointer as usize));
        let start = self.log.len();
        // SAFETY: valid component and a state made by this instance, freed once.
        let raw = unsafe { (self.library.functions.free_fmu_state)(self.component, &mut state.pointer) };
        self.check("fmi2FreeFMUstate", raw, start)
    }

    pub fn serialize_state(&mut self, state: &FmuState) -> Result<Vec<u8>, ImportError> {
        let mut size = 0usize;
        let start = self.log.len();
        // SAFETY: valid component, state and output pointer.
        let raw =
            unsafe { (self.library.functions.serialized_fmu_state_size)(self.component, state.pointer, &mut size) };
        self.check("fmi2SerializedFMUstateSize", raw, start)?;
        let mut bytes = vec![0u8; size];
        // SAFETY: the buffer has exactly `size` bytes.
        let raw = unsafe {
            (self.library.functions.serialize_fmu_state)(
                self.component,
                state.pointer,
                bytes.as_mut_ptr() as *mut fmi2Byte,
                size,
            )
        };
        self.check("fmi2SerializeFMUstate", raw, start)?;
        Ok(bytes)
    }

    pub fn deserialize_state(&mut self, bytes: &[u8]) -> Result<FmuState, ImportError> {
        let mut pointer: fmi2FMUstate = std::ptr::null_mut();
        let start = self.log.len();
        // SAFETY: valid component and buffer.
        let raw = unsafe {
            (self.library.functions.deserialize_fmu_state)(
                self.component,
                bytes.as_ptr() as *const fmi2Byte,
                bytes.len(),
                &mut pointer,
            )
        };
        self.check("fmi2DeSerializeFMUstate", raw, start)?;
        self.states.insert(pointer as usize);
        Ok(FmuState { pointer })
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        for pointer in std::mem::take(&mut self.states) {
            let mut p = pointer as fmi2FMUstate;
            // SAFETY: states made by this instance and not freed yet.
            unsafe { (self.library.functions.free_fmu_state)(self.component, &mut p) };
        }
        // SAFETY: the component came from fmi2Instantiate and is freed exactly once, here.
        unsafe { (self.library.functions.free_instance)(self.component) };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"<?xml version="1.0"?>
<fmiModelDescription fmiVersion="2.0" modelName="m" guid="{g}">
  <CoSimulation modelIdentifier="m"/>
  <ModelVariables><ScalarVariable name="x" valueReference="1"><Real/></ScalarVariable></ModelVariables>
</fmiModelDescription>"#;

    #[test]
    fn a_model_description_without_the_parts_a_master_needs_says_which() {
        assert!(ModelDescription::parse(MINIMAL).is_ok());
        let without = |from: &str, to: &str| ModelDescription::parse(&MINIMAL.replace(from, to)).unwrap_err();
        assert!(matches!(without(r#" guid="{g}""#, ""), DescriptionError::NoGuid));
        assert!(matches!(without(r#"<CoSimulation modelIdentifier="m"/>"#, ""), DescriptionError::NotCoSimulation));
        assert!(matches!(without(r#" modelIdentifier="m""#, ""), DescriptionError::NoModelIdentifier));
        assert!(matches!(
            without(r#" valueReference="1""#, ""),
            DescriptionError::Attributes(AttributeError::NoValueReference { .. })
        ));
        assert!(matches!(without("</ModelVariables>", "</Other>"), DescriptionError::Xml { .. }));
    }

    #[test]
    fn a_missing_variable_names_the_model_and_the_variable() {
        let description = ModelDescription::parse(MINIMAL).unwrap();
        let error = description.vr("y").unwrap_err();
        assert!(matches!(&error, ImportError::NoVariable { model, name } if model == "m" && name == "y"), "{error}");
    }

    #[test]
    fn a_file_that_is_missing_or_not_a_zip_archive_is_refused_with_its_path() {
        let folder = std::env::temp_dir().join(format!("fmu-import-typed-errors-{}", std::process::id()));
        std::fs::create_dir_all(&folder).unwrap();
        let missing = folder.join("missing.fmu");
        assert!(matches!(Fmu::open(&missing), Err(ImportError::Read { path, .. }) if path == missing));
        let text = folder.join("text.fmu");
        std::fs::write(&text, "not a zip archive").unwrap();
        assert!(matches!(Fmu::open(&text), Err(ImportError::NotAnArchive { path, .. }) if path == text));
        let unpacked = folder.join("unpacked");
        std::fs::create_dir_all(&unpacked).unwrap();
        let result = Fmu::open_unpacked(&unpacked);
        assert!(matches!(result, Err(ImportError::Read { path, .. }) if path.ends_with("modelDescription.xml")));
        std::fs::remove_dir_all(&folder).unwrap();
    }
}
