//! The structure as an FMI 2.0 co-simulation FMU (`Structure`): loads on the structure in,
//! beam pointing offsets relative to the encoder-measured axes out.

use std::path::PathBuf;

use fmu_runtime::package::{default_parameter_file, FmuSpec};
use fmu_runtime::{declare_variables, Context, DefaultExperiment, Model, ModelInfo, Notes, StateError, Values};
use serde::{Deserialize, Serialize};

use crate::dynamics::{ModalState, ModalStructure, StructureError, ARCSEC_PER_RAD};
use crate::modes::{parse_modes, read_modes, Mode, ModesError, DEFAULT_MODES, DEFAULT_MODES_FILE, LOADS};

/// Why the structure FMU refuses a call; logged with `fmi2Error`.
#[derive(Debug, thiserror::Error)]
pub enum StructureFmuError {
    /// The modes file named by `modes_file` cannot be read or holds no valid modes.
    #[error(transparent)]
    Modes(#[from] ModesError),
    /// A step left the finite numbers.
    #[error(transparent)]
    Structure(#[from] StructureError),
    #[error("too many modes")]
    TooManyModes { count: usize },
    /// A step before fmi2ExitInitializationMode built the structure.
    #[error("the structure model is not initialised")]
    NotInitialised,
}

/// Largest load torque about an axis, N m (either sign): some hundred times the survival wind
/// torque of a 13.5 m dish (estimate, order 1e6 N m), as the plants declare it.
pub const MAX_LOAD_TORQUE: f64 = 1e8;

/// Largest wind force on the dish, N (either sign): some hundred times the survival drag of a
/// 13.5 m dish (estimate, order 1e6 N).
pub const MAX_LOAD_FORCE: f64 = 1e8;

/// Largest axis speed, deg/s (either sign): some fifty times a fast slew.
pub const MAX_AXIS_SPEED: f64 = 100.0;

/// What the drive torques depend on within a step: the loads, the elevation (which sets the
/// frequency of a mode that changes with it) and then the axes' speeds.
const DRIVE_TORQUE_INPUTS: &[u32] = &[
    StructureVar::AzTorque as u32,
    StructureVar::ElTorque as u32,
    StructureVar::DishForce as u32,
    StructureVar::AxialForce as u32,
    StructureVar::LateralForce as u32,
    StructureVar::LiftForce as u32,
    StructureVar::Elevation as u32,
    StructureVar::AzSpeed as u32,
    StructureVar::ElSpeed as u32,
];

/// What the quasi-static offsets depend on within a step: the loads and the elevation (the
/// inertia that the current step's accelerations load the modes with is `K / w^2` there).
const OFFSET_INPUTS: &[u32] = DRIVE_TORQUE_INPUTS.split_at(7).0;

/// The elevation range the structure takes, deg: the azimuth plant's.
const ELEVATION_RANGE_DEG: (f64, f64) = (-10.0, 120.0);

declare_variables! {
    /// Variables of the structure FMU. Loads in SI, beam offsets in arcseconds.
    pub enum StructureVar {
        AzTorque = Var::real("torque.azimuth", "N.m").input().start(0.0).min(-MAX_LOAD_TORQUE).max(MAX_LOAD_TORQUE)
            .description("Load torque on the structure about the azimuth axis (the wind's yawing moment; with a drive-excited mode, also the drive's pinion reaction); positive drives positive azimuth."),
        ElTorque = Var::real("torque.elevation", "N.m").input().start(0.0).min(-MAX_LOAD_TORQUE).max(MAX_LOAD_TORQUE)
            .description("Load torque on the structure about the elevation axis (the wind's pitching moment; with a drive-excited mode, also the jackscrew reaction); positive raises the dish."),
        DishForce = Var::real("force.dish", "N").input().start(0.0).min(-MAX_LOAD_FORCE).max(MAX_LOAD_FORCE)
            .description("Wind drag on the dish along the wind, whatever its direction relative to the antenna (the Wind FMU's force.drag), weighed by each mode's dish_force. One number cannot weigh a drag whose direction in the antenna's frame turns with the yaw: modes from a finite-element model should take force.axial and force.lateral instead (a mode may not take both). The default modes take no force."),
        // The structure starts at rest in the static deflection under its start loads, seen at
        // the start elevation: the initial offsets depend on those inputs, the later ones only
        // through the modes' state.
        BeamAz = Var::real("beam.azimuth_offset", "arcsec").output().initially_depends_on(OFFSET_INPUTS)
            .description("Beam (RF boresight) pointing offset in azimuth relative to the encoder-measured axis, on the sky (cross-elevation): the sum over the modes of (beam_azimuth + beam_azimuth_rotation cos(elevation)) times the modal coordinate, with the elevation input held over the step just taken (a rotation about the azimuth axis moves the beam on the sky by the angle times cos(elevation))."),
        BeamEl = Var::real("beam.elevation_offset", "arcsec").output().initially_depends_on(OFFSET_INPUTS)
            .description("Beam pointing offset in elevation relative to the encoder-measured axis: the sum over the modes of beam_elevation times the modal coordinate."),
        BeamAzStatic = Var::real("beam.azimuth_offset_static", "arcsec").output().depends_on(OFFSET_INPUTS)
            .description("Quasi-static part of beam.azimuth_offset: where it settles under the current loads held for ever (static compliance times load)."),
        BeamElStatic = Var::real("beam.elevation_offset_static", "arcsec").output().depends_on(OFFSET_INPUTS)
            .description("Quasi-static part of beam.elevation_offset: where it settles under the current loads held for ever (static compliance times load)."),
        ModesFile = Var::string("modes_file").parameter().start_string(DEFAULT_MODES_FILE)
            .description("Modes file (name = value lines: mode<k>.frequency, damping, stiffness, azimuth_torque, elevation_torque, dish_force, beam_azimuth, beam_elevation, and optionally axial_force, lateral_force, lift_force, which default to 0, and horizon_frequency, which defaults to frequency; docs/structure-model.md); relative paths are looked up in the resources folder. The shipped structure_modes.params holds one estimated 6 Hz mode per axis."),
        ModeCount = Var::integer("mode_count").calculated_parameter()
            .description("Number of modes read from modes_file."),
        AzSpeed = Var::real("axis.azimuth_speed", "deg/s").input().start(0.0).min(-MAX_AXIS_SPEED).max(MAX_AXIS_SPEED)
            .description("Load-side azimuth speed (the plant's axis.speed): its change over each step is the azimuth acceleration whose inertial load the modes feel, -(stiffness / (2 pi frequency)^2) times azimuth_torque times the acceleration (docs/structure-model.md). Leave it at 0 for wind loads alone."),
        ElSpeed = Var::real("axis.elevation_speed", "deg/s").input().start(0.0).min(-MAX_AXIS_SPEED).max(MAX_AXIS_SPEED)
            .description("Load-side elevation speed (the plant's axis.speed): as axis.azimuth_speed, through elevation_torque."),
        AxialForce = Var::real("force.axial", "N").input().start(0.0).min(-MAX_LOAD_FORCE).max(MAX_LOAD_FORCE)
            .description("Horizontal wind force on the dish along the horizontal projection of the boresight (the Wind FMU's force.axial), positive pushing the dish backwards, from its reflector face towards its back: a wind blowing into the face (yaw 0) gives +drag. Weighed by each mode's axial_force (default 0)."),
        LateralForce = Var::real("force.lateral", "N").input().start(0.0).min(-MAX_LOAD_FORCE).max(MAX_LOAD_FORCE)
            .description("Horizontal wind force on the dish across the boresight (cross-elevation; the Wind FMU's force.lateral), positive pushing the dish towards increasing azimuth (clockwise seen from above, to the right seen from behind the dish looking out along the boresight). Weighed by each mode's lateral_force (default 0)."),
        LiftForce = Var::real("force.lift", "N").input().start(0.0).min(-MAX_LOAD_FORCE).max(MAX_LOAD_FORCE)
            .description("Vertical wind force on the dish (the Wind FMU's force.lift), positive up. Weighed by each mode's lift_force (default 0)."),
        TakesDishForce = Var::boolean("takes.force.dish").calculated_parameter()
            .description("True when a mode of modes_file takes force.dish (a non-zero dish_force). When false the input changes nothing, and a master may leave it unset: the shipped modes take no force."),
        TakesAxialForce = Var::boolean("takes.force.axial").calculated_parameter()
            .description("True when a mode of modes_file takes force.axial (a non-zero axial_force); when false a master may leave that input unset."),
        TakesLateralForce = Var::boolean("takes.force.lateral").calculated_parameter()
            .description("True when a mode of modes_file takes force.lateral (a non-zero lateral_force); when false a master may leave that input unset."),
        TakesLiftForce = Var::boolean("takes.force.lift").calculated_parameter()
            .description("True when a mode of modes_file takes force.lift (a non-zero lift_force); when false a master may leave that input unset."),
        DriveTorqueAz = Var::real("drive_torque.azimuth", "N.m").output().depends_on(DRIVE_TORQUE_INPUTS)
            .description("Torque the structure passes to the azimuth drive's load side, mean over a coming step as long as the last: torque.azimuth less, through each mode's azimuth_torque participation, the force that accelerates the mode's moving part (for one mode of participation 1, its spring and damper). To couple the modes both ways, connect it to the azimuth plant's load.disturbance_torque in place of the wind's torque and lower the plant's load inertia by modal_inertia.azimuth (docs/structure-model.md)."),
        DriveTorqueEl = Var::real("drive_torque.elevation", "N.m").output().depends_on(DRIVE_TORQUE_INPUTS)
            .description("As drive_torque.azimuth, about the elevation axis: to the elevation plant's load.disturbance_torque, with its load inertia lowered by modal_inertia.elevation."),
        ModalInertiaAz = Var::real("modal_inertia.azimuth", "kg.m2").calculated_parameter()
            .description("Inertia the modes carry about the azimuth axis with the dish at the zenith (at every elevation when no mode changes with elevation), the sum over the modes of azimuth_torque^2 stiffness / (2 pi frequency)^2: what a plant coupled to drive_torque.azimuth leaves out of its load inertia. Between the zenith and the horizon it turns as modal_inertia.azimuth_horizon cos^2(elevation) + modal_inertia.azimuth sin^2(elevation)."),
        ModalInertiaEl = Var::real("modal_inertia.elevation", "kg.m2").calculated_parameter()
            .description("Inertia the modes carry about the elevation axis with the dish at the zenith, as modal_inertia.azimuth with elevation_torque."),
        Elevation = Var::real("axis.elevation", "deg").input().start(45.0).min(ELEVATION_RANGE_DEG.0).max(ELEVATION_RANGE_DEG.1)
            .description("Elevation of the dish (the elevation plant's axis.position): sets the frequency of a mode that changes with elevation (horizon_frequency in the modes file), held at the centre of each 0.25 deg cell, and projects the modes' rotations about the azimuth axis (beam_azimuth_rotation) on the sky with its cosine. Changes nothing when takes.axis.elevation is false."),
        ModalInertiaAzHorizon = Var::real("modal_inertia.azimuth_horizon", "kg.m2").calculated_parameter()
            .description("Inertia the modes carry about the azimuth axis with the dish at the horizon (elevation 0), as modal_inertia.azimuth with each mode's horizon_frequency; equal to modal_inertia.azimuth when no mode changes with elevation."),
        ModalInertiaElHorizon = Var::real("modal_inertia.elevation_horizon", "kg.m2").calculated_parameter()
            .description("Inertia the modes carry about the elevation axis with the dish at the horizon, as modal_inertia.azimuth_horizon with elevation_torque."),
        TakesElevation = Var::boolean("takes.axis.elevation").calculated_parameter()
            .description("True when a mode of modes_file changes with elevation (a horizon_frequency other than its frequency) or rotates the beam about the azimuth axis (a non-zero beam_azimuth_rotation, projected on the sky with cos(elevation)). When false the input axis.elevation changes nothing, and a master may leave it unset. The shipped modes' azimuth twist needs it."),
    }
}

/// The structure FMU.
pub struct StructureModel {
    /// Where the instance runs: a restored state reads the modes file again from it.
    context: Context,
    structure: Option<ModalStructure>,
}

impl StructureModel {
    /// The loads in the order of [`LOADS`].
    #[inline]
    fn loads(values: &Values<StructureVar>) -> [f64; LOADS] {
        [
            values.real(StructureVar::AzTorque),
            values.real(StructureVar::ElTorque),
            values.real(StructureVar::DishForce),
            values.real(StructureVar::AxialForce),
            values.real(StructureVar::LateralForce),
            values.real(StructureVar::LiftForce),
        ]
    }

    /// The modes named by `modes_file`: relative names are looked up in the resources folder;
    /// the shipped default is also built in, so the FMU works without one.
    fn modes(values: &Values<StructureVar>, context: &Context) -> Result<Vec<Mode>, ModesError> {
        let name = values.string(StructureVar::ModesFile);
        let builtin = || parse_modes(DEFAULT_MODES, DEFAULT_MODES_FILE);
        if name.is_empty() {
            return builtin();
        }
        let path = PathBuf::from(name);
        let path = match (&context.resource_dir, path.is_absolute()) {
            (Some(dir), false) => dir.join(path),
            (None, false) if name == DEFAULT_MODES_FILE => return builtin(),
            _ => path,
        };
        read_modes(&path)
    }

    /// The elevation the modes are taken at, deg.
    #[inline]
    fn elevation(values: &Values<StructureVar>) -> f64 {
        values.real(StructureVar::Elevation)
    }

    /// The axes' speeds, rad/s.
    #[inline]
    fn speeds(values: &Values<StructureVar>) -> [f64; 2] {
        [values.real(StructureVar::AzSpeed).to_radians(), values.real(StructureVar::ElSpeed).to_radians()]
    }

    fn write_offsets(&self, values: &mut Values<StructureVar>) {
        let Some(structure) = &self.structure else { return };
        let [az, el] = structure.beam_offset();
        values.set_real(StructureVar::BeamAz, az * ARCSEC_PER_RAD);
        values.set_real(StructureVar::BeamEl, el * ARCSEC_PER_RAD);
    }
}

impl Model for StructureModel {
    type Var = StructureVar;
    type Error = StructureFmuError;

    fn info() -> ModelInfo {
        ModelInfo {
            model_identifier: "Structure",
            model_name: "Structure",
            description: "Modal model of the antenna structure between the drives' load side (the encoders) and the RF beam: loads (torques about the axes, wind forces on the dish) in, beam pointing offsets relative to the encoder-measured axes out. Modes (frequency, damping, modal stiffness, participation factors) from a replaceable file; exact zero-order hold, so results do not depend on the communication step for piecewise-constant loads.",
            author: "MeerKAT antenna positioner reference model contributors",
            version: env!("CARGO_PKG_VERSION"),
            default_experiment: DefaultExperiment { start_time: 0.0, stop_time: 10.0, step_size: 1e-3 },
        }
    }

    fn new(_values: &Values<StructureVar>, context: &Context) -> Result<Self, StructureFmuError> {
        Ok(StructureModel { context: context.clone(), structure: None })
    }

    /// The structure starts at rest in the static deflection under the loads it has at the end
    /// of initialisation, so that a run with a mean wind does not begin with a ringing mode.
    fn initialize(
        &mut self,
        values: &mut Values<StructureVar>,
        context: &Context,
        _notes: &mut Notes,
    ) -> Result<(), StructureFmuError> {
        let modes = Self::modes(values, context)?;
        let count = i32::try_from(modes.len()).map_err(|_| StructureFmuError::TooManyModes { count: modes.len() })?;
        // Which forces the modes take (participations 2.. of `LOADS`), so that a master can
        // leave the others unset.
        let takes = |load: usize| modes.iter().any(|mode| mode.participation[load] != 0.0);
        values.set_boolean(StructureVar::TakesDishForce, takes(2));
        values.set_boolean(StructureVar::TakesAxialForce, takes(3));
        values.set_boolean(StructureVar::TakesLateralForce, takes(4));
        values.set_boolean(StructureVar::TakesLiftForce, takes(5));
        let takes_elevation = modes.iter().any(|m| m.varies_with_elevation() || m.beam_azimuth_rotation != 0.0);
        values.set_boolean(StructureVar::TakesElevation, takes_elevation);
        let mut structure = ModalStructure::at_rest(modes, &Self::loads(values));
        structure.set_elevation(Self::elevation(values));
        let ([az_inertia, el_inertia], [az_horizon, el_horizon]) = structure.modal_inertias_zenith_and_horizon();
        values.set_real(StructureVar::ModalInertiaAz, az_inertia);
        values.set_real(StructureVar::ModalInertiaEl, el_inertia);
        values.set_real(StructureVar::ModalInertiaAzHorizon, az_horizon);
        values.set_real(StructureVar::ModalInertiaElHorizon, el_horizon);
        self.structure = Some(structure);
        values.set_integer(StructureVar::ModeCount, count);
        self.write_offsets(values);
        self.update_feedthrough(values);
        Ok(())
    }

    fn do_step(
        &mut self,
        values: &mut Values<StructureVar>,
        _time: f64,
        step: f64,
        _notes: &mut Notes,
    ) -> Result<(), StructureFmuError> {
        // Not `ok_or`: it would build the error at every step and drop it again.
        let Some(structure) = self.structure.as_mut() else { return Err(StructureFmuError::NotInitialised) };
        structure.set_elevation(Self::elevation(values));
        structure.step(&Self::loads(values), &Self::speeds(values), step)?;
        self.write_offsets(values);
        Ok(())
    }

    fn update_feedthrough(&mut self, values: &mut Values<StructureVar>) {
        let Some(structure) = &mut self.structure else { return };
        structure.set_elevation(Self::elevation(values));
        let ([az, el], [torque_az, torque_el]) = structure.feedthrough(&Self::loads(values), &Self::speeds(values));
        values.set_real(StructureVar::BeamAzStatic, az * ARCSEC_PER_RAD);
        values.set_real(StructureVar::BeamElStatic, el * ARCSEC_PER_RAD);
        values.set_real(StructureVar::DriveTorqueAz, torque_az);
        values.set_real(StructureVar::DriveTorqueEl, torque_el);
    }

    /// A new modes file is read at once, so that a bad one is refused by the call that names it.
    fn string_changed(
        &mut self,
        var: StructureVar,
        values: &mut Values<StructureVar>,
        context: &Context,
    ) -> Result<(), StructureFmuError> {
        if var == StructureVar::ModesFile {
            Self::modes(values, context)?;
        }
        Ok(())
    }

    type State = StructureState;

    fn save_state(&self) -> StructureState {
        match &self.structure {
            None => StructureState::NotInitialized,
            Some(structure) => StructureState::Initialized(structure.save_state()),
        }
    }

    fn save_state_into(&self, state: &mut StructureState) {
        match (&self.structure, state) {
            (Some(structure), StructureState::Initialized(kept)) => structure.save_state_into(kept),
            (_, state) => *state = self.save_state(),
        }
    }

    fn load_state(&mut self, state: StructureState, values: &Values<StructureVar>) -> Result<(), StateError> {
        let StructureState::Initialized(saved) = state else {
            self.structure = None;
            return Ok(());
        };
        let modes = Self::modes(values, &self.context).map_err(StateError::model)?;
        let mut structure = ModalStructure::at_rest(modes, &Self::loads(values));
        structure.set_elevation(Self::elevation(values));
        structure.load_state(saved).map_err(StateError::model)?;
        self.structure = Some(structure);
        Ok(())
    }
}

/// The structure model's part of an FMU state.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum StructureState {
    NotInitialized,
    /// Every mode's coordinate and velocity.
    Initialized(ModalState),
}

/// The FMUs this crate ships: `Structure`, with its default modes file and parameters.
pub fn fmus() -> Vec<FmuSpec> {
    vec![FmuSpec::of::<StructureModel>("fmu_structure_ffi", || {
        vec![
            ("defaults.params".into(), default_parameter_file::<StructureModel>().into_bytes()),
            (DEFAULT_MODES_FILE.into(), DEFAULT_MODES.as_bytes().to_vec()),
        ]
    })]
}
