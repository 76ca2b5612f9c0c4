//! The azimuth controller as an FMI 2.0 co-simulation model (`AzimuthController`).

use fmu_runtime::{Context, Model, ModelInfo, Notes, StateError, Values};

use super::common::{model_info, ControllerState};
use super::common::{
    MAX_AXIS_INERTIA, MAX_CURRENT, MAX_GEAR_RATIO, MAX_LOOP_FREQUENCY, MAX_MOTOR_INERTIA, MAX_MOTOR_SPEED,
    MAX_MOTOR_TORQUE, MAX_SPEED_GAIN, MAX_TORQUE_CONSTANT, MIN_MOTOR_INERTIA, TINY,
};
use super::ControllerFmuError;
use crate::params::{AzimuthControllerParams, CascadeParams};
use crate::timing::SampleScheduler;
use crate::{AzimuthController, AzimuthInputs, AzimuthOutputs, SampledController};

crate::controller_variables! {
    /// Variables of the azimuth controller FMU.
    pub enum AzCtrlVar (2.0, 1.0) {
        Motor1Speed = Var::real("measured.motor1_speed", "rad/s").input().start(0.0).min(-MAX_MOTOR_SPEED).max(MAX_MOTOR_SPEED)
            .description("Speed of motor 1 at its shaft, positive towards positive azimuth."),
        Motor2Speed = Var::real("measured.motor2_speed", "rad/s").input().start(0.0).min(-MAX_MOTOR_SPEED).max(MAX_MOTOR_SPEED)
            .description("Speed of motor 2 at its shaft, positive towards positive azimuth."),
        Current1Command = Var::real("motor1.current_command", "A").output()
            .description("Current command to drive 1 (limited to the current limit), applied after the computation delay."),
        Current2Command = Var::real("motor2.current_command", "A").output()
            .description("Current command to drive 2 (limited to the current limit), applied after the computation delay."),
        BiasTorque = Var::real("torque_bias.torque", "N.m").output()
            .description("Bias torque b(T) added to motor 1 and taken from motor 2."),
        DifferentialTorque = Var::real("differential_loop.torque", "N.m").output()
            .description("Differential speed loop torque added to motor 1 and taken from motor 2."),
        GearRatio = Var::real("drive.gear_ratio", "1").parameter().start(9000.0).min(1.0).max(MAX_GEAR_RATIO)
            .description("Gear ratio the controller assumes, motor rad per axis rad."),
        MotorInertia = Var::real("drive.motor_inertia", "kg.m2").parameter().start(0.006).min(MIN_MOTOR_INERTIA).max(MAX_MOTOR_INERTIA)
            .description("Inertia of one motor with its gearbox input stage, as the controller assumes it."),
        AxisInertia = Var::real("drive.axis_inertia", "kg.m2").parameter().start(8.5e5).min(1.0).max(MAX_AXIS_INERTIA)
            .description("Azimuth inertia the gains are designed for (mid elevation)."),
        TorqueConstant = Var::real("drive.torque_constant", "N.m/A").parameter().start(0.8).min(TINY).max(MAX_TORQUE_CONSTANT)
            .description("Torque constant K_phi the controller assumes."),
        CurrentLimit = Var::real("drive.current_limit", "A").parameter().start(15.0).min(TINY).max(MAX_CURRENT)
            .description("Current limit of each drive."),
        BiasEnabled = Var::boolean("torque_bias.enabled").parameter().start_boolean(true)
            .description("Torque bias between the motors, which keeps each pinion on one flank (off: backlash shows at reversals)."),
        BiasTorqueParam = Var::real("torque_bias.bias", "N.m").parameter().start(1.8).min(0.0).max(MAX_MOTOR_TORQUE)
            .description("Bias torque at low demand, per motor, at the motor."),
        BiasFadeStart = Var::real("torque_bias.fade_start", "N.m").parameter().start(3.6).min(0.0).max(MAX_MOTOR_TORQUE)
            .description("Total torque demand at which the bias starts to fade."),
        BiasFadeEnd = Var::real("torque_bias.fade_end", "N.m").parameter().start(7.2).min(0.0).max(MAX_MOTOR_TORQUE)
            .description("Total torque demand at which the bias has faded to zero (both motors then drive the same way)."),
        DifferentialEnabled = Var::boolean("differential_loop.enabled").parameter().start_boolean(true)
            .description("Superimposed differential speed controller on motor 1 minus motor 2 speed."),
        DifferentialBandwidth = Var::real("differential_loop.bandwidth", "Hz").parameter().start(15.0).min(0.0).max(MAX_LOOP_FREQUENCY)
            .description("Bandwidth the differential gain is designed for."),
        DifferentialGainOverride = Var::real("differential_loop.gain_override", "N.m.s/rad").parameter().start(0.0).min(0.0).max(MAX_SPEED_GAIN)
            .description("Differential gain; 0 uses the designed gain."),
        DifferentialMaxTorque = Var::real("differential_loop.max_torque", "N.m").parameter().start(3.0).min(0.0).max(MAX_MOTOR_TORQUE)
            .description("Limit of the differential loop's torque."),
    }
}

/// The controller parameters the variable values describe.
pub fn azimuth_controller_params(v: &Values<AzCtrlVar>) -> AzimuthControllerParams {
    let mut p = AzimuthControllerParams {
        cascade: AzCtrlVar::CASCADE.read(v, CascadeParams::for_axis(2.0, 1.0)),
        ..AzimuthControllerParams::default()
    };
    p.drive.gear_ratio = v.real(AzCtrlVar::GearRatio);
    p.drive.motor_inertia_kg_m2 = v.real(AzCtrlVar::MotorInertia);
    p.drive.axis_inertia_kg_m2 = v.real(AzCtrlVar::AxisInertia);
    p.drive.torque_constant_nm_per_a = v.real(AzCtrlVar::TorqueConstant);
    p.drive.current_limit_a = v.real(AzCtrlVar::CurrentLimit);
    p.torque_bias.enabled = v.boolean(AzCtrlVar::BiasEnabled);
    p.torque_bias.bias_torque_nm = v.real(AzCtrlVar::BiasTorqueParam);
    p.torque_bias.fade_start_torque_nm = v.real(AzCtrlVar::BiasFadeStart);
    p.torque_bias.fade_end_torque_nm = v.real(AzCtrlVar::BiasFadeEnd);
    p.differential_loop.enabled = v.boolean(AzCtrlVar::DifferentialEnabled);
    p.differential_loop.bandwidth_hz = v.real(AzCtrlVar::DifferentialBandwidth);
    let k = v.real(AzCtrlVar::DifferentialGainOverride);
    p.differential_loop.gain_override_nm_s_per_rad = (k > 0.0).then_some(k);
    p.differential_loop.max_torque_nm = v.real(AzCtrlVar::DifferentialMaxTorque);
    p
}

/// The azimuth controller FMU.
pub struct AzimuthControllerModel {
    controller: Option<AzimuthController>,
    scheduler: Option<SampleScheduler<AzimuthOutputs>>,
}

impl AzimuthControllerModel {
    fn inputs(v: &Values<AzCtrlVar>) -> AzimuthInputs {
        AzimuthInputs {
            mode: AzCtrlVar::mode(v),
            position_command_deg: v.real(AzCtrlVar::PositionCommand),
            command_velocity_deg_per_s: v.real(AzCtrlVar::CommandVelocity),
            velocity_mode_command_deg_per_s: v.real(AzCtrlVar::VelocityModeCommand),
            open_loop_current_a: v.real(AzCtrlVar::OpenLoopCurrent),
            encoder_position_deg: v.real(AzCtrlVar::MeasuredPosition),
            motor_speed_rad_per_s: [v.real(AzCtrlVar::Motor1Speed), v.real(AzCtrlVar::Motor2Speed)],
        }
    }

    fn write_outputs(o: &AzimuthOutputs, v: &mut Values<AzCtrlVar>) {
        v.set_real(AzCtrlVar::Current1Command, o.current_command_a[0]);
        v.set_real(AzCtrlVar::Current2Command, o.current_command_a[1]);
        v.set_real(AzCtrlVar::BiasTorque, o.bias_torque_nm);
        v.set_real(AzCtrlVar::DifferentialTorque, o.differential_torque_nm);
        AzCtrlVar::STATUS.write(&o.status, v);
    }
}

impl Model for AzimuthControllerModel {
    type Var = AzCtrlVar;
    type Error = ControllerFmuError;

    fn info() -> ModelInfo {
        model_info(
            "AzimuthController",
            "MeerKAT ACU azimuth controller (Fig. 3 of the seed paper): command profiler, position loop, velocity PI with anti-windup, velocity and acceleration feedforward, torque bias between the two motors with a superimposed differential speed loop, anti-limit-cycle hold; discrete time with a computation delay.",
        )
    }

    fn new(_values: &Values<AzCtrlVar>, _context: &Context) -> Result<Self, ControllerFmuError> {
        Ok(AzimuthControllerModel { controller: None, scheduler: None })
    }

    fn initialize(
        &mut self,
        values: &mut Values<AzCtrlVar>,
        _context: &Context,
        _notes: &mut Notes,
    ) -> Result<(), ControllerFmuError> {
        let controller = AzimuthController::new(azimuth_controller_params(values))?;
        Self::write_outputs(&controller.idle_outputs(), values);
        self.controller = Some(controller);
        self.scheduler = None;
        Ok(())
    }

    fn do_step(
        &mut self,
        values: &mut Values<AzCtrlVar>,
        time: f64,
        step: f64,
        _notes: &mut Notes,
    ) -> Result<(), ControllerFmuError> {
        // Not `ok_or`: it would build the error at every step and drop it again.
        let Some(controller) = self.controller.as_mut() else { return Err(ControllerFmuError::NotInitialised) };
        // The sample grid starts at the first communication point.
        let scheduler = self.scheduler.get_or_insert_with(|| {
            SampleScheduler::new(time, &controller.params().cascade.sampling, controller.idle_outputs())
        });
        let inputs = Self::inputs(values);
        // Written from the scheduler's own copy: the outputs are a few dozen numbers.
        scheduler.check_clock(time)?;
        Self::write_outputs(scheduler.do_step(controller, time, step, &inputs), values);
        Ok(())
    }

    fn step_pieces(values: &Values<AzCtrlVar>, step: f64) -> (f64, &'static str) {
        let samples = SampleScheduler::<AzimuthOutputs>::samples_in(step, values.real(AzCtrlVar::SampleTime));
        (samples, "controller samples, one per sampling.sample_time")
    }

    type State = ControllerState<AzimuthOutputs>;

    fn save_state(&self) -> ControllerState<AzimuthOutputs> {
        ControllerState {
            cascade: self.controller.as_ref().map(AzimuthController::save_state),
            scheduler: self.scheduler.as_ref().map(SampleScheduler::saved_state),
        }
    }

    fn save_state_into(&self, state: &mut ControllerState<AzimuthOutputs>) {
        state.overwrite(self.controller.as_ref().map(AzimuthController::save_state), self.scheduler.as_ref());
    }

    fn load_state(
        &mut self,
        state: ControllerState<AzimuthOutputs>,
        values: &Values<AzCtrlVar>,
    ) -> Result<(), StateError> {
        let ControllerState { cascade, scheduler } = state;
        let controller = match cascade {
            Some(cascade) => {
                let mut c = AzimuthController::new(azimuth_controller_params(values)).map_err(StateError::model)?;
                c.load_state(cascade)?;
                Some(c)
            }
            None => None,
        };
        let scheduler = match (scheduler, &controller) {
            (Some(saved), Some(c)) => Some(SampleScheduler::restored(&c.params().cascade.sampling, saved)?),
            (None, _) => None,
            (Some(_), None) => {
                return Err(StateError::Parts { part: "the sample scheduler (the state has one, but no controller)" })
            }
        };
        self.controller = controller;
        self.scheduler = scheduler;
        Ok(())
    }
}
