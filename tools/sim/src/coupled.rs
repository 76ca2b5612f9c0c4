//! The coupled antenna: two plants, two controllers, the wind unit and (unless the paper's rigid
//! configuration is asked for) the structure, loaded from their packaged `.fmu` files through
//! the C ABI and stepped together by a fixed-step master.
//!
//! Connections, all exchanged at every communication point `t_k` (Jacobi: every unit steps from
//! the values at `t_k`; there is no algebraic loop, because only the wind unit has direct
//! feedthrough and its inputs come from the plants' states; the structure's quasi-static
//! outputs follow the wind loads set at the same point, which come from the plants' states):
//!
//! ```text
//! command table ──► controllers ──current commands──► plants ──encoders, motor speeds──► controllers
//!                                     wind ◄── true pointing (az, el) ── plants
//!                                     wind ──torques about the axes, drag, its axial and lateral parts, lift──► structure ──beam offsets──► pointing
//!                                structure ──drive torques (the modes pushing back)──► plants (load.disturbance_torque)
//!                                   plants ──axis speeds──► structure
//!                         elevation plant ──true elevation──► azimuth plant (load inertia)
//! ```
//!
//! The beam points where the load-side axes point plus the structure's offsets; the pointing
//! error the requirements judge is the command minus the beam. The structure's modes push back
//! on the drives (`AntennaConfig::structure_feedback`): the plants take the structure's drive
//! torques, and their load inertias leave out what the modes carry. Coupled one way, or without
//! a structure, the plants take the wind's torques themselves.
//!
//! A step is the wind exchange (the wind unit told where the axes point, its loads read) and
//! then two lanes: the azimuth plant, its controller and the structure; the elevation plant, its
//! controller and the wind unit's own step. They share one value within the step, the
//! structure's torque on the elevation drive, which the azimuth lane hands over as soon as the
//! structure's exchange gives it. [`Lanes::Two`] runs the first lane on a second thread (a
//! Jacobi master's units are independent between exchanges); every unit sees the same calls
//! with the same values in the same order as on one thread, so the results are equal bit for
//! bit.

use std::path::Path;
use std::sync::Arc;

use fmu_import::{Fmu, ImportError, Instance, ModelDescription};

use super::command::{Command, CommandTable};
use super::handoff::{Handoff, Received};
use super::pointing_model::PointingModel;

/// Why the coupled antenna could not be set up: an FMU refused a call, or the structure's
/// modes cannot be coupled both ways to a plant.
#[derive(Debug, Clone, thiserror::Error)]
pub enum CouplingError {
    #[error(transparent)]
    Import(#[from] ImportError),
    /// Modes whose inertia about the elevation axis changes with elevation, against an
    /// elevation plant whose load inertia does not.
    #[error(
        "the structure's modes carry {zenith:.4e} kg m^2 about the elevation axis at the zenith and {horizon:.4e} at the horizon, but the elevation plant's load inertia does not change with elevation: a mode that changes with elevation (horizon_frequency) and takes the elevation torque cannot be coupled both ways to it (couple it one way, or give it no horizon_frequency)"
    )]
    InertiaChangesWithElevation { zenith: f64, horizon: f64 },
    /// Modes that carry at least the inertia of the part of the axis they come out of.
    #[error(
        "the structure's modes carry {carried:.4e} kg m^2 about the axis of {plant}, not less than its {parameter} = {inertia:.4e} kg m^2: modes that push back on the drive cannot carry more than the drive's load (lower the modes' stiffness or raise their frequency, or couple them one way)"
    )]
    CarriedAboveLoad { carried: f64, plant: String, parameter: &'static str, inertia: f64 },
}

/// A value for a parameter set by name.
#[derive(Debug, Clone, PartialEq)]
pub enum ParameterValue {
    Real(f64),
    Integer(i32),
    Boolean(bool),
    Text(String),
}

/// Parameter overrides for one unit, applied by variable name before initialisation.
pub type Overrides = Vec<(String, ParameterValue)>;

/// The wind the antenna stands in.
#[derive(Debug, Clone, PartialEq)]
pub struct WindCondition {
    /// Mean speed at 10 m, m/s; 0 means no wind at all.
    pub mean_speed_m_s: f64,
    /// Roughness length, m (sets the turbulence intensity).
    pub roughness_length_m: f64,
    /// Where the wind comes from, deg from north.
    pub direction_deg: f64,
    pub seed: i32,
}

impl WindCondition {
    pub const CALM: WindCondition =
        WindCondition { mean_speed_m_s: 0.0, roughness_length_m: 0.026, direction_deg: 0.0, seed: 1 };
}

/// Everything a coupled run needs besides the command table. `AntennaConfig::default()` is the
/// realistic antenna of `docs/parameters.csv`'s default column; the configuration module builds
/// it, the paper's configuration and any point of a sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct AntennaConfig {
    /// Communication step, s. The controllers keep their own sample time (1 ms by default, a
    /// parameter): a step that is a multiple of it runs several samples per step on held
    /// measurements, as docs/controller.md describes; the master never retunes them.
    pub step_s: f64,
    pub wind: WindCondition,
    pub azimuth_plant: Overrides,
    pub elevation_plant: Overrides,
    pub azimuth_controller: Overrides,
    pub elevation_controller: Overrides,
    /// Parameters of the wind unit besides the wind condition (admittance, coefficients).
    pub wind_unit: Overrides,
    /// Multiplies the wind unit's loads before they reach the plants and the structure (a
    /// torque-coefficient scale: the shipped coefficient table is a stand-in).
    pub wind_load_scale: f64,
    /// The structure between encoders and beam with its parameter overrides (`modes_file`), or
    /// `None` for the paper's rigid antenna, whose beam is the load-side axes.
    pub structure: Option<Overrides>,
    /// Whether the structure's modes push back on the drives: the plants take the structure's
    /// `drive_torque.*` in place of the wind's torques and leave the modes' inertia
    /// (`modal_inertia.*`) out of their load inertia, so that the modes and the drives move
    /// together (docs/structure-model.md, "Both ways"). Off, the modes swing on the drives
    /// without reacting on them. Without a structure it changes nothing.
    pub structure_feedback: bool,
    /// How many threads step the run; the results do not depend on it.
    pub lanes: Lanes,
    /// A pointing-model table the master applies as an antenna control unit does: each command
    /// moved by the error the table predicts from the commanded angles and the run's mean wind
    /// (its speed and direction, as a weather station reports them; never the gust). `None`: the
    /// command goes to the controllers as the table gives it.
    pub pointing_model: Option<Arc<PointingModel>>,
}

impl AntennaConfig {
    /// The paper's drive-only model with nothing applied: the FMUs' start values, no structure.
    pub fn bare() -> Self {
        AntennaConfig {
            step_s: 1e-3,
            wind: WindCondition::CALM,
            azimuth_plant: Vec::new(),
            elevation_plant: Vec::new(),
            azimuth_controller: Vec::new(),
            elevation_controller: Vec::new(),
            wind_unit: Vec::new(),
            wind_load_scale: 1.0,
            structure: None,
            structure_feedback: true,
            lanes: Lanes::One,
            pointing_model: None,
        }
    }

    /// Every override of the run, as `<model identifier>.<variable> = value` pairs, for another
    /// master to apply (the trace export).
    pub fn all_overrides(&self) -> Vec<(&'static str, &Overrides)> {
        let mut all = vec![
            ("AzimuthPlant", &self.azimuth_plant),
            ("ElevationPlant", &self.elevation_plant),
            ("AzimuthController", &self.azimuth_controller),
            ("ElevationController", &self.elevation_controller),
            ("Wind", &self.wind_unit),
        ];
        if let Some(structure) = &self.structure {
            all.push(("Structure", structure));
        }
        all
    }

    /// The run as another master reads it (`tools/fmpy_master/coupled_master.py --config`): the step,
    /// the end, the wind, the structure's coupling and every parameter override as
    /// `<model identifier>.<variable> = value`, one `name = value` a line.
    pub fn master_config_text(&self, wind: &WindCondition, end_s: f64) -> String {
        let mut text = format!(
            "step_s = {:e}\nend_s = {:e}\nwind.mean_speed = {:e}\nwind.roughness_length = {:e}\nwind.direction = {:e}\nseed = {}\nwind_load_scale = {:e}\nstructure = {}\nstructure_feedback = {}\n",
            self.step_s,
            end_s,
            wind.mean_speed_m_s,
            wind.roughness_length_m,
            wind.direction_deg,
            wind.seed,
            self.wind_load_scale,
            self.structure.is_some(),
            self.structure.is_some() && self.structure_feedback,
        );
        for (unit, overrides) in self.all_overrides() {
            for (name, value) in overrides {
                let value = match value {
                    ParameterValue::Real(x) => format!("{x:e}"),
                    ParameterValue::Integer(i) => i.to_string(),
                    ParameterValue::Boolean(b) => b.to_string(),
                    ParameterValue::Text(t) => format!("\"{t}\""),
                };
                text.push_str(&format!("{unit}.{name} = {value}\n"));
            }
        }
        text
    }
}

/// The six packaged FMUs.
pub struct FmuSet {
    pub azimuth_plant: Fmu,
    pub elevation_plant: Fmu,
    pub azimuth_controller: Fmu,
    pub elevation_controller: Fmu,
    pub wind: Fmu,
    pub structure: Fmu,
}

impl FmuSet {
    /// Opens the FMUs in a folder (the packaging tool writes them to `target/fmu/`).
    pub fn open(directory: &Path) -> Result<FmuSet, ImportError> {
        let open = |name: &str| Fmu::open(directory.join(format!("{name}.fmu")));
        Ok(FmuSet {
            azimuth_plant: open("AzimuthPlant")?,
            elevation_plant: open("ElevationPlant")?,
            azimuth_controller: open("AzimuthController")?,
            elevation_controller: open("ElevationController")?,
            wind: open("Wind")?,
            structure: open("Structure")?,
        })
    }
}

/// Time series of one coupled run, one entry per communication point.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Trace {
    pub time_s: Vec<f64>,
    pub command_azimuth_deg: Vec<f64>,
    pub command_elevation_deg: Vec<f64>,
    pub azimuth_deg: Vec<f64>,
    pub elevation_deg: Vec<f64>,
    pub encoder_azimuth_deg: Vec<f64>,
    pub encoder_elevation_deg: Vec<f64>,
    pub reference_azimuth_deg: Vec<f64>,
    pub reference_elevation_deg: Vec<f64>,
    pub wind_speed_m_s: Vec<f64>,
    pub wind_torque_azimuth_nm: Vec<f64>,
    pub wind_torque_elevation_nm: Vec<f64>,
    pub current_azimuth_a: Vec<[f64; 2]>,
    pub current_elevation_a: Vec<f64>,
    /// The structure's beam offsets relative to the load-side axes, arcsec on the sky
    /// (cross-elevation, elevation); zero without a structure.
    pub beam_offset_arcsec: Vec<[f64; 2]>,
    /// Their quasi-static part (compliance times the loads), arcsec.
    pub beam_offset_static_arcsec: Vec<[f64; 2]>,
    /// What a pointing model added to the command (azimuth, elevation), deg of axis angle: the
    /// controllers were sent `command + correction`, while `command_*` keep the target the
    /// error is judged against. Empty without a pointing model.
    pub pointing_correction_deg: Vec<[f64; 2]>,
}

/// On-sky pointing error vectors (cross-elevation, elevation), arcsec, of one run, split into
/// the parts a pointing error budget names. They add up to the beam's error exactly.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ErrorParts {
    /// Command minus the encoder reading: what the servo leaves.
    pub servo: Vec<[f64; 2]>,
    /// Encoder reading minus the true load-side axis: the encoder's errors and its count.
    pub encoder: Vec<[f64; 2]>,
    /// Minus the structure's quasi-static beam offset.
    pub structure_static: Vec<[f64; 2]>,
    /// Minus the rest of the structure's beam offset (its modes ringing).
    pub structure_dynamic: Vec<[f64; 2]>,
    /// Minus the pointing model's correction of the command (zero without one): with it, the
    /// servo's part is the corrected command minus the encoder reading.
    pub pointing_model: Vec<[f64; 2]>,
}

impl Trace {
    /// Pointing error of the beam on the sky, arcsec: `sqrt(cross^2 + d_el^2)` with
    /// `cross = d_az cos el - beam azimuth offset`, `d_el` likewise, where `d` is the command
    /// minus the true load-side axis position. Without a structure the offsets are zero and this
    /// is the paper's command minus true position.
    pub fn pointing_error_arcsec(&self) -> Vec<f64> {
        self.pointing_error_sky_arcsec().into_iter().map(|[cross, d_el]| cross.hypot(d_el)).collect()
    }

    /// The beam's pointing error as an on-sky vector (cross-elevation, elevation), arcsec: the
    /// components whose length [`Trace::pointing_error_arcsec`] is. Centring takes their means out.
    pub fn pointing_error_sky_arcsec(&self) -> Vec<[f64; 2]> {
        (0..self.time_s.len())
            .map(|k| {
                let d_az = self.command_azimuth_deg[k] - self.azimuth_deg[k];
                let d_el = self.command_elevation_deg[k] - self.elevation_deg[k];
                let [offset_az, offset_el] = self.beam_offset_arcsec.get(k).copied().unwrap_or_default();
                let cross = d_az * self.elevation_deg[k].to_radians().cos() - offset_az / 3600.0;
                let d_el = d_el - offset_el / 3600.0;
                [cross * 3600.0, d_el * 3600.0]
            })
            .collect()
    }

    /// The beam's error split into servo, encoder and structure parts (on-sky vectors, arcsec).
    pub fn error_parts(&self) -> ErrorParts {
        let n = self.time_s.len();
        let mut parts = ErrorParts::default();
        for k in 0..n {
            let cos_el = self.elevation_deg[k].to_radians().cos();
            let sky = |az_deg: f64, el_deg: f64| [az_deg * cos_el * 3600.0, el_deg * 3600.0];
            let [correction_az, correction_el] = self.pointing_correction_deg.get(k).copied().unwrap_or_default();
            parts.servo.push(sky(
                self.command_azimuth_deg[k] + correction_az - self.encoder_azimuth_deg[k],
                self.command_elevation_deg[k] + correction_el - self.encoder_elevation_deg[k],
            ));
            parts.pointing_model.push(sky(-correction_az, -correction_el));
            parts.encoder.push(sky(
                self.encoder_azimuth_deg[k] - self.azimuth_deg[k],
                self.encoder_elevation_deg[k] - self.elevation_deg[k],
            ));
            let [total_az, total_el] = self.beam_offset_arcsec.get(k).copied().unwrap_or_default();
            let [static_az, static_el] = self.beam_offset_static_arcsec.get(k).copied().unwrap_or_default();
            parts.structure_static.push([-static_az, -static_el]);
            parts.structure_dynamic.push([static_az - total_az, static_el - total_el]);
        }
        parts
    }

    /// The columns of [`Trace::to_csv`].
    pub const CSV_HEADER: [&'static str; 19] = [
        "time_s",
        "command_azimuth_deg",
        "command_elevation_deg",
        "azimuth_deg",
        "elevation_deg",
        "encoder_azimuth_deg",
        "encoder_elevation_deg",
        "reference_azimuth_deg",
        "reference_elevation_deg",
        "wind_speed_m_s",
        "wind_torque_azimuth_nm",
        "wind_torque_elevation_nm",
        "current_azimuth_1_a",
        "current_azimuth_2_a",
        "current_elevation_a",
        "beam_azimuth_offset_arcsec",
        "beam_elevation_offset_arcsec",
        "beam_azimuth_offset_static_arcsec",
        "beam_elevation_offset_static_arcsec",
    ];

    /// The trace as CSV, every value with all its digits (`{:e}`, the shortest text that reads
    /// back to the same number), for bit-for-bit comparisons with other masters.
    pub fn to_csv(&self) -> String {
        let mut writer = csv::Writer::from_writer(Vec::new());
        let mut write = || -> Result<(), csv::Error> {
            writer.write_record(Self::CSV_HEADER)?;
            for k in 0..self.time_s.len() {
                let row = [
                    self.time_s[k],
                    self.command_azimuth_deg[k],
                    self.command_elevation_deg[k],
                    self.azimuth_deg[k],
                    self.elevation_deg[k],
                    self.encoder_azimuth_deg[k],
                    self.encoder_elevation_deg[k],
                    self.reference_azimuth_deg[k],
                    self.reference_elevation_deg[k],
                    self.wind_speed_m_s[k],
                    self.wind_torque_azimuth_nm[k],
                    self.wind_torque_elevation_nm[k],
                    self.current_azimuth_a[k][0],
                    self.current_azimuth_a[k][1],
                    self.current_elevation_a[k],
                    self.beam_offset_arcsec[k][0],
                    self.beam_offset_arcsec[k][1],
                    self.beam_offset_static_arcsec[k][0],
                    self.beam_offset_static_arcsec[k][1],
                ];
                writer.write_record(row.map(|x| format!("{x:e}")))?;
            }
            writer.flush()?;
            Ok(())
        };
        write().expect("writing CSV into memory cannot fail");
        String::from_utf8(writer.into_inner().expect("flushed above")).expect("the CSV is ASCII")
    }

    fn reserve(&mut self, n: usize) {
        for v in [
            &mut self.time_s,
            &mut self.command_azimuth_deg,
            &mut self.command_elevation_deg,
            &mut self.azimuth_deg,
            &mut self.elevation_deg,
            &mut self.encoder_azimuth_deg,
            &mut self.encoder_elevation_deg,
            &mut self.reference_azimuth_deg,
            &mut self.reference_elevation_deg,
            &mut self.wind_speed_m_s,
            &mut self.wind_torque_azimuth_nm,
            &mut self.wind_torque_elevation_nm,
            &mut self.current_elevation_a,
        ] {
            v.reserve(n);
        }
        self.current_azimuth_a.reserve(n);
        self.beam_offset_arcsec.reserve(n);
        self.beam_offset_static_arcsec.reserve(n);
    }

    /// The budget's parts added up: the beam's on-sky error (equal to
    /// [`Trace::pointing_error_sky_arcsec`] up to rounding), arcsec.
    pub fn summed_parts(parts: &ErrorParts) -> Vec<[f64; 2]> {
        (0..parts.servo.len())
            .map(|k| {
                let all = [
                    parts.servo[k],
                    parts.encoder[k],
                    parts.structure_static[k],
                    parts.structure_dynamic[k],
                    parts.pointing_model[k],
                ];
                [all.iter().map(|p| p[0]).sum(), all.iter().map(|p| p[1]).sum()]
            })
            .collect()
    }
}

/// The plants' parameters (azimuth, elevation) whose inertia the structure's modes carry when
/// they push back on the drives: the part of each axis's load inertia a mode's body belongs to.
const CARRIED_INERTIA_PARAMETERS: [&str; 2] = ["load.turning_head_inertia", "load.inertia"];

/// The azimuth plant's two parts of the elevation structure's inertia about the azimuth axis,
/// the one that goes as `cos^2(el)` and the one that goes as `sin^2(el)`: where a mode that
/// changes with elevation carries more at the horizon or at the zenith than at the other end,
/// the excess comes out of them.
const ELEVATION_DEPENDENT_INERTIA_PARAMETERS: [&str; 2] =
    ["load.elevation_structure_cross_inertia", "load.elevation_structure_boresight_inertia"];

/// Which plant parameters lose how much inertia (kg m^2) when the structure's modes, coupled
/// both ways, carry `zenith` about an axis with the dish at the zenith and `horizon` at the
/// horizon (`modal_inertia.*` and `modal_inertia.*_horizon`), so that the plant's inertia plus
/// the modes' is the axis's at every elevation.
///
/// The modes' inertia about an axis turns as `horizon cos^2(el) + zenith sin^2(el)`, the
/// azimuth plant's as `turning_head + cross cos^2(el) + boresight sin^2(el)`: the part both ends
/// share comes out of the turning head ([`CARRIED_INERTIA_PARAMETERS`]) and the rest out of the
/// cross or the boresight part. The elevation plant's inertia does not change with elevation, so
/// modes whose inertia about the elevation axis does are an error: they cannot be coupled both
/// ways to that plant.
pub fn carried_inertia_split(
    axis: usize,
    zenith: f64,
    horizon: f64,
) -> Result<Vec<(&'static str, f64)>, CouplingError> {
    let shared = zenith.min(horizon);
    let parts = match axis {
        0 => vec![
            (CARRIED_INERTIA_PARAMETERS[0], shared),
            (ELEVATION_DEPENDENT_INERTIA_PARAMETERS[0], horizon - shared),
            (ELEVATION_DEPENDENT_INERTIA_PARAMETERS[1], zenith - shared),
        ],
        _ if zenith != horizon => return Err(CouplingError::InertiaChangesWithElevation { zenith, horizon }),
        _ => vec![(CARRIED_INERTIA_PARAMETERS[1], zenith)],
    };
    Ok(parts.into_iter().filter(|(_, carried)| *carried > 0.0).collect())
}

/// Lowers a plant's load inertia by the inertia the structure's modes carry about its axis
/// (`axis` 0 azimuth, 1 elevation; `zenith` and `horizon` as [`carried_inertia_split`] takes
/// them), in initialisation mode; nothing when they carry none. A mode at least as heavy as the
/// part of its axis it comes out of is an error: it could not push back on a drive.
pub fn leave_out_carried_inertia(
    plant: &mut Instance,
    description: &ModelDescription,
    axis: usize,
    zenith: f64,
    horizon: f64,
) -> Result<(), CouplingError> {
    for (parameter, carried) in carried_inertia_split(axis, zenith, horizon)? {
        let vr = description.vr(parameter)?;
        let mut inertia = [0.0];
        plant.get_real(&[vr], &mut inertia)?;
        if carried >= inertia[0] {
            return Err(CouplingError::CarriedAboveLoad {
                carried,
                plant: plant.name.clone(),
                parameter,
                inertia: inertia[0],
            });
        }
        plant.set_real(&[vr], &[inertia[0] - carried])?;
    }
    Ok(())
}

fn apply_overrides(
    instance: &mut Instance,
    description: &ModelDescription,
    overrides: &Overrides,
) -> Result<(), ImportError> {
    for (name, value) in overrides {
        let vr = description.vr(name)?;
        match value {
            ParameterValue::Real(x) => instance.set_real(&[vr], &[*x])?,
            ParameterValue::Integer(i) => instance.set_integer(&[vr], &[*i])?,
            ParameterValue::Boolean(b) => instance.set_boolean(&[vr], &[*b])?,
            ParameterValue::Text(s) => instance.set_string(&[vr], &[s.as_str()])?,
        };
    }
    Ok(())
}

/// Value references used at every step, looked up once by name.
#[derive(Clone)]
struct Ports {
    az_plant_out: [u32; 7],
    az_plant_in: [u32; 4],
    el_plant_out: [u32; 5],
    el_plant_in: [u32; 2],
    az_ctrl_in: [u32; 5],
    az_ctrl_out: [u32; 3],
    el_ctrl_in: [u32; 4],
    el_ctrl_out: [u32; 2],
    wind_in: [u32; 2],
    /// Torque about azimuth, about elevation, wind speed and then the forces of [`WIND_FORCES`]
    /// that the wind unit gives: read in one call.
    wind_out: Vec<u32>,
    /// For each force read after the wind speed, its place in [`WIND_FORCES`].
    wind_forces: Vec<usize>,
    /// Torque about azimuth, about elevation, force on the dish and, where the structure takes
    /// them, the axes' speeds (whose changes swing the structure) and the resolved forces that
    /// both the structure takes and the wind unit gives.
    structure_in: Vec<u32>,
    /// For each of `structure_in`, its name and where its value comes from: an index into the
    /// loads ([`LOADS`]: torques, then [`WIND_FORCES`]) or, from [`LOADS`] on, the azimuth and
    /// elevation speeds.
    structure_sources: Vec<(&'static str, usize)>,
    /// The four beam offsets and, when its modes push back on the drives, the two drive
    /// torques: read in one call.
    structure_out: Vec<u32>,
    /// The structure's `drive_torque.azimuth` and `drive_torque.elevation` when its modes push
    /// back on the drives: then they, not the wind's torques, go to the plants.
    structure_drive: Option<[u32; 2]>,
}

/// The wind unit's forces the master reads where the unit gives them, in the order they follow
/// the two torques in the loads, each with the structure input it drives: the drag along the
/// wind (to `force.dish`, which the structure always has), and the drag resolved in the
/// antenna's frame and the lift (each connected only where both units have it).
const WIND_FORCES: [(&str, &str); 4] = [
    ("force.drag", "force.dish"),
    ("force.axial", "force.axial"),
    ("force.lateral", "force.lateral"),
    ("force.lift", "force.lift"),
];

/// The loads the wind unit gives at a point: torque about azimuth, about elevation (N m), and
/// the forces of [`WIND_FORCES`] (N, 0 where the wind unit gives none).
const LOADS: usize = 2 + WIND_FORCES.len();

/// The most inputs the structure is sent: the loads, the two axes' speeds and the elevation.
const STRUCTURE_INPUTS: usize = LOADS + 3;

impl Ports {
    /// Leaves out the inputs that the structure's modes do not take, as its `takes.<input>`
    /// calculated parameters say (a structure that does not say takes every input it has): the
    /// wind's forces and the elevation, which the shipped modes do not take; reading and setting
    /// four forces at every step cost some 600 instructions, a twentieth of a step. The results
    /// are the same bit for bit, since no mode weighs an input left out.
    fn keep_inputs_taken(
        &mut self,
        structure: &mut Instance,
        description: &ModelDescription,
    ) -> Result<(), ImportError> {
        let mut kept = Vec::with_capacity(self.structure_in.len());
        for (&vr, &(input, source)) in self.structure_in.iter().zip(&self.structure_sources) {
            let taken = match description.vr(&format!("takes.{input}")) {
                Ok(takes) => {
                    let mut value = [true];
                    structure.get_boolean(&[takes], &mut value)?;
                    value[0]
                }
                Err(_) => true,
            };
            if taken {
                kept.push((vr, (input, source)));
            }
        }
        (self.structure_in, self.structure_sources) = kept.into_iter().unzip();
        self.read_only_forces_sent();
        Ok(())
    }

    /// Reads from the wind unit only the forces that go to the structure (none without one).
    fn read_only_forces_sent(&mut self) {
        let sent = |force: usize| self.structure_sources.iter().any(|&(_, source)| source == 2 + force);
        // The torques and the wind speed come first and are always read; the forces follow.
        let (forces, vrs): (Vec<usize>, Vec<u32>) =
            self.wind_forces.iter().zip(&self.wind_out[3..]).filter(|(&force, _)| sent(force)).unzip();
        self.wind_out.truncate(3);
        self.wind_out.extend(vrs);
        self.wind_forces = forces;
    }

    fn look_up(fmus: &FmuSet) -> Result<Ports, ImportError> {
        fn vrs<const N: usize>(d: &ModelDescription, names: [&str; N]) -> Result<[u32; N], ImportError> {
            let mut out = [0; N];
            for (o, n) in out.iter_mut().zip(names) {
                *o = d.vr(n)?;
            }
            Ok(out)
        }
        let ap = &fmus.azimuth_plant.description;
        let ep = &fmus.elevation_plant.description;
        let ac = &fmus.azimuth_controller.description;
        let ec = &fmus.elevation_controller.description;
        let w = &fmus.wind.description;
        let s = &fmus.structure.description;
        // The torques and the drag always (an old wind unit without forces sends zero drag);
        // the axes' speeds and the elevation where the structure takes them; a resolved force
        // where both take it.
        let mut structure_inputs = vec![("torque.azimuth", 0), ("torque.elevation", 1), ("force.dish", 2)];
        if s.vr("axis.azimuth_speed").is_ok() && s.vr("axis.elevation_speed").is_ok() {
            structure_inputs.extend([("axis.azimuth_speed", LOADS), ("axis.elevation_speed", LOADS + 1)]);
        }
        if s.vr("axis.elevation").is_ok() {
            structure_inputs.push(("axis.elevation", LOADS + 2));
        }
        for (i, (output, input)) in WIND_FORCES.iter().enumerate().skip(1) {
            if w.vr(output).is_ok() && s.vr(input).is_ok() {
                structure_inputs.push((input, 2 + i));
            }
        }
        Ok(Ports {
            az_plant_out: vrs(
                ap,
                [
                    "axis.encoder_position",
                    "axis.position",
                    "motor1.speed",
                    "motor2.speed",
                    "motor1.current",
                    "motor2.current",
                    "axis.speed",
                ],
            )?,
            az_plant_in: vrs(
                ap,
                ["motor1.current_command", "motor2.current_command", "load.disturbance_torque", "elevation"],
            )?,
            el_plant_out: vrs(
                ep,
                ["axis.encoder_position", "axis.position", "motor.speed", "motor.current", "axis.speed"],
            )?,
            el_plant_in: vrs(ep, ["motor.current_command", "load.disturbance_torque"])?,
            az_ctrl_in: vrs(
                ac,
                [
                    "command.position",
                    "command.velocity",
                    "measured.position",
                    "measured.motor1_speed",
                    "measured.motor2_speed",
                ],
            )?,
            az_ctrl_out: vrs(ac, ["motor1.current_command", "motor2.current_command", "status.reference_position"])?,
            el_ctrl_in: vrs(ec, ["command.position", "command.velocity", "measured.position", "measured.motor_speed"])?,
            el_ctrl_out: vrs(ec, ["motor.current_command", "status.reference_position"])?,
            wind_in: vrs(w, ["antenna.azimuth", "antenna.elevation"])?,
            wind_out: {
                let mut out = vrs(w, ["torque.azimuth", "torque.elevation", "wind.speed"])?.to_vec();
                out.extend(WIND_FORCES.iter().filter_map(|(name, _)| w.vr(name).ok()));
                out
            },
            wind_forces: (0..WIND_FORCES.len()).filter(|i| w.vr(WIND_FORCES[*i].0).is_ok()).collect(),
            structure_in: structure_inputs.iter().map(|(name, _)| s.vr(name)).collect::<Result<_, _>>()?,
            structure_sources: structure_inputs,
            structure_out: vrs(
                s,
                [
                    "beam.azimuth_offset",
                    "beam.elevation_offset",
                    "beam.azimuth_offset_static",
                    "beam.elevation_offset_static",
                ],
            )?
            .to_vec(),
            structure_drive: None,
        })
    }
}

/// The instances of one antenna, initialised and ready to step.
pub struct CoupledAntenna {
    pub azimuth_plant: Instance,
    pub elevation_plant: Instance,
    pub azimuth_controller: Instance,
    pub elevation_controller: Instance,
    pub wind: Instance,
    /// `None` for the paper's rigid antenna.
    pub structure: Option<Instance>,
    ports: Ports,
    step_s: f64,
    start_time_s: f64,
    steps_done: u64,
    /// The configuration's load scale, or 0 for a calm day (the wind unit cannot be set to
    /// zero speed).
    wind_scale: f64,
    lanes: Lanes,
    /// The pointing model and the mean wind it is told, if the configuration has one.
    pointing: Option<Pointing>,
}

/// A pointing model as the antenna control unit applies it in one run: the table, and the mean
/// wind's speed (m/s, 0 in calm) and direction (deg from north) from the weather station.
#[derive(Debug, Clone)]
struct Pointing {
    model: Arc<PointingModel>,
    wind_speed_m_s: f64,
    wind_direction_deg: f64,
}

impl Pointing {
    /// The configuration's pointing model, told the run's mean wind; `None` without one.
    fn of(config: &AntennaConfig) -> Option<Pointing> {
        config.pointing_model.clone().map(|model| Pointing {
            model,
            wind_speed_m_s: config.wind.mean_speed_m_s.max(0.0),
            wind_direction_deg: config.wind.direction_deg,
        })
    }
}

/// The command the controllers are sent for the target `target`: corrected by the pointing
/// model, if there is one.
fn corrected(pointing: Option<&Pointing>, target: Command) -> Command {
    match pointing {
        Some(p) => p.model.correct(target, p.wind_speed_m_s, p.wind_direction_deg),
        None => target,
    }
}

impl CoupledAntenna {
    /// Instantiates and initialises every unit, the antenna at rest at the table's first point.
    pub fn new(fmus: &FmuSet, config: &AntennaConfig, table: &CommandTable) -> Result<CoupledAntenna, CouplingError> {
        let start = table.at(table.time_span().0);
        let ports = Ports::look_up(fmus)?;
        let real = |d: &ModelDescription, name: &str, value: f64| -> Result<(String, ParameterValue), ImportError> {
            d.vr(name)?;
            Ok((name.to_string(), ParameterValue::Real(value)))
        };
        let mut az_plant_overrides =
            vec![real(&fmus.azimuth_plant.description, "initial_position", start.azimuth_deg)?];
        az_plant_overrides.push(real(&fmus.azimuth_plant.description, "elevation", start.elevation_deg)?);
        az_plant_overrides.extend(config.azimuth_plant.iter().cloned());
        let mut el_plant_overrides =
            vec![real(&fmus.elevation_plant.description, "initial_position", start.elevation_deg)?];
        el_plant_overrides.extend(config.elevation_plant.iter().cloned());
        let mut az_ctrl_overrides = vec![
            real(&fmus.azimuth_controller.description, "command.position", start.azimuth_deg)?,
            real(&fmus.azimuth_controller.description, "measured.position", start.azimuth_deg)?,
        ];
        az_ctrl_overrides.extend(config.azimuth_controller.iter().cloned());
        let mut el_ctrl_overrides = vec![
            real(&fmus.elevation_controller.description, "command.position", start.elevation_deg)?,
            real(&fmus.elevation_controller.description, "measured.position", start.elevation_deg)?,
        ];
        el_ctrl_overrides.extend(config.elevation_controller.iter().cloned());
        let w = &config.wind;
        let wind_spectrum = if w.mean_speed_m_s > 0.0 { 1 } else { 3 };
        let mut wind_overrides: Overrides = vec![
            ("wind.mean_speed".into(), ParameterValue::Real(w.mean_speed_m_s.max(0.5))),
            ("wind.roughness_length".into(), ParameterValue::Real(w.roughness_length_m)),
            ("wind.direction".into(), ParameterValue::Real(w.direction_deg)),
            ("seed".into(), ParameterValue::Integer(w.seed)),
            ("spectrum".into(), ParameterValue::Integer(wind_spectrum)),
            ("antenna.azimuth".into(), ParameterValue::Real(start.azimuth_deg)),
            ("antenna.elevation".into(), ParameterValue::Real(start.elevation_deg)),
        ];
        wind_overrides.extend(config.wind_unit.iter().cloned());
        let start_time = table.time_span().0;
        // Instantiates and initialises a unit; `carried` is a plant's axis and the inertia the
        // structure's modes carry about it at the zenith and at the horizon, which the unit
        // leaves out.
        let make_carrying = |fmu: &Fmu,
                             name: &str,
                             overrides: &Overrides,
                             carried: Option<(usize, f64, f64)>|
         -> Result<Instance, CouplingError> {
            let mut instance = fmu.instantiate(name, false)?;
            instance.setup_experiment(start_time, None)?;
            apply_overrides(&mut instance, &fmu.description, overrides)?;
            instance.enter_initialization_mode()?;
            if let Some((axis, zenith, horizon)) = carried {
                leave_out_carried_inertia(&mut instance, &fmu.description, axis, zenith, horizon)?;
            }
            instance.exit_initialization_mode()?;
            Ok(instance)
        };
        let make = |fmu: &Fmu, name: &str, overrides: &Overrides| make_carrying(fmu, name, overrides, None);
        let mut ports = ports;
        let mut wind = make(&fmus.wind, "wind", &wind_overrides)?;
        // The wind unit's gust is meaningless without wind: zero torques in that case.
        let wind_scale = if w.mean_speed_m_s <= 0.0 { 0.0 } else { config.wind_load_scale };
        // The structure comes before the plants: where its modes push back on the drives, the
        // plants leave the inertia the modes carry out of their own.
        let mut structure = None;
        // The modes' inertia about each axis at the zenith and at the horizon.
        let mut carried = [[0.0; 2]; 2];
        if let Some(structure_overrides) = &config.structure {
            // The structure starts at rest in its static deflection under the loads at the
            // start, so that a run in a mean wind does not begin with ringing modes.
            let (loads, _) = wind_loads(&mut wind, &ports, wind_scale)?;
            let mut overrides = structure_overrides.clone();
            for (name, source) in &ports.structure_sources {
                if let Some(value) = loads.get(*source) {
                    overrides.push((name.to_string(), ParameterValue::Real(*value)));
                }
            }
            let description = &fmus.structure.description;
            // The modes that change with elevation start at the antenna's.
            if description.vr("axis.elevation").is_ok() {
                overrides.push(("axis.elevation".into(), ParameterValue::Real(start.elevation_deg)));
            }
            let mut unit = make(&fmus.structure, "structure", &overrides)?;
            ports.keep_inputs_taken(&mut unit, description)?;
            if config.structure_feedback {
                let zenith = [description.vr("modal_inertia.azimuth")?, description.vr("modal_inertia.elevation")?];
                unit.get_real(&zenith, &mut carried[0])?;
                // A structure without the horizon's inertias has modes that do not change with
                // elevation: the zenith's hold at the horizon too.
                carried[1] = carried[0];
                let horizon = [
                    description.vr("modal_inertia.azimuth_horizon"),
                    description.vr("modal_inertia.elevation_horizon"),
                ];
                if let [Ok(az), Ok(el)] = horizon {
                    unit.get_real(&[az, el], &mut carried[1])?;
                }
                let drive = [description.vr("drive_torque.azimuth")?, description.vr("drive_torque.elevation")?];
                ports.structure_out.extend(drive);
                ports.structure_drive = Some(drive);
            }
            structure = Some(unit);
        } else {
            ports.structure_in.clear();
            ports.structure_sources.clear();
            ports.read_only_forces_sent();
        }
        let antenna = CoupledAntenna {
            azimuth_plant: make_carrying(
                &fmus.azimuth_plant,
                "azimuth_plant",
                &az_plant_overrides,
                Some((0, carried[0][0], carried[1][0])),
            )?,
            elevation_plant: make_carrying(
                &fmus.elevation_plant,
                "elevation_plant",
                &el_plant_overrides,
                Some((1, carried[0][1], carried[1][1])),
            )?,
            azimuth_controller: make(&fmus.azimuth_controller, "azimuth_controller", &az_ctrl_overrides)?,
            elevation_controller: make(&fmus.elevation_controller, "elevation_controller", &el_ctrl_overrides)?,
            wind,
            structure,
            ports,
            step_s: config.step_s,
            start_time_s: start_time,
            steps_done: 0,
            wind_scale,
            lanes: config.lanes,
            pointing: Pointing::of(config),
        };
        Ok(antenna)
    }

    /// The time of the next communication point, s.
    pub fn time_s(&self) -> f64 {
        step_time(self.start_time_s, self.step_s, self.steps_done)
    }

    /// How many threads step this antenna from now on (the configuration's at first).
    pub fn set_lanes(&mut self, lanes: Lanes) {
        self.lanes = lanes;
    }

    /// Exchanges values at the current communication point, records them, and steps every
    /// unit to the next point. On [`Lanes::Two`] every call starts and ends the second thread:
    /// [`Self::run_steps`] is the way to take many steps.
    pub fn step(&mut self, table: &CommandTable, trace: Option<&mut Trace>) -> Result<(), ImportError> {
        self.run_steps(table, 1, trace, &mut |_| {})
    }

    /// Takes `steps` communication steps, recording each point in `trace` if given; `progress`
    /// is called with the fraction done every 1000 steps. With [`Lanes::Two`] the azimuth
    /// lane runs on a second thread; the values exchanged and every unit's sequence of calls
    /// are the same as with one, so the results are equal bit for bit, whatever the lanes.
    pub fn run_steps(
        &mut self,
        table: &CommandTable,
        steps: u64,
        trace: Option<&mut Trace>,
        progress: &mut dyn FnMut(f64),
    ) -> Result<(), ImportError> {
        self.run_lanes(table, steps, trace, self.lanes, progress)
    }

    /// [`Self::run_steps`] on the given lanes.
    fn run_lanes(
        &mut self,
        table: &CommandTable,
        steps: u64,
        trace: Option<&mut Trace>,
        lanes: Lanes,
        progress: &mut dyn FnMut(f64),
    ) -> Result<(), ImportError> {
        let mut master = Master {
            table,
            start_time_s: self.start_time_s,
            step_s: self.step_s,
            first_step: self.steps_done,
            wind_scale: self.wind_scale,
            ports: &self.ports,
            trace,
            pointing: self.pointing.as_ref(),
        };
        let mut azimuth = AzimuthLane {
            plant: &mut self.azimuth_plant,
            controller: &mut self.azimuth_controller,
            structure: self.structure.as_mut(),
            ports: &self.ports,
        };
        let mut elevation = ElevationLane {
            plant: &mut self.elevation_plant,
            controller: &mut self.elevation_controller,
            ports: &self.ports,
        };
        let (done, result) = match lanes {
            Lanes::Two => master.run_on_two_threads(&mut azimuth, &mut elevation, &mut self.wind, steps, progress),
            Lanes::One => master.run_on_one_thread(&mut azimuth, &mut elevation, &mut self.wind, steps, progress),
        };
        self.steps_done += done;
        result
    }

    /// Runs until `end_time_s`, recording every communication point; `progress` is called
    /// with the fraction done every 1000 steps.
    pub fn run(
        &mut self,
        table: &CommandTable,
        end_time_s: f64,
        progress: &mut dyn FnMut(f64),
    ) -> Result<Trace, ImportError> {
        let start = self.time_s();
        let steps = ((end_time_s - start) / self.step_s).round().max(0.0) as u64;
        let mut trace = Trace::default();
        trace.reserve(steps as usize);
        self.run_steps(table, steps, Some(&mut trace), progress)?;
        progress(1.0);
        Ok(trace)
    }
}

/// How many threads step one coupled run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Lanes {
    /// Every unit on the calling thread.
    #[default]
    One,
    /// The azimuth lane (plant, controller, structure) on a second thread while the calling
    /// thread steps the elevation lane and the wind. The two meet once per communication step:
    /// worth it for one long run on an otherwise idle machine, not for many runs side by side
    /// (sweeps and the report already keep every core busy with whole runs), and much slower
    /// than one thread when the second has to wait for a core. Each unit stays on one thread:
    /// a unit called from both moves its memory between the cores at every step (the wind
    /// unit stepped on the lane and exchanged with here made a step 1.4 times as long, README
    /// "Speed").
    Two,
}

/// The wind's loads on the antenna now, scaled by `scale` (torque about azimuth, about
/// elevation, N m; the forces of [`WIND_FORCES`], N, 0 where the wind unit gives none), and the
/// wind speed, m/s.
fn wind_loads(wind: &mut Instance, ports: &Ports, scale: f64) -> Result<([f64; LOADS], f64), ImportError> {
    let mut values = [0.0; 3 + WIND_FORCES.len()];
    let n = ports.wind_out.len();
    wind.get_real(&ports.wind_out, &mut values[..n])?;
    let mut loads = [0.0; LOADS];
    loads[0] = scale * values[0];
    loads[1] = scale * values[1];
    for (value, force) in values[3..n].iter().zip(&ports.wind_forces) {
        loads[2 + force] = scale * value;
    }
    Ok((loads, values[2]))
}

/// What the azimuth lane is given at a communication point once the wind's loads are known.
struct AzimuthLoads {
    wind_torque_nm: f64,
    /// The true elevation, deg (the azimuth load's inertia depends on it).
    elevation_deg: f64,
    /// The structure's inputs (`Ports::structure_in`; the first `len` are used).
    structure: [f64; STRUCTURE_INPUTS],
}

/// The values of an [`AzimuthLoads`] and its time, in the order they cross between threads.
const AZIMUTH_LOADS_WORDS: usize = 3 + STRUCTURE_INPUTS;

impl AzimuthLoads {
    fn to_words(&self, t: f64) -> [f64; AZIMUTH_LOADS_WORDS] {
        let mut words = [0.0; AZIMUTH_LOADS_WORDS];
        words[0] = t;
        words[1] = self.wind_torque_nm;
        words[2] = self.elevation_deg;
        words[3..].copy_from_slice(&self.structure);
        words
    }

    /// The loads and their time.
    fn from_words(words: &[f64; AZIMUTH_LOADS_WORDS]) -> (f64, Self) {
        let loads = AzimuthLoads {
            wind_torque_nm: words[1],
            elevation_deg: words[2],
            structure: std::array::from_fn(|i| words[3 + i]),
        };
        (words[0], loads)
    }
}

/// What the azimuth lane gives back: the values at the point it was given, and the plant's
/// outputs at the next one.
struct AzimuthLaneOutput {
    controller: [f64; 3],
    beam: [f64; 4],
    plant_next: [f64; 7],
}

/// The values of an [`AzimuthLaneOutput`] and the next step's command, in the order they cross
/// between threads.
const AZIMUTH_OUTPUT_WORDS: usize = 18;

impl AzimuthLaneOutput {
    fn to_words(&self, next_command: &Command) -> [f64; AZIMUTH_OUTPUT_WORDS] {
        let c = next_command;
        let mut words = [0.0; AZIMUTH_OUTPUT_WORDS];
        words[0..3].copy_from_slice(&self.controller);
        words[3..7].copy_from_slice(&self.beam);
        words[7..14].copy_from_slice(&self.plant_next);
        words[14..18].copy_from_slice(&[
            c.azimuth_deg,
            c.azimuth_rate_deg_per_s,
            c.elevation_deg,
            c.elevation_rate_deg_per_s,
        ]);
        words
    }

    /// The output and the next step's command.
    fn from_words(words: &[f64; AZIMUTH_OUTPUT_WORDS]) -> (Self, Command) {
        let output = AzimuthLaneOutput {
            controller: std::array::from_fn(|i| words[i]),
            beam: std::array::from_fn(|i| words[3 + i]),
            plant_next: std::array::from_fn(|i| words[7 + i]),
        };
        let command = Command {
            azimuth_deg: words[14],
            azimuth_rate_deg_per_s: words[15],
            elevation_deg: words[16],
            elevation_rate_deg_per_s: words[17],
        };
        (output, command)
    }
}

/// The azimuth plant, its controller and the structure: everything that the azimuth axis and
/// the beam exchange within a step once the wind's loads are known.
///
/// A step is two parts. The controller's exchange and step need only the command and the
/// plant's outputs at the point, not the wind, so on two lanes they are done ahead, while the
/// master is still exchanging with the wind; the plant and the structure wait for the loads.
/// Every unit sees the same calls with the same values in either order.
struct AzimuthLane<'a> {
    plant: &'a mut Instance,
    controller: &'a mut Instance,
    structure: Option<&'a mut Instance>,
    ports: &'a Ports,
}

impl AzimuthLane<'_> {
    /// The controller's exchange and step at a point; its outputs (the two motors' current
    /// commands, the reference position).
    fn control(&mut self, t: f64, h: f64, command: [f64; 2], az: &[f64; 7]) -> Result<[f64; 3], ImportError> {
        let p = self.ports;
        self.controller.set_real(&p.az_ctrl_in, &[command[0], command[1], az[0], az[2], az[3]])?;
        let mut controller = [0.0; 3];
        self.controller.get_real(&p.az_ctrl_out, &mut controller)?;
        self.controller.do_step(t, h)?;
        Ok(controller)
    }

    /// The structure's exchange once the loads are known: the beam's offsets at the point and,
    /// where its modes push back on the drives, the torques it passes to their load side over
    /// the step (azimuth, elevation); `None` leaves the drives the wind's torques.
    fn exchange_structure(&mut self, loads: &AzimuthLoads) -> Result<([f64; 4], Option<[f64; 2]>), ImportError> {
        let p = self.ports;
        let mut beam = [0.0; 4];
        let mut drive = None;
        if let Some(structure) = self.structure.as_deref_mut() {
            structure.set_real(&p.structure_in, &loads.structure[..p.structure_in.len()])?;
            let mut values = [0.0; 6];
            let n = p.structure_out.len();
            structure.get_real(&p.structure_out, &mut values[..n])?;
            beam.copy_from_slice(&values[..4]);
            if p.structure_drive.is_some() {
                drive = Some([values[4], values[5]]);
            }
        }
        Ok((beam, drive))
    }

    /// The plant's and the structure's steps, with the torque on the azimuth load side: the
    /// plant's outputs at the next point.
    fn drive(
        &mut self,
        t: f64,
        h: f64,
        controller: &[f64; 3],
        torque_nm: f64,
        elevation_deg: f64,
    ) -> Result<[f64; 7], ImportError> {
        let p = self.ports;
        self.plant.set_real(&p.az_plant_in, &[controller[0], controller[1], torque_nm, elevation_deg])?;
        self.plant.do_step(t, h)?;
        if let Some(structure) = self.structure.as_deref_mut() {
            structure.do_step(t, h)?;
        }
        let mut plant_next = [0.0; 7];
        self.plant.get_real(&p.az_plant_out, &mut plant_next)?;
        Ok(plant_next)
    }

    /// A whole step on one lane, and the structure's torque on the elevation load side over
    /// it where its modes push back on the drives.
    fn step(
        &mut self,
        t: f64,
        h: f64,
        command: [f64; 2],
        az: &[f64; 7],
        loads: &AzimuthLoads,
    ) -> Result<(AzimuthLaneOutput, Option<f64>), ImportError> {
        let controller = self.control(t, h, command, az)?;
        let (beam, drive) = self.exchange_structure(loads)?;
        let torque_az = drive.map_or(loads.wind_torque_nm, |[az, _]| az);
        let plant_next = self.drive(t, h, &controller, torque_az, loads.elevation_deg)?;
        Ok((AzimuthLaneOutput { controller, beam, plant_next }, drive.map(|[_, el]| el)))
    }
}

/// The elevation plant and its controller; the wind unit is stepped with them (its values
/// were exchanged before the lanes ran).
struct ElevationLane<'a> {
    plant: &'a mut Instance,
    controller: &'a mut Instance,
    ports: &'a Ports,
}

/// What the elevation lane gives back: its controller's outputs at the point, the plant's at
/// the next one.
struct ElevationLaneOutput {
    controller: [f64; 2],
    plant_next: [f64; 5],
}

impl ElevationLane<'_> {
    /// A step of the elevation lane; `torque_nm` gives the torque on the elevation load side
    /// over the step, asked for as late as possible: on two lanes it comes from the structure's
    /// exchange on the other thread, which runs meanwhile, so the controller's and the wind
    /// unit's steps (which need nothing from the plant's step) come first.
    fn step(
        &mut self,
        t: f64,
        h: f64,
        command: [f64; 2],
        el: &[f64; 5],
        torque_nm: impl FnOnce() -> Result<f64, ImportError>,
        wind: &mut Instance,
    ) -> Result<ElevationLaneOutput, ImportError> {
        let p = self.ports;
        self.controller.set_real(&p.el_ctrl_in, &[command[0], command[1], el[0], el[2]])?;
        let mut controller = [0.0; 2];
        self.controller.get_real(&p.el_ctrl_out, &mut controller)?;
        self.controller.do_step(t, h)?;
        wind.do_step(t, h)?;
        self.plant.set_real(&p.el_plant_in, &[controller[0], torque_nm()?])?;
        self.plant.do_step(t, h)?;
        let mut plant_next = [0.0; 5];
        self.plant.get_real(&p.el_plant_out, &mut plant_next)?;
        Ok(ElevationLaneOutput { controller, plant_next })
    }
}

/// A communication point's values once the wind's loads are known: what the lanes are given.
struct Point {
    t: f64,
    /// What the controllers are sent: the target, corrected by the pointing model if any.
    command: Command,
    /// The target the error is judged against.
    target: Command,
    loads: [f64; LOADS],
    wind_speed: f64,
}

/// The time of a run's `n`th communication point, counted in steps, not accumulated, so that
/// long runs do not drift.
fn step_time(start_time_s: f64, step_s: f64, n: u64) -> f64 {
    start_time_s + n as f64 * step_s
}

/// The azimuth lane's thread in [`Master::run_on_two_threads`]: what it owns (its copy of the
/// command table) and the handoffs through which it meets the master.
struct LaneThread<'h> {
    table: CommandTable,
    to_azimuth: &'h Handoff<(), AZIMUTH_LOADS_WORDS>,
    from_azimuth: &'h Handoff<ImportError, AZIMUTH_OUTPUT_WORDS>,
    /// The elevation drive's torque from the structure, where the modes push back on the drives.
    elevation_torque: &'h Handoff<ImportError, 1>,
    start_time_s: f64,
    step_s: f64,
    first_step: u64,
    steps: u64,
    first_az: [f64; 7],
    first_command: [f64; 2],
    /// Whether the structure's modes feed back on the drives (the lane sends the elevation torque).
    feedback: bool,
    /// The pointing model, which the lane applies to the commands it looks up (the master hands
    /// back the targets and corrects them the same way).
    pointing: Option<Pointing>,
}

impl LaneThread<'_> {
    /// Runs the azimuth lane for every step the master hands it, answering each with its outputs
    /// and the next step's command, until the steps are done, the master stops, or it fails.
    fn run(self, azimuth: &mut AzimuthLane) {
        let (table, h, steps, feedback) = (&self.table, self.step_s, self.steps, self.feedback);
        let (from_azimuth, to_azimuth, elevation_torque) = (self.from_azimuth, self.to_azimuth, self.elevation_torque);
        // Tells the master if this thread ends without answering (a panic).
        let _closing = from_azimuth.closing_on_drop();
        let _closing_torque = elevation_torque.closing_on_drop();
        let time = |k: u64| step_time(self.start_time_s, h, self.first_step + k);
        // The controller's part of step k is done before the loads of step k arrive
        // (see `AzimuthLane`); a failure there answers step k.
        let control = |azimuth: &mut AzimuthLane, k: u64, command: [f64; 2], az: &[f64; 7]| {
            azimuth.control(time(k), h, command, az)
        };
        let mut az = self.first_az;
        let mut controller = match control(azimuth, 0, self.first_command, &az) {
            Ok(controller) => controller,
            Err(error) => return from_azimuth.send_failure(error),
        };
        for k in 0..steps {
            // Looked up while the master exchanges with the wind.
            let next_command = if k + 1 < steps { table.at(time(k + 1)) } else { Command::default() };
            let Received::Values(words) = to_azimuth.receive(k + 1) else { return };
            let (t, loads) = AzimuthLoads::from_words(&words);
            let (beam, drive) = match azimuth.exchange_structure(&loads) {
                Ok(exchanged) => exchanged,
                // The master waits for the elevation torque first where it needs it.
                Err(error) if feedback => return elevation_torque.send_failure(error),
                Err(error) => return from_azimuth.send_failure(error),
            };
            if let Some([_, torque_el]) = drive {
                elevation_torque.send(&[torque_el]);
            }
            let torque_az = drive.map_or(loads.wind_torque_nm, |[az, _]| az);
            match azimuth.drive(t, h, &controller, torque_az, loads.elevation_deg) {
                Ok(plant_next) => {
                    let output = AzimuthLaneOutput { controller, beam, plant_next };
                    from_azimuth.send(&output.to_words(&next_command));
                    az = plant_next;
                }
                Err(error) => return from_azimuth.send_failure(error),
            }
            if k + 1 < steps {
                let sent = corrected(self.pointing.as_ref(), next_command);
                match control(azimuth, k + 1, Master::azimuth_command(&sent), &az) {
                    Ok(next) => controller = next,
                    Err(error) => return from_azimuth.send_failure(error),
                }
            }
        }
    }
}

/// The master's side of a run: the clock, the command, the wind exchange, and the trace.
struct Master<'a, 't> {
    table: &'a CommandTable,
    start_time_s: f64,
    step_s: f64,
    /// The antenna's step count when this run began.
    first_step: u64,
    wind_scale: f64,
    ports: &'a Ports,
    trace: Option<&'t mut Trace>,
    pointing: Option<&'a Pointing>,
}

impl Master<'_, '_> {
    /// The time of the `k`th step of this run, counted in steps, not accumulated, so that long
    /// runs do not drift.
    fn time(&self, k: u64) -> f64 {
        step_time(self.start_time_s, self.step_s, self.first_step + k)
    }

    /// The exchange that comes before the lanes: the command, and the wind unit told where the
    /// antenna points and asked for its loads.
    fn point(&self, k: u64, az: &[f64; 7], el: &[f64; 5], wind: &mut Instance) -> Result<Point, ImportError> {
        self.point_commanded(k, self.table.at(self.time(k)), az, el, wind)
    }

    /// [`Self::point`] with the target already looked up.
    fn point_commanded(
        &self,
        k: u64,
        target: Command,
        az: &[f64; 7],
        el: &[f64; 5],
        wind: &mut Instance,
    ) -> Result<Point, ImportError> {
        let t = self.time(k);
        wind.set_real(&self.ports.wind_in, &[az[1], el[1]])?;
        let (loads, wind_speed) = wind_loads(wind, self.ports, self.wind_scale)?;
        let command = corrected(self.pointing, target);
        Ok(Point { t, command, target, loads, wind_speed })
    }

    fn azimuth_command(command: &Command) -> [f64; 2] {
        [command.azimuth_deg, command.azimuth_rate_deg_per_s]
    }

    /// The azimuth lane's values at a point: the structure's inputs gathered in the order of
    /// `Ports::structure_in`.
    fn azimuth_loads(ports: &Ports, point: &Point, az: &[f64; 7], el: &[f64; 5]) -> AzimuthLoads {
        let mut sources = [0.0; STRUCTURE_INPUTS];
        sources[..LOADS].copy_from_slice(&point.loads);
        sources[LOADS..].copy_from_slice(&[az[6], el[4], el[1]]);
        let mut structure = [0.0; STRUCTURE_INPUTS];
        for (value, (_, source)) in structure.iter_mut().zip(&ports.structure_sources) {
            *value = sources[*source];
        }
        AzimuthLoads { wind_torque_nm: point.loads[0], elevation_deg: el[1], structure }
    }

    fn elevation_command(point: &Point) -> [f64; 2] {
        [point.command.elevation_deg, point.command.elevation_rate_deg_per_s]
    }

    fn record(&mut self, point: &Point, az: &[f64; 7], el: &[f64; 5], a: &AzimuthLaneOutput, e: &ElevationLaneOutput) {
        let Some(trace) = self.trace.as_deref_mut() else { return };
        trace.time_s.push(point.t);
        trace.command_azimuth_deg.push(point.target.azimuth_deg);
        trace.command_elevation_deg.push(point.target.elevation_deg);
        if self.pointing.is_some() {
            trace.pointing_correction_deg.push([
                point.command.azimuth_deg - point.target.azimuth_deg,
                point.command.elevation_deg - point.target.elevation_deg,
            ]);
        }
        trace.azimuth_deg.push(az[1]);
        trace.elevation_deg.push(el[1]);
        trace.encoder_azimuth_deg.push(az[0]);
        trace.encoder_elevation_deg.push(el[0]);
        trace.reference_azimuth_deg.push(a.controller[2]);
        trace.reference_elevation_deg.push(e.controller[1]);
        trace.wind_speed_m_s.push(if self.wind_scale > 0.0 { point.wind_speed } else { 0.0 });
        trace.wind_torque_azimuth_nm.push(point.loads[0]);
        trace.wind_torque_elevation_nm.push(point.loads[1]);
        trace.current_azimuth_a.push([az[4], az[5]]);
        trace.current_elevation_a.push(el[3]);
        trace.beam_offset_arcsec.push([a.beam[0], a.beam[1]]);
        trace.beam_offset_static_arcsec.push([a.beam[2], a.beam[3]]);
    }

    /// Both plants' outputs where the run begins.
    fn plant_outputs(
        &self,
        azimuth: &mut AzimuthLane,
        elevation: &mut ElevationLane,
    ) -> Result<([f64; 7], [f64; 5]), ImportError> {
        let mut az = [0.0; 7];
        azimuth.plant.get_real(&self.ports.az_plant_out, &mut az)?;
        let mut el = [0.0; 5];
        elevation.plant.get_real(&self.ports.el_plant_out, &mut el)?;
        Ok((az, el))
    }

    /// Every lane on this thread. Returns the steps completed and how the run ended.
    fn run_on_one_thread(
        &mut self,
        azimuth: &mut AzimuthLane,
        elevation: &mut ElevationLane,
        wind: &mut Instance,
        steps: u64,
        progress: &mut dyn FnMut(f64),
    ) -> (u64, Result<(), ImportError>) {
        let mut done = 0;
        let mut body = || -> Result<(), ImportError> {
            let (mut az, mut el) = self.plant_outputs(azimuth, elevation)?;
            let h = self.step_s;
            for k in 0..steps {
                let point = self.point(k, &az, &el, wind)?;
                let command = Self::azimuth_command(&point.command);
                let loads = Self::azimuth_loads(self.ports, &point, &az, &el);
                let (a, drive_el) = azimuth.step(point.t, h, command, &az, &loads)?;
                let torque_el = || Ok(drive_el.unwrap_or(point.loads[1]));
                let e = elevation.step(point.t, h, Self::elevation_command(&point), &el, torque_el, wind)?;
                self.record(&point, &az, &el, &a, &e);
                (az, el) = (a.plant_next, e.plant_next);
                done = k + 1;
                if k % 1000 == 0 {
                    progress(k as f64 / steps as f64);
                }
            }
            Ok(())
        };
        let result = body();
        (done, result)
    }

    /// The azimuth lane on a second thread, the rest on this one; they meet at every point
    /// through two [`Handoff`]s. Returns the steps completed and how the run ended.
    fn run_on_two_threads(
        &mut self,
        azimuth: &mut AzimuthLane,
        elevation: &mut ElevationLane,
        wind: &mut Instance,
        steps: u64,
        progress: &mut dyn FnMut(f64),
    ) -> (u64, Result<(), ImportError>) {
        let (mut az, mut el) = match self.plant_outputs(azimuth, elevation) {
            Ok(outputs) => outputs,
            Err(e) => return (0, Err(e)),
        };
        let h = self.step_s;
        let to_azimuth: Handoff<(), AZIMUTH_LOADS_WORDS> = Handoff::new();
        let from_azimuth: Handoff<ImportError, AZIMUTH_OUTPUT_WORDS> = Handoff::new();
        // Where the structure's modes push back on the drives, the elevation plant's load comes
        // from the structure's exchange on the azimuth lane, handed over within the step.
        let feedback = self.ports.structure_drive.is_some();
        let elevation_torque: Handoff<ImportError, 1> = Handoff::new();
        let first_az = az;
        let (start_time_s, first_step) = (self.start_time_s, self.first_step);
        let mut command = self.table.at(self.time(0));
        let first_command = Self::azimuth_command(&corrected(self.pointing, command));
        // The azimuth lane looks up the commands (a table is not shared between threads): the
        // next step's goes back with its outputs, so that the master has one lookup less.
        let worker_table = self.table.clone();
        // Everything the lane reads at every step lives on its own thread (moved into it):
        // read through references into this thread's stack, which this thread writes at every
        // step, the same values kept the cache lines moving between the cores, and the lane's
        // steps took half again as long as on one thread.
        let lane_ports = self.ports.clone();
        let mut lane = AzimuthLane {
            plant: &mut *azimuth.plant,
            controller: &mut *azimuth.controller,
            structure: azimuth.structure.as_deref_mut(),
            ports: &lane_ports,
        };
        std::thread::scope(|scope| {
            let (to_azimuth, from_azimuth, elevation_torque) = (&to_azimuth, &from_azimuth, &elevation_torque);
            let thread = LaneThread {
                table: worker_table,
                to_azimuth,
                from_azimuth,
                elevation_torque,
                start_time_s,
                step_s: h,
                first_step,
                steps,
                first_az,
                first_command,
                feedback,
                pointing: self.pointing.cloned(),
            };
            scope.spawn(move || thread.run(&mut lane));
            let _closing = to_azimuth.closing_on_drop();
            let mut done = 0;
            let mut body = || -> Result<(), ImportError> {
                for k in 0..steps {
                    let point = match self.point_commanded(k, command, &az, &el, wind) {
                        Ok(point) => point,
                        Err(e) => {
                            to_azimuth.send_stop();
                            return Err(e);
                        }
                    };
                    to_azimuth.send(&Self::azimuth_loads(self.ports, &point, &az, &el).to_words(point.t));
                    // Set when the azimuth lane failed before its elevation torque: it has
                    // ended, and answers nothing more.
                    let lane_failed = std::cell::Cell::new(false);
                    let torque_el = || {
                        if !feedback {
                            return Ok(point.loads[1]);
                        }
                        match elevation_torque.receive(k + 1) {
                            Received::Values([torque]) => Ok(torque),
                            Received::Failed(error) => {
                                lane_failed.set(true);
                                Err(error)
                            }
                            // The lane ended on a failure it reported with its outputs (its
                            // controller's, which runs a step ahead).
                            Received::Gone => match from_azimuth.receive(k + 1) {
                                Received::Failed(error) => {
                                    lane_failed.set(true);
                                    Err(error)
                                }
                                _ => panic!("the azimuth lane answers every point it is given or panics"),
                            },
                            Received::Stop => panic!("the azimuth lane never asks the master to stop"),
                        }
                    };
                    let e = elevation.step(point.t, h, Self::elevation_command(&point), &el, torque_el, wind);
                    if lane_failed.get() {
                        return e.map(|_| ());
                    }
                    let a = match from_azimuth.receive(k + 1) {
                        Received::Values(words) => {
                            let (output, next_command) = AzimuthLaneOutput::from_words(&words);
                            command = next_command;
                            Ok(output)
                        }
                        Received::Failed(error) => Err(error),
                        Received::Stop | Received::Gone => {
                            panic!("the azimuth lane answers every point it is given or panics")
                        }
                    };
                    let (a, e) = match (a, e) {
                        (Ok(a), Ok(e)) => (a, e),
                        (Err(error), _) => return Err(error),
                        (Ok(_), Err(error)) => {
                            to_azimuth.send_stop();
                            return Err(error);
                        }
                    };
                    self.record(&point, &az, &el, &a, &e);
                    (az, el) = (a.plant_next, e.plant_next);
                    done = k + 1;
                    if k % 1000 == 0 {
                        progress(k as f64 / steps as f64);
                    }
                }
                to_azimuth.send_stop();
                Ok(())
            };
            let result = body();
            (done, result)
        })
    }
}
