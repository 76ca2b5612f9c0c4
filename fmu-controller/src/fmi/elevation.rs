//! The elevation controller as an FMI 2.0 co-simulation model (`ElevationController`).

use fmu_runtime::{Context, Model, ModelInfo, Notes, StateError, Values};

use super::common::{model_info, ControllerState};
use super::common::{
    MAX_AXIS_INERTIA, MAX_AXIS_SPEED_DEG_PER_S, MAX_CURRENT, MAX_GEAR_RATIO, MAX_MOTOR_INERTIA, MAX_MOTOR_SPEED,
    MAX_MOTOR_TORQUE, MAX_TORQUE_CONSTANT, MIN_MOTOR_INERTIA, TINY,
};
use super::ControllerFmuError;
use crate::params::{CascadeParams, ElevationControllerParams};
use crate::timing::SampleScheduler;
use crate::{ElevationController, ElevationInputs, ElevationOutputs, SampledController};

crate::controller_variables! {
    /// Variables of the elevation controller FMU.
    pub enum ElCtrlVar (1.0, 0.5) {
        MotorSpeed = Var::real("measured.motor_speed", "rad/s").input().start(0.0).min(-MAX_MOTOR_SPEED).max(MAX_MOTOR_SPEED)
            .description("Speed of the elevation motor at its shaft, positive raising the dish."),
        CurrentCommand = Var::real("motor.current_command", "A").output()
            .description("Current command to the elevation drive (limited to the current limit), applied after the computation delay."),
        FrictionFeedforwardTorque = Var::real("friction_feedforward.torque", "N.m").output()
            .description("Direction-dependent friction feedforward torque in use, at the motor."),
        GearRatioInUse = Var::real("drive.gear_ratio", "1").output()
            .description("Jackscrew ratio N(el) the controller uses at the measured elevation (gain scheduling)."),
        DishRadius = Var::real("drive.dish_attachment_radius", "m").parameter().start(2.0).min(TINY).max(100.0)
            .description("Jackscrew geometry the controller assumes: pivot to dish attachment."),
        YokeRadius = Var::real("drive.yoke_attachment_radius", "m").parameter().start(3.6).min(TINY).max(100.0)
            .description("Jackscrew geometry the controller assumes: pivot to yoke trunnion."),
        AttachmentAngle = Var::real("drive.attachment_angle_at_zero_elevation", "deg").parameter().start(20.0).min(-180.0).max(180.0)
            .description("Jackscrew geometry the controller assumes: angle between the attachment radii at 0 deg."),
        Lead = Var::real("drive.screw_lead", "m").parameter().start(0.02).min(TINY).max(1.0)
            .description("Screw lead the controller assumes."),
        GearboxRatio = Var::real("drive.gearbox_ratio", "1").parameter().start(28.0).min(0.1).max(MAX_GEAR_RATIO)
            .description("Gearbox ratio between motor and screw the controller assumes."),
        TravelMin = Var::real("drive.travel_min", "deg").parameter().start(15.0).min(-90.0).max(180.0)
            .description("Lower end of travel (the ratio is held at its end values beyond)."),
        TravelMax = Var::real("drive.travel_max", "deg").parameter().start(92.0).min(-90.0).max(180.0)
            .description("Upper end of travel."),
        MotorInertia = Var::real("drive.motor_inertia", "kg.m2").parameter().start(0.002).min(MIN_MOTOR_INERTIA).max(MAX_MOTOR_INERTIA)
            .description("Motor inertia the controller assumes."),
        DishInertia = Var::real("drive.dish_inertia", "kg.m2").parameter().start(3.5e5).min(1.0).max(MAX_AXIS_INERTIA)
            .description("Dish inertia about the elevation axis the controller assumes."),
        TorqueConstant = Var::real("drive.torque_constant", "N.m/A").parameter().start(0.8).min(TINY).max(MAX_TORQUE_CONSTANT)
            .description("Torque constant K_phi the controller assumes."),
        CurrentLimit = Var::real("drive.current_limit", "A").parameter().start(15.0).min(TINY).max(MAX_CURRENT)
            .description("Current limit of the drive."),
        FrictionEnabled = Var::boolean("friction_feedforward.enabled").parameter().start_boolean(true)
            .description("Direction-dependent constant friction-torque feedforward that overcomes the jackscrew friction (off: larger error at low speed)."),
        FrictionRaising = Var::real("friction_feedforward.raising", "N.m").parameter().start(0.4).min(0.0).max(MAX_MOTOR_TORQUE)
            .description("Friction feedforward while raising the dish, at the motor."),
        FrictionLowering = Var::real("friction_feedforward.lowering", "N.m").parameter().start(0.4).min(0.0).max(MAX_MOTOR_TORQUE)
            .description("Friction feedforward while lowering the dish, at the motor."),
        FrictionBand = Var::real("friction_feedforward.velocity_band", "deg/s").parameter().start(0.001).min(0.0).max(MAX_AXIS_SPEED_DEG_PER_S)
            .description("Velocity band over which the feedforward changes sign smoothly."),
    }
}

/// The controller parameters the variable values describe.
pub fn elevation_controller_params(v: &Values<ElCtrlVar>) -> ElevationControllerParams {
    let mut p = ElevationControllerParams {
        cascade: ElCtrlVar::CASCADE.read(v, CascadeParams::for_axis(1.0, 0.5)),
        ..ElevationControllerParams::default()
    };
    let j = &mut p.drive.jackscrew;
    j.dish_attachment_radius_m = v.real(ElCtrlVar::DishRadius);
    j.yoke_attachment_radius_m = v.real(ElCtrlVar::YokeRadius);
    j.attachment_angle_at_zero_elevation_deg = v.real(ElCtrlVar::AttachmentAngle);
    j.screw_lead_m = v.real(ElCtrlVar::Lead);
    j.gearbox_ratio = v.real(ElCtrlVar::GearboxRatio);
    p.drive.travel_min_deg = v.real(ElCtrlVar::TravelMin);
    p.drive.travel_max_deg = v.real(ElCtrlVar::TravelMax);
    p.drive.motor_inertia_kg_m2 = v.real(ElCtrlVar::MotorInertia);
    p.drive.dish_inertia_kg_m2 = v.real(ElCtrlVar::DishInertia);
    p.drive.torque_constant_nm_per_a = v.real(ElCtrlVar::TorqueConstant);
    p.drive.current_limit_a = v.real(ElCtrlVar::CurrentLimit);
    p.friction_feedforward.enabled = v.boolean(ElCtrlVar::FrictionEnabled);
    p.friction_feedforward.raising_torque_nm = v.real(ElCtrlVar::FrictionRaising);
    p.friction_feedforward.lowering_torque_nm = v.real(ElCtrlVar::FrictionLowering);
    p.friction_feedforward.velocity_band_deg_per_s = v.real(ElCtrlVar::FrictionBand);
    p
}

/// The elevation controller FMU.
pub struct ElevationControllerModel {
    controller: Option<ElevationController>,
    scheduler: Option<SampleScheduler<ElevationOutputs>>,
}

impl ElevationControllerModel {
    fn inputs(v: &Values<ElCtrlVar>) -> ElevationInputs {
        ElevationInputs {
            mode: ElCtrlVar::mode(v),
            position_command_deg: v.real(ElCtrlVar::PositionCommand),
            command_velocity_deg_per_s: v.real(ElCtrlVar::CommandVelocity),
            velocity_mode_command_deg_per_s: v.real(ElCtrlVar::VelocityModeCommand),
            open_loop_current_a: v.real(ElCtrlVar::OpenLoopCurrent),
            encoder_position_deg: v.real(ElCtrlVar::MeasuredPosition),
            motor_speed_rad_per_s: v.real(ElCtrlVar::MotorSpeed),
        }
    }

    fn write_outputs(o: &ElevationOutputs, v: &mut Values<ElCtrlVar>) {
        v.set_real(ElCtrlVar::CurrentCommand, o.current_command_a);
        v.set_real(ElCtrlVar::FrictionFeedforwardTorque, o.friction_feedforward_nm);
        v.set_real(ElCtrlVar::GearRatioInUse, o.gear_ratio);
        ElCtrlVar::STATUS.write(&o.status, v);
    }
}

impl Model for ElevationControllerModel {
    type Var = ElCtrlVar;
    type Error = ControllerFmuError;

    fn info() -> ModelInfo {
        model_info(
            "ElevationController",
            "MeerKAT ACU elevation controller (Fig. 3 of the seed paper): command profiler, position loop, velocity PI with anti-windup and gains scheduled with the jackscrew ratio, velocity and acceleration feedforward, direction-dependent friction feedforward, anti-limit-cycle hold; discrete time with a computation delay.",
        )
    }

    fn new(_values: &Values<ElCtrlVar>, _context: &Context) -> Result<Self, ControllerFmuError> {
        Ok(ElevationControllerModel { controller: None, scheduler: None })
    }

    fn initialize(
        &mut self,
        values: &mut Values<ElCtrlVar>,
        _context: &Context,
        _notes: &mut Notes,
    ) -> Result<(), ControllerFmuError> {
        let controller = ElevationController::new(elevation_controller_params(values))?;
        Self::write_outputs(&controller.idle_outputs(), values);
        self.controller = Some(controller);
        self.scheduler = None;
        Ok(())
    }

    fn do_step(
        &mut self,
        values: &mut Values<ElCtrlVar>,
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

    fn step_pieces(values: &Values<ElCtrlVar>, step: f64) -> (f64, &'static str) {
        let samples = SampleScheduler::<ElevationOutputs>::samples_in(step, values.real(ElCtrlVar::SampleTime));
        (samples, "controller samples, one per sampling.sample_time")
    }

    type State = ControllerState<ElevationOutputs>;

    fn save_state(&self) -> ControllerState<ElevationOutputs> {
        ControllerState {
            cascade: self.controller.as_ref().map(ElevationController::save_state),
            scheduler: self.scheduler.as_ref().map(SampleScheduler::saved_state),
        }
    }

    fn save_state_into(&self, state: &mut ControllerState<ElevationOutputs>) {
        state.overwrite(self.controller.as_ref().map(ElevationController::save_state), self.scheduler.as_ref());
    }

    fn load_state(
        &mut self,
        state: ControllerState<ElevationOutputs>,
        values: &Values<ElCtrlVar>,
    ) -> Result<(), StateError> {
        let ControllerState { cascade, scheduler } = state;
        let controller = match cascade {
            Some(cascade) => {
                let mut c = ElevationController::new(elevation_controller_params(values)).map_err(StateError::model)?;
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
