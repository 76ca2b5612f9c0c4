//! The packaged plant FMU (`AzimuthPlant.fmu`) as the validate tool's simulator, loaded through
//! the FMI 2.0 C ABI by `fmu_import`, exactly as any master loads it.
//!
//! A [`Session`] is one FMU instance configured with one parameter set (written as a parameter
//! file and loaded through the FMU's `parameter_file` string variable, the same file the tool
//! writes as its corrected model). Each output-error window starts the instance from the
//! measured state: the FMU's own initialisation can only put the axis at rest
//! (`initial_position`), so the tool takes the state the FMU serialises after initialisation
//! (`fmi2SerializeFMUstate`), writes the measured positions, speeds, twist, currents and the
//! recent command history into it, and restores it with `fmi2DeSerializeFMUstate` and
//! `fmi2SetFMUstate`. The state is decoded and encoded as the FMU's own serde types
//! (`fmu_runtime::InstanceState` of `fmu_plant::fmi::AzimuthPlantModel`, whose model part is a
//! `fmu_plant::DriveState`; `docs/plant-model.md`, section 7): header, variable values, then the
//! drive's time, grid cell, state vector `[p_L, v_L, (d_k, v_Mk, i_k, beta_k) per path]` (motor
//! side), compensation term, body motions, meshes, delay lines and friction anchors. The
//! runtime checks the state format version and the model's GUID, so a change of layout is an
//! error, not a wrong simulation. One instance serves all windows of a parameter set;
//! restoring a state costs one plant construction (tens of microseconds).

use super::output_error::{PlantSimulator, SimulatedOutputs, SimulatorError, WindowJob, WindowStart};
use super::parameters::{fmu_parameter_text, FmuConfig, ParameterSet};
use fmu_import::{Fmu, ImportError, Instance};
use fmu_plant::fmi::{AzVar, AzimuthPlantModel};
use fmu_plant::{Mesh, Motion};
use fmu_runtime::{InstanceState, StateError};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

/// Why the packaged plant FMU could not be opened, configured or stepped. Clone (the I/O
/// errors are shared through an `Arc`) so that a simulation error can be cached and repeated.
#[derive(Debug, Clone, thiserror::Error)]
pub enum PlantFmuError {
    #[error("{} is missing: package the FMUs first (cargo xtask package)", path.display())]
    Missing { path: PathBuf },
    #[error("cannot open {}: {source}", path.display())]
    Open { path: PathBuf, source: ImportError },
    #[error("{} is {model_identifier}, not the AzimuthPlant FMU", path.display())]
    NotThePlant { path: PathBuf, model_identifier: String },
    #[error("cannot write {}: {source}", path.display())]
    WriteParameterFile { path: PathBuf, source: Arc<std::io::Error> },
    #[error("cannot find {}: {source}", path.display())]
    FindParameterFile { path: PathBuf, source: Arc<std::io::Error> },
    #[error("the parameter file path {} is not UTF-8", path.display())]
    ParameterFileNotUtf8 { path: PathBuf },
    #[error("the plant FMU rejects the parameter set: {0}")]
    ParametersRejected(ImportError),
    #[error("the plant FMU does not initialise: {0}")]
    Initialise(ImportError),
    #[error("unexpected plant FMU state: {0}")]
    StateDecode(StateError),
    #[error("the plant FMU state has no plant (not initialised)")]
    StateWithoutPlant,
    #[error("the plant FMU state has {states} states and {paths} paths; this tool knows {STATES} and {PATHS}")]
    StateLayout { states: usize, paths: usize },
    #[error("the plant FMU rejects the window's start state: {0}")]
    StartStateRejected(ImportError),
    #[error("plant FMU step {step}: {source}")]
    Step { step: usize, source: ImportError },
    /// Any other call of the FMU (a variable lookup, an instantiation, a get or set) failed.
    #[error(transparent)]
    Call(#[from] ImportError),
}

impl From<PlantFmuError> for SimulatorError {
    fn from(error: PlantFmuError) -> Self {
        SimulatorError::Fmu(Arc::new(error))
    }
}

const PATHS: usize = 2;
const STATES: usize = 2 + 4 * PATHS;

static FILE_COUNTER: AtomicU64 = AtomicU64::new(0);

/// The plant FMU, unpacked and loaded.
pub struct PlantFmu {
    fmu: Fmu,
}

impl PlantFmu {
    /// Where `cargo xtask package` writes the azimuth plant.
    pub fn default_path() -> PathBuf {
        antenna_fmus::fmu_path("AzimuthPlant")
    }

    pub fn open(path: &Path) -> Result<PlantFmu, PlantFmuError> {
        if !path.is_file() {
            return Err(PlantFmuError::Missing { path: path.to_path_buf() });
        }
        let fmu = Fmu::open(path).map_err(|source| PlantFmuError::Open { path: path.to_path_buf(), source })?;
        if fmu.description.model_identifier != "AzimuthPlant" {
            return Err(PlantFmuError::NotThePlant {
                path: path.to_path_buf(),
                model_identifier: fmu.description.model_identifier.clone(),
            });
        }
        Ok(PlantFmu { fmu })
    }

    /// An instance configured by a parameter-file text (written to a temporary file, loaded
    /// through `parameter_file`, removed).
    pub fn session(&self, parameter_text: &str) -> Result<Session, PlantFmuError> {
        let path = std::env::temp_dir().join(format!(
            "validate-{}-{}.params",
            std::process::id(),
            FILE_COUNTER.fetch_add(1, Ordering::Relaxed)
        ));
        std::fs::write(&path, parameter_text)
            .map_err(|e| PlantFmuError::WriteParameterFile { path: path.clone(), source: Arc::new(e) })?;
        let session = self.session_from_file(&path);
        let _ = std::fs::remove_file(&path);
        session
    }

    /// An instance configured by a parameter file on disk (absolute path).
    pub fn session_from_file(&self, path: &Path) -> Result<Session, PlantFmuError> {
        let description = &self.fmu.description;
        let vr = |name: &str| description.vr(name);
        let mut instance = self.fmu.instantiate("validate", false)?;
        let absolute = std::fs::canonicalize(path)
            .map_err(|e| PlantFmuError::FindParameterFile { path: path.to_path_buf(), source: Arc::new(e) })?;
        let file = absolute.to_str().ok_or_else(|| PlantFmuError::ParameterFileNotUtf8 { path: absolute.clone() })?;
        instance.set_string(&[vr("parameter_file")?], &[file]).map_err(PlantFmuError::ParametersRejected)?;
        instance.initialize(0.0, &[]).map_err(PlantFmuError::Initialise)?;
        let parameters = [
            vr("gear.ratio")?,
            vr("pinion1.backlash")?,
            vr("pinion2.backlash")?,
            vr("pinion1.stiffness")?,
            vr("pinion2.stiffness")?,
            vr("motor1.torque_constant")?,
            vr("motor2.torque_constant")?,
            vr("motor1.torque_constant_scale")?,
            vr("motor2.torque_constant_scale")?,
        ];
        let mut values = [0.0; 9];
        instance.get_real(&parameters, &mut values)?;
        let template = StateTemplate::capture(&mut instance)?;
        Ok(Session {
            instance,
            template,
            gear_ratio: values[0],
            backlash_motor_rad: [values[1], values[2]].map(|b| b * std::f64::consts::PI / (180.0 * 3600.0) * values[0]),
            path_stiffness: [values[3], values[4]],
            axis_torque_per_input: [values[0] * values[5] * values[7], values[0] * values[6] * values[8]],
            inputs: [vr("motor1.current_command")?, vr("motor2.current_command")?, vr("load.disturbance_torque")?],
            outputs: [vr("axis.position")?, vr("axis.speed")?, vr("motor1.speed")?, vr("motor2.speed")?],
        })
    }
}

/// The plant FMU's state after initialisation, which each window start edits.
struct StateTemplate {
    state: InstanceState<AzimuthPlantModel>,
    motor_has_friction: [bool; PATHS],
}

impl StateTemplate {
    fn capture(instance: &mut Instance) -> Result<StateTemplate, PlantFmuError> {
        let saved = instance.get_state()?;
        let bytes = instance.serialize_state(&saved)?;
        instance.free_state(saved)?;
        let state = InstanceState::<AzimuthPlantModel>::decode(&bytes).map_err(PlantFmuError::StateDecode)?;
        let drive = state.model.as_ref().ok_or(PlantFmuError::StateWithoutPlant)?;
        if drive.x.len() != STATES || drive.paths.len() != PATHS {
            return Err(PlantFmuError::StateLayout { states: drive.x.len(), paths: drive.paths.len() });
        }
        let values = &state.values;
        let has_friction = |coulomb: AzVar, stat: AzVar| values.real(coulomb) > 0.0 || values.real(stat) > 0.0;
        let motor_has_friction =
            [has_friction(AzVar::M1Coulomb, AzVar::M1Static), has_friction(AzVar::M2Coulomb, AzVar::M2Static)];
        Ok(StateTemplate { state, motor_has_friction })
    }
}

/// One configured FMU instance.
pub struct Session {
    instance: Instance,
    template: StateTemplate,
    gear_ratio: f64,
    backlash_motor_rad: [f64; PATHS],
    /// Each path's stiffness (axis side, N m/rad) and each motor's axis torque per unit of its
    /// input (A or N m), for the paths' counter-deflection under a torque bias.
    path_stiffness: [f64; PATHS],
    axis_torque_per_input: [f64; PATHS],
    inputs: [u32; 3],
    outputs: [u32; 4],
}

impl Session {
    pub fn gear_ratio(&self) -> f64 {
        self.gear_ratio
    }

    /// The serialised state of the plant at a window start (time 0 of the window).
    ///
    /// Motor k: angle difference `d_k = N (q_m - q_L)`, speed `N w_m`, current as logged at the
    /// start; it slides in the direction of its speed, or sticks when the speed is exactly 0
    /// (the plant's own event handling makes a slow body stick within the first step if its
    /// holding torque is below breakaway). A path with backlash is on the flank the twist
    /// presses (`beta = +-b/2`) when the twist exceeds half the gap, else in the gap with a
    /// relaxed spring. The command history within the delay goes into the delay lines.
    pub fn state_bytes(&self, start: &WindowStart) -> Vec<u8> {
        let n = self.gear_ratio;
        let mut state = self.template.state.clone();
        // Time, start time, no stop time, last successful time: the window runs from 0.
        state.header.time = 0.0;
        state.header.start_time = 0.0;
        state.header.stop_time = None;
        state.header.last_successful_time = 0.0;
        let mut x = [0.0; STATES];
        x[0] = n * start.load_angle;
        x[1] = n * start.load_speed;
        let mut meshes = [Mesh::PositiveFlank; PATHS];
        // Two motors with different torques (a torque bias) deflect their paths against each
        // other: moving together, with equal inertias and friction, the path torques differ by
        // the motor torques' difference, half of it each way about the common twist. Without
        // this every window of a biased drive would start with the bias unbalanced and ring.
        let torques: [f64; PATHS] = std::array::from_fn(|k| self.axis_torque_per_input[k] * start.currents[k]);
        let imbalance = 0.5 * (torques[0] - torques[1]);
        for k in 0..PATHS {
            let sign = if k == 0 { 1.0 } else { -1.0 };
            let counter = if self.path_stiffness[k] > 0.0 { sign * imbalance / self.path_stiffness[k] } else { 0.0 };
            let d = n * (start.twist + counter);
            x[2 + 4 * k] = d;
            x[3 + 4 * k] = n * start.motor_speed;
            x[4 + 4 * k] = start.currents[k];
            let half_gap = 0.5 * self.backlash_motor_rad[k];
            if half_gap > 0.0 {
                if d > half_gap {
                    x[5 + 4 * k] = half_gap;
                } else if d < -half_gap {
                    x[5 + 4 * k] = -half_gap;
                    meshes[k] = Mesh::NegativeFlank;
                } else {
                    x[5 + 4 * k] = d;
                    meshes[k] = Mesh::Gap;
                }
            }
        }
        let drive = state.model.as_mut().expect("the template has a plant (checked at capture)");
        drive.time = 0.0;
        drive.x = x.to_vec();
        drive.load_angle_low = 0.0;
        for (k, path) in drive.paths.iter_mut().enumerate() {
            path.motor_motion = if !self.template.motor_has_friction[k] || start.motor_speed > 0.0 {
                Motion::Forward
            } else if start.motor_speed < 0.0 {
                Motion::Backward
            } else {
                Motion::Stuck
            };
            path.mesh = meshes[k];
            // Delay line: (time the command was issued, command), oldest first, consecutive
            // equal commands merged as the plant does.
            path.delay.clear();
            for &(t, commands) in &start.history {
                if path.delay.last().is_none_or(|&(_, v)| v != commands[k]) {
                    path.delay.push((t, commands[k]));
                }
            }
            // Friction anchors of presliding motors at the motor angle (d_k + p_L): a relaxed
            // bristle. Only a motor that starts sticking uses it; a sliding one sets its own
            // when it comes to rest.
            path.anchor = path.anchor.map(|_| x[2 + 4 * k] + x[0]);
        }
        state.encode().expect("a plant state always encodes")
    }

    /// Simulates one window: restores the start state, then one communication step per log
    /// interval with the commands (per motor) and the disturbance held over each step.
    /// Returns the outputs at the start and after every step.
    pub fn run(
        &mut self,
        start: &WindowStart,
        commands: &[[f64; 2]],
        disturbance: &[f64],
        dt: f64,
    ) -> Result<SimulatedOutputs, PlantFmuError> {
        let bytes = self.state_bytes(start);
        let state = self.instance.deserialize_state(&bytes).map_err(PlantFmuError::StartStateRejected)?;
        let set = self.instance.set_state(&state);
        self.instance.free_state(state)?;
        set?;
        let n = self.gear_ratio;
        let steps = commands.len();
        let mut out = SimulatedOutputs::with_capacity(steps + 1);
        out.push(start.load_angle, start.load_speed, start.motor_angle, start.motor_speed);
        let mut motor_angle = start.motor_angle;
        let mut motor_speed = start.motor_speed;
        let mut values = [0.0; 4];
        for (j, command) in commands.iter().enumerate() {
            let inputs = [command[0], command[1], disturbance.get(j).copied().unwrap_or(0.0)];
            self.instance.set_real(&self.inputs, &inputs)?;
            self.instance.do_step(j as f64 * dt, dt).map_err(|source| PlantFmuError::Step { step: j, source })?;
            self.instance.get_real(&self.outputs, &mut values)?;
            let speed = 0.5 * (values[2] + values[3]) / n;
            // The FMU has no motor-angle output: the angle is the trapezoidal integral of the
            // motor speed, whose error over a step is dt^3/12 times the speed's second
            // derivative (below 1e-9 rad per step for the suite's plant).
            motor_angle += 0.5 * dt * (motor_speed + speed);
            motor_speed = speed;
            out.push(values[0].to_radians(), values[1].to_radians(), motor_angle, speed);
        }
        Ok(out)
    }
}

/// The plant FMU as a [`PlantSimulator`]: sessions of one parameter set, reused for every
/// window of that set; one session per thread when windows run side by side
/// ([`PlantSimulator::simulate_all`]).
pub struct FmuSimulator {
    fmu: PlantFmu,
    /// The configured parameter set, which every session of the pool is made from.
    source: Option<Source>,
    /// The sessions of that set: the first made by the configuration, the others when windows
    /// first ran on more threads.
    sessions: Vec<Session>,
    /// The log's length per FMU radian of the configured set ([`FmuConfig::length_unit`]).
    length_unit: f64,
}

/// Where a configuration's parameters come from.
#[derive(Debug, Clone, PartialEq)]
enum Source {
    Text(String),
    File(PathBuf),
}

impl FmuSimulator {
    pub fn new(fmu: PlantFmu) -> Self {
        FmuSimulator { fmu, source: None, sessions: Vec::new(), length_unit: 1.0 }
    }

    pub fn open(path: &Path) -> Result<Self, PlantFmuError> {
        Ok(Self::new(PlantFmu::open(path)?))
    }

    /// Configures the simulator from a parameter file on disk (for checking a written file),
    /// written for the FMU length unit `length_unit` ([`FmuConfig::length_unit`]).
    pub fn configure_from_file(&mut self, path: &Path, length_unit: f64) -> Result<(), PlantFmuError> {
        let source = Source::File(path.to_path_buf());
        let session = self.session(&source)?;
        self.source = Some(source);
        self.sessions = vec![session];
        self.length_unit = length_unit;
        Ok(())
    }

    fn session(&self, source: &Source) -> Result<Session, PlantFmuError> {
        match source {
            Source::Text(text) => self.fmu.session(text),
            Source::File(path) => self.fmu.session_from_file(path),
        }
    }

    /// Sessions of the configured set until there are `count` (fewer if one cannot be made:
    /// the windows then share the ones there are).
    fn grow_pool(&mut self, count: usize) {
        let Some(source) = self.source.clone() else { return };
        while self.sessions.len() < count {
            match self.session(&source) {
                Ok(session) => self.sessions.push(session),
                Err(_) => break,
            }
        }
    }
}

impl PlantSimulator for FmuSimulator {
    fn configure(&mut self, params: &ParameterSet, config: &FmuConfig) -> Result<(), SimulatorError> {
        let text = fmu_parameter_text(params, config, "written by validate for an output-error run")
            .map_err(|e| SimulatorError::Parameters(Arc::new(e)))?;
        let source = Source::Text(text);
        if self.source.as_ref() == Some(&source) && !self.sessions.is_empty() {
            return Ok(());
        }
        let session = self.session(&source)?;
        self.source = Some(source);
        self.sessions = vec![session];
        self.length_unit = config.length_unit;
        Ok(())
    }

    fn simulate(
        &mut self,
        start: &WindowStart,
        commands: &[[f64; 2]],
        disturbance: &[f64],
        dt: f64,
    ) -> Result<SimulatedOutputs, SimulatorError> {
        let unit = self.length_unit;
        let session = self.sessions.first_mut().ok_or(SimulatorError::NotConfigured)?;
        Ok(run_in_length_unit(session, start, commands, disturbance, dt, unit)?)
    }

    /// The windows split into one contiguous run per thread of the rayon pool, of about equal
    /// numbers of steps, each on its own session. A session restores the whole FMU state at
    /// every window start, so a window's result does not depend on the session or on what it
    /// ran before: the results are the same for any number of threads.
    fn simulate_all(&mut self, jobs: &[WindowJob<'_>], dt: f64) -> Vec<Result<SimulatedOutputs, SimulatorError>> {
        if self.sessions.is_empty() {
            return jobs.iter().map(|_| Err(SimulatorError::NotConfigured)).collect();
        }
        self.grow_pool(rayon::current_num_threads().min(jobs.len()).max(1));
        let runs = split_by_steps(jobs, self.sessions.len());
        let results: Vec<Vec<Result<SimulatedOutputs, SimulatorError>>> = self.sessions[..runs.len()]
            .par_iter_mut()
            .zip(runs.par_iter())
            .map(|(session, run)| run_windows(session, run, dt, self.length_unit))
            .collect();
        results.into_iter().flatten().collect()
    }
}

/// The jobs cut into at most `parts` contiguous runs of about equal numbers of steps (a
/// window's cost is about proportional to its steps), none empty.
fn split_by_steps<'j, 'a>(jobs: &'j [WindowJob<'a>], parts: usize) -> Vec<&'j [WindowJob<'a>]> {
    let total: usize = jobs.iter().map(|job| job.commands.len() + 1).sum();
    let mut runs = Vec::with_capacity(parts);
    let (mut first, mut done) = (0, 0);
    for (index, job) in jobs.iter().enumerate() {
        done += job.commands.len() + 1;
        // The run ends once it reaches its share of the total steps.
        if done * parts >= total * (runs.len() + 1) {
            runs.push(&jobs[first..=index]);
            first = index + 1;
        }
    }
    if first < jobs.len() {
        runs.push(&jobs[first..]);
    }
    runs
}

/// Simulates a run of windows on one session, in order. After a failure the rest of the run
/// repeats the error instead of simulating: the output error stops at the first failure in
/// window order, so what follows it is never read.
fn run_windows(
    session: &mut Session,
    run: &[WindowJob<'_>],
    dt: f64,
    unit: f64,
) -> Vec<Result<SimulatedOutputs, SimulatorError>> {
    let mut results = Vec::with_capacity(run.len());
    let mut failure: Option<SimulatorError> = None;
    for job in run {
        let result = match &failure {
            Some(error) => Err(error.clone()),
            None => run_in_length_unit(session, &job.start, job.commands, job.disturbance, dt, unit)
                .map_err(SimulatorError::from),
        };
        if let Err(error) = &result {
            failure.get_or_insert_with(|| error.clone());
        }
        results.push(result);
    }
    results
}

/// One window on a session whose FMU measures lengths in `unit` of the log's
/// ([`FmuConfig::length_unit`]): the same motion with angles and speeds over the unit and the
/// load disturbance (a force) times it; the commands' scale is in the FMU's torque constant.
fn run_in_length_unit(
    session: &mut Session,
    start: &WindowStart,
    commands: &[[f64; 2]],
    disturbance: &[f64],
    dt: f64,
    unit: f64,
) -> Result<SimulatedOutputs, PlantFmuError> {
    if unit == 1.0 {
        return session.run(start, commands, disturbance, dt);
    }
    let scaled = WindowStart {
        load_angle: start.load_angle / unit,
        load_speed: start.load_speed / unit,
        motor_angle: start.motor_angle / unit,
        motor_speed: start.motor_speed / unit,
        twist: start.twist / unit,
        currents: start.currents,
        history: start.history.clone(),
    };
    let disturbance: Vec<f64> = disturbance.iter().map(|d| d * unit).collect();
    let mut out = session.run(&scaled, commands, &disturbance, dt)?;
    for series in [&mut out.load_pos, &mut out.load_vel, &mut out.motor_pos, &mut out.motor_vel] {
        series.iter_mut().for_each(|x| *x *= unit);
    }
    Ok(out)
}
