//! The phases of an instance's life in the FMI 2.0 co-simulation state machine, which call is
//! legal in each, and the log categories an instance declares and switches.

use serde::{Deserialize, Serialize};

/// The phases of the co-simulation state machine (FMI 2.0, Fig. 10), one bit each so that the
/// table of legal calls is a set of masks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[repr(u32)]
pub enum Phase {
    Instantiated = 1 << 0,
    InitializationMode = 1 << 1,
    StepComplete = 1 << 2,
    StepFailed = 1 << 3,
    Terminated = 1 << 4,
    Error = 1 << 5,
    Fatal = 1 << 6,
}

impl Phase {
    pub fn name(self) -> &'static str {
        match self {
            Phase::Instantiated => "Instantiated",
            Phase::InitializationMode => "InitializationMode",
            Phase::StepComplete => "StepComplete",
            Phase::StepFailed => "StepFailed",
            Phase::Terminated => "Terminated",
            Phase::Error => "Error",
            Phase::Fatal => "Fatal",
        }
    }
}

/// The phases in which each function may be called, after modelica/Reference-FMUs
/// (`fmi2Functions.c`), with one deliberate widening: the status functions are also legal in
/// `Error`, because the standard lets a master diagnose an instance after fmi2Error.
pub mod legal {
    use super::Phase::*;
    const fn mask(phases: &[super::Phase]) -> u32 {
        let mut m = 0;
        let mut i = 0;
        while i < phases.len() {
            m |= phases[i] as u32;
            i += 1;
        }
        m
    }
    pub const ANY: u32 = mask(&[Instantiated, InitializationMode, StepComplete, StepFailed, Terminated, Error, Fatal]);
    pub const SET_DEBUG_LOGGING: u32 =
        mask(&[Instantiated, InitializationMode, StepComplete, StepFailed, Terminated, Error]);
    pub const FREE_INSTANCE: u32 =
        mask(&[Instantiated, InitializationMode, StepComplete, StepFailed, Terminated, Error]);
    pub const SETUP_EXPERIMENT: u32 = mask(&[Instantiated]);
    pub const ENTER_INITIALIZATION_MODE: u32 = mask(&[Instantiated]);
    pub const EXIT_INITIALIZATION_MODE: u32 = mask(&[InitializationMode]);
    pub const TERMINATE: u32 = mask(&[StepComplete, StepFailed]);
    pub const RESET: u32 = FREE_INSTANCE;
    pub const GET: u32 = mask(&[InitializationMode, StepComplete, StepFailed, Terminated, Error]);
    pub const SET_REAL: u32 = mask(&[Instantiated, InitializationMode, StepComplete]);
    pub const SET_OTHER: u32 = mask(&[Instantiated, InitializationMode, StepComplete]);
    pub const FMU_STATE: u32 = FREE_INSTANCE;
    pub const DO_STEP: u32 = mask(&[StepComplete]);
    pub const STATUS: u32 = mask(&[StepComplete, StepFailed, Terminated, Error]);
    // The functions this FMU does not provide (model exchange, directional and input/output
    // derivatives, fmi2CancelStep) have no entry: `exports::unsupported` answers them in every
    // phase without touching the instance, so that a master probing a capability does not lose
    // the instance by asking.

    pub fn describe(mask: u32) -> String {
        let names: Vec<&str> = [Instantiated, InitializationMode, StepComplete, StepFailed, Terminated, Error, Fatal]
            .iter()
            .filter(|p| mask & (**p as u32) != 0)
            .map(|p| p.name())
            .collect();
        names.join(", ")
    }
}

/// Log categories, switched by fmi2SetDebugLogging. Errors and warnings are logged unless the
/// master switches their category off; events and call traces only when debug logging is on.
pub const LOG_CATEGORIES: &[(&str, &str)] = &[
    ("logEvents", "Model events: mode switches such as friction sticking or a pinion entering its backlash, files loaded, limits hit."),
    ("logStatusWarning", "Calls that return fmi2Warning, with the reason."),
    ("logStatusDiscard", "Calls that return fmi2Discard, with the reason."),
    ("logStatusError", "Calls that return fmi2Error, with the reason (bad arguments, illegal call sequence, a rejected value)."),
    ("logStatusFatal", "Calls that return fmi2Fatal."),
    ("logCalls", "Every call into the FMU with its arguments (verbose)."),
];

pub const CAT_EVENTS: usize = 0;
pub const CAT_WARNING: usize = 1;
pub const CAT_DISCARD: usize = 2;
pub const CAT_ERROR: usize = 3;
pub const CAT_FATAL: usize = 4;
pub const CAT_CALLS: usize = 5;
