//! The coupled antenna: a fixed-step co-simulation master over the packaged FMUs, the
//! requirement scenarios, their metrics and the requirement report; the frequency responses
//! identified on the FMUs as in the seed paper's Figs. 6-9 (`frequency_response`); and the
//! wind unit's spectra (`wind_spectra`); and the antenna as SSP 1.0 archives for other
//! co-simulation engines (`ssp`).

pub mod budget;
pub mod command;
pub mod configuration;
pub mod coupled;
pub mod frequency_response;
mod handoff;
pub mod metrics;
pub mod pointing_model;
pub mod pointing_model_fit;
pub mod report;
pub mod scenario;
pub mod ssp;
pub mod sweep;
pub mod wind_spectra;

pub use command::{Command, CommandPoint, CommandTable};
pub use configuration::{AntennaSetup, Configuration, ScenarioSettings};
pub use coupled::{
    AntennaConfig, CoupledAntenna, ErrorParts, FmuSet, Lanes, Overrides, ParameterValue, Trace, WindCondition,
};
