//! The coupled antenna: a fixed-step co-simulation master over the packaged FMUs, the
//! requirement scenarios, their metrics and the requirement report; and the closed
//! velocity-loop identification of the seed paper's Figs. 7 and 9 (`bode`).

pub mod command;
pub mod coupled;

pub use command::{Command, CommandPoint, CommandTable};
pub use coupled::{AntennaConfig, CoupledAntenna, FmuSet, Overrides, ParameterValue, Trace, WindCondition};
pub mod bode;
pub mod metrics;
pub mod report;
pub mod scenario;
pub mod plant_identification;
pub mod wind_spectra;
