//! Frequency responses identified on the packaged FMUs through the C ABI, as the seed paper
//! measured them on the antenna: white noise on a constant offset that keeps every body
//! sliding one way (so friction is a constant torque and backlash stays closed), an H1 estimate
//! (Welch) with its coherence, beside an analytic model.
//!
//! Two experiments share this module: [`plant`], the open-loop plant from current command to
//! motor speed (Figs. 6 and 8), and [`velocity_loop`], the closed velocity loop of the
//! controller FMU on the plant FMU (Figs. 7 and 9). What they share is here: the axis, the
//! error type, reading a parameter back from an instance, counting pinion flank changes, the
//! Welch estimate and the bin-by-bin comparison with the model.

pub mod plant;
pub mod structure_loop;
pub mod velocity_loop;

use antenna_dsp::{transfer_function_h1, Complex64, Detrend, DspError, ResponseComparison, WelchConfig};
use fmu_import::{Fmu, ImportError, Instance};

/// Which axis an experiment runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    Azimuth,
    Elevation,
}

impl Axis {
    /// Both axes, azimuth first (the order of the figures and the summaries).
    pub const BOTH: [Axis; 2] = [Axis::Azimuth, Axis::Elevation];

    pub fn name(self) -> &'static str {
        match self {
            Axis::Azimuth => "azimuth",
            Axis::Elevation => "elevation",
        }
    }

    /// The model identifier of the axis's plant FMU.
    pub fn model_identifier(self) -> &'static str {
        match self {
            Axis::Azimuth => "AzimuthPlant",
            Axis::Elevation => "ElevationPlant",
        }
    }

    /// The model identifier of the axis's controller FMU.
    pub fn controller_model_identifier(self) -> &'static str {
        match self {
            Axis::Azimuth => "AzimuthController",
            Axis::Elevation => "ElevationController",
        }
    }
}

/// Why an identification could not be run.
#[derive(Debug, thiserror::Error)]
pub enum IdentificationError {
    #[error(transparent)]
    Import(#[from] ImportError),
    #[error(transparent)]
    Coupling(#[from] crate::coupled::CouplingError),
    #[error("Welch estimate")]
    Welch(#[source] DspError),
    /// The azimuth plant's two motors differ, and the analytic reference doubles one.
    #[error("motor1.{parameter} = {motor1} and motor2.{parameter} = {motor2} differ: the doubled two-mass reference needs identical drives")]
    MotorsDiffer { parameter: &'static str, motor1: f64, motor2: f64 },
    /// The azimuth plant's two pinion paths differ, and the analytic reference doubles one.
    #[error("the two pinion paths differ: the doubled two-mass reference needs identical paths")]
    PinionPathsDiffer,
    /// The structure's shipped modes file does not parse.
    #[error("the shipped structure modes")]
    Modes(#[source] fmu_structure::modes::ModesError),
    /// The structure's shipped modes file has no mode that the axis's torque drives.
    #[error("the shipped structure has no mode about {axis}")]
    NoModeAbout { axis: &'static str },
    /// The controller FMU's parameter differs from the library default the analytic model uses.
    #[error(
        "the controller FMU's {parameter} is {reported}, the library default the analytic model uses is {library}"
    )]
    ControllerParameter { parameter: &'static str, reported: f64, library: f64 },
    /// The controller FMU's velocity integrator setting differs from the library default.
    #[error("the controller FMU's velocity integrator setting differs from the library default")]
    IntegratorSetting,
    /// The controller FMU's sampling delay differs from the library's.
    #[error("the controller FMU's delay is {fmu} samples, the library's {library}")]
    ControllerDelay { fmu: i64, library: i64 },
    /// The library controller the analytic model is built from refused its parameters.
    #[error("controller parameters: {0}")]
    Controller(fmu_controller::params::ParameterError),
}

/// A real variable of an initialised instance, by name.
fn read_real(fmu: &Fmu, instance: &mut Instance, name: &str) -> Result<f64, IdentificationError> {
    let mut value = [f64::NAN];
    instance.get_real(&[fmu.description.vr(name)?], &mut value)?;
    Ok(value[0])
}

/// Counts how often the pinions' flanks change over a record (azimuth: each pinion should stay
/// on the flank the torque bias puts it on; elevation has no pinions and nothing to count).
struct FlankWatch {
    vrs: Vec<u32>,
    flanks: Vec<i32>,
    last: Option<Vec<i32>>,
    changes: usize,
}

impl FlankWatch {
    fn new(fmu: &Fmu, axis: Axis) -> Result<Self, IdentificationError> {
        let vrs = match axis {
            Axis::Azimuth => fmu.description.vrs(&["pinion1.flank", "pinion2.flank"])?,
            Axis::Elevation => Vec::new(),
        };
        Ok(FlankWatch { flanks: vec![0; vrs.len()], vrs, last: None, changes: 0 })
    }

    /// Reads the flanks at one record sample.
    fn sample(&mut self, instance: &mut Instance) -> Result<(), IdentificationError> {
        if self.vrs.is_empty() {
            return Ok(());
        }
        instance.get_integer(&self.vrs, &mut self.flanks)?;
        match &self.last {
            Some(last) if *last == self.flanks => {}
            Some(_) => {
                self.changes += 1;
                self.last = Some(self.flanks.clone());
            }
            None => self.last = Some(self.flanks.clone()),
        }
        Ok(())
    }
}

/// The H1 estimate of a record without its DC bin.
struct Estimate {
    frequency_hz: Vec<f64>,
    measured: Vec<Complex64>,
    coherence: Vec<f64>,
    dof: f64,
    segments: usize,
}

/// H1 and coherence from `input` to `output` sampled every `step_s`, in Welch segments of
/// `segment_s` with linear detrending (both experiments have a slow ramp in the output: the
/// axis still accelerating, or the elevation ratio drifting as the dish rises), DC dropped.
fn welch_h1(input: &[f64], output: &[f64], step_s: f64, segment_s: f64) -> Result<Estimate, IdentificationError> {
    let sample_rate = 1.0 / step_s;
    let welch = WelchConfig::from_duration(segment_s, sample_rate).with_detrend(Detrend::Linear);
    let estimate = transfer_function_h1(input, output, sample_rate, &welch).map_err(IdentificationError::Welch)?;
    let bins = 1..estimate.frequency_hz.len();
    Ok(Estimate {
        frequency_hz: estimate.frequency_hz[bins.clone()].to_vec(),
        measured: estimate.h1[bins.clone()].to_vec(),
        coherence: estimate.coherence[bins].to_vec(),
        dof: estimate.dof,
        segments: estimate.segments,
    })
}

/// A measured frequency response beside its analytic model, bin by bin; the comparisons the
/// figures, summaries and tests state come with it.
pub trait MeasuredResponse {
    /// The estimate beside the model.
    fn comparison(&self) -> ResponseComparison<'_>;

    /// Bins with coherence above `threshold` up to `max_frequency_hz`.
    fn coherent_bins(&self, threshold: f64, max_frequency_hz: f64) -> Vec<usize> {
        self.comparison().coherent_bins(threshold, max_frequency_hz)
    }

    /// Largest |20 log10 |measured / analytic||, dB, with its frequency, over `bins`.
    fn max_magnitude_error_db(&self, bins: &[usize]) -> (f64, f64) {
        self.comparison().max_magnitude_error_db(bins)
    }

    /// Largest |phase(measured / analytic)|, deg (wrapped to +/-180), over `bins`.
    fn max_phase_error_deg(&self, bins: &[usize]) -> f64 {
        self.comparison().max_phase_error_deg(bins)
    }
}
