//! The oracle: the FMI 2.0 co-simulation state machine (FMI 2.0.2, section 4.2.4 and Fig. 10,
//! written down here from the standard rather than taken from the exporter, so that the two
//! check each other), the phase a master expects after each call, and which calls must fail
//! whatever their arguments.

use crate::sequence::Call;

/// The phases of a co-simulation instance.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    Instantiated,
    InitializationMode,
    StepComplete,
    Terminated,
    /// After a call returned fmi2Error: the standard then allows the getters, the status
    /// functions, the FMU-state functions, fmi2Reset and fmi2FreeInstance (section 2.1.3).
    Error,
}

/// Whether the standard allows `call` in `phase` (for the functions with arguments, whether
/// the function may be called at all; the arguments are judged separately).
pub fn legal(call: &Call, phase: Phase) -> bool {
    use Phase::*;
    match call {
        Call::Setup { .. } | Call::EnterInit => phase == Instantiated,
        Call::ExitInit => phase == InitializationMode,
        Call::Terminate => phase == StepComplete,
        Call::Reset => true,
        Call::SetReal(_) | Call::SetInteger(_) | Call::SetBoolean(_) | Call::SetString(_) => {
            matches!(phase, Instantiated | InitializationMode | StepComplete)
        }
        Call::GetReal(_) | Call::GetInteger(_) | Call::GetBoolean(_) | Call::GetString(_) => {
            matches!(phase, InitializationMode | StepComplete | Terminated | Error)
        }
        Call::DoStep { .. } => phase == StepComplete,
        Call::SaveState
        | Call::RestoreState(_)
        | Call::FreeState(_)
        | Call::SerializeRoundTrip(_)
        | Call::CorruptState { .. }
        | Call::Garbage(_) => true,
        Call::DebugLogging(_) => true,
        Call::Status => matches!(phase, StepComplete | Terminated | Error),
        Call::EventMode => false,
    }
}

/// The phase after a call that succeeded.
pub fn after_success(call: &Call, phase: Phase) -> Phase {
    match call {
        Call::EnterInit => Phase::InitializationMode,
        Call::ExitInit | Call::DoStep { .. } => Phase::StepComplete,
        Call::Terminate => Phase::Terminated,
        Call::Reset => Phase::Instantiated,
        _ => phase,
    }
}

/// The phase after a call that returned fmi2Error: the instance is in error, except after a
/// function the FMU does not provide, which changes nothing (it was never attempted).
pub fn after_error(call: &Call, phase: Phase) -> Phase {
    match call {
        Call::EventMode => phase,
        _ => Phase::Error,
    }
}
