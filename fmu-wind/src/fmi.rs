//! The wind unit as an FMI 2.0 co-simulation FMU (`Wind`): Davenport gusts for the given mean
//! speed and the wind torques they put on the azimuth and elevation axes, following the
//! antenna's pointing.

use fmu_runtime::package::{default_parameter_file, FmuSpec};
use fmu_runtime::{
    declare_variables, Context, DefaultExperiment, EnumerationType, Model, ModelInfo, Notes, StateError, Values,
    VariableSet,
};

use crate::admittance::AdmittanceFilter;
use crate::coefficients::{CoefficientError, CoefficientTable, DEFAULT_TABLE_CSV};
use crate::davenport::Davenport;
use crate::error::WindError;
use crate::gust::{GustGenerator, GustState};
use crate::shaping::ShapingFilter;
use crate::torque::{normalised_gust, FeedDrag, ForceCoefficients, TorqueForm, WindTorqueModel};
use fmu_runtime::params::ParamsError;
use fmu_runtime::seed::seed_from_fmi_integer;
use serde::{Deserialize, Serialize};

/// Why the wind FMU refuses a call; logged with `fmi2Error`.
#[derive(Debug, thiserror::Error)]
pub enum WindFmuError {
    /// A part of the wind model refused its parameters.
    #[error(transparent)]
    Wind(#[from] WindError),
    /// The built-in coefficient table did not read (a defect of the build, not of the user's
    /// parameters).
    #[error(transparent)]
    DefaultTable(CoefficientError),
    /// The coefficient table named by `coefficient_file` cannot be read.
    #[error("{}: {table}", .path.display())]
    CoefficientFile { path: std::path::PathBuf, table: CoefficientError },
    /// An output would not be finite; the step or initialisation is refused.
    #[error(
        "'{name}' would be {value} (v_m = {v_mean} m/s, D = {diameter} m, rho = {density} kg/m3): the step is refused"
    )]
    NonFiniteOutput { name: &'static str, value: f64, v_mean: f64, diameter: f64, density: f64 },
    /// A step before fmi2ExitInitializationMode built the model.
    #[error("the wind model is not initialised")]
    NotInitialised,
    /// The parameter file named by `parameter_file` cannot be applied.
    #[error(transparent)]
    Parameters(#[from] ParamsError),
}

static SPECTRUM: EnumerationType = EnumerationType {
    name: "SpectrumMode",
    description: "How the gust spectrum is realised.",
    items: &[
        ("davenport", "A shaping filter derived at initialisation that follows Eq. 2 within 0.06 dB from 0.001 to 30 rad/s, variance 6 kappa v_m^2."),
        ("paper", "The seed paper's filters exactly: H3 for v_m = 3 m/s, H10 for v_m = 9.5 m/s, at the paper's site z = 10 m, z0 = 0.4 m (other speeds or sites are an error)."),
        ("off", "No gust: the wind is steady at v_m."),
    ],
};

static TORQUE_FORM: EnumerationType = EnumerationType {
    name: "TorqueForm",
    description: "How wind speed becomes torque.",
    items: &[
        ("quadratic", "T = tau 0.5 rho A D v|v| with v = v_m + v_t (exact in the gust)."),
        ("linearised", "The paper's form: Eq. 3 mean torque plus k_t dv0, linear in the gust."),
    ],
};

declare_variables! {
    /// Variables of the wind FMU. Torques are about the axes (axis side), in N m.
    pub enum WindVar {
        Azimuth = Var::real("antenna.azimuth", "deg").input().start(0.0).min(-360.0).max(360.0)
            .description("Azimuth the antenna points at (the yaw angle to the wind is wind.direction minus this); one turn either way covers MeerKAT's -185 to +275 deg travel."),
        Elevation = Var::real("antenna.elevation", "deg").input().start(45.0).min(-10.0).max(120.0)
            .description("Elevation the antenna points at."),
        Speed = Var::real("wind.speed", "m/s").output().description("Wind speed v = v_m + v_t."),
        Gust = Var::real("wind.gust", "m/s").output().description("Gust v_t (zero-mean Davenport turbulence)."),
        NormalisedGust = Var::real("wind.normalised_gust", "1").output()
            .description("The paper's normalised gust dv0 = v_t / (sqrt(6 kappa) v_m), of unit variance in Davenport mode."),
        AzTorque = Var::real("torque.azimuth", "N.m").output().depends_on(&[WindVar::Azimuth as u32, WindVar::Elevation as u32])
            .description("Wind torque about the azimuth axis (yawing moment); positive drives positive azimuth."),
        AzTorqueMean = Var::real("torque.azimuth_mean", "N.m").output().depends_on(&[WindVar::Azimuth as u32, WindVar::Elevation as u32])
            .description("Mean part of the azimuth torque, Eq. 3 with the yawing coefficient."),
        AzTorqueGust = Var::real("torque.azimuth_gust", "N.m").output().depends_on(&[WindVar::Azimuth as u32, WindVar::Elevation as u32])
            .description("Gust part of the azimuth torque."),
        ElTorque = Var::real("torque.elevation", "N.m").output().depends_on(&[WindVar::Azimuth as u32, WindVar::Elevation as u32])
            .description("Wind torque about the elevation axis (pitching moment); positive raises the dish."),
        ElTorqueMean = Var::real("torque.elevation_mean", "N.m").output().depends_on(&[WindVar::Azimuth as u32, WindVar::Elevation as u32])
            .description("Mean part of the elevation torque, Eq. 3 with the pitching coefficient."),
        ElTorqueGust = Var::real("torque.elevation_gust", "N.m").output().depends_on(&[WindVar::Azimuth as u32, WindVar::Elevation as u32])
            .description("Gust part of the elevation torque."),
        TauAz = Var::real("coefficient.azimuth", "1").output().depends_on(&[WindVar::Azimuth as u32, WindVar::Elevation as u32])
            .description("Yawing torque coefficient tau_az at the current yaw and elevation, from coefficient_file. The shipped table is a synthetic stand-in, not measured data: only the yaw of its largest azimuth torque (about 130 deg, JPL 64 m antenna, DSN Progress Report XV, 1973) is sourced; its magnitudes and shape are not (docs/wind-model.md)."),
        TauEl = Var::real("coefficient.elevation", "1").output().depends_on(&[WindVar::Azimuth as u32, WindVar::Elevation as u32])
            .description("Pitching torque coefficient tau_el at the current yaw and elevation, from coefficient_file. The shipped table is a synthetic stand-in, not measured data: no pitching value in it is sourced (docs/wind-model.md)."),
        Yaw = Var::real("wind.yaw", "deg").output().depends_on(&[WindVar::Azimuth as u32])
            .description("Wind direction minus antenna azimuth, wrapped to (-180, 180]."),
        MeanSpeed = Var::real("wind.mean_speed", "m/s").parameter().start(3.0).min(0.5).max(25.0)
            .description("Mean wind speed v_m at the reference height (0.5-25 m/s: the band the Davenport filter is fitted for; MeerKAT points in winds to 69 km/h, 19 m/s)."),
        Direction = Var::real("wind.direction", "deg").parameter().tunable().start(0.0).min(-360.0).max(360.0)
            .description("Direction the wind comes from, degrees from north, clockwise."),
        Height = Var::real("wind.reference_height", "m").parameter().start(10.0).min(1.0).max(200.0)
            .description("Height z at which v_m and the spectrum are defined (the site anemometer is at 10 m; 1-200 m, the range of the logarithmic profile over a surface layer); must exceed z0."),
        Roughness = Var::real("wind.roughness_length", "m").parameter().start(0.4).min(1e-5).max(2.0)
            .description("Roughness length z0 (1e-5 m, ice or calm sea, to 2 m, city centres). The paper's 0.4 m gives about 30 % turbulence; the requirement scenarios use 0.026 m (optimal) and 0.0105 m (normal), which reproduce the specification's gust factors (docs/wind-model.md)."),
        Density = Var::real("air.density", "kg/m3").parameter().start(1.075).min(0.6).max(1.5)
            .description("Air density; 1.075 kg/m3 is the standard atmosphere at MeerKAT's 1,087 m at 15 C (1.005 at 35 C, 1.155 at -5 C). 0.6-1.5 kg/m3 spans sites from 5,000 m (ALMA) to cold sea level."),
        Diameter = Var::real("dish.diameter", "m").parameter().start(13.5).min(1.0).max(100.0)
            .description("Dish diameter D (1-100 m); the reference area is A = pi D^2 / 4, and sqrt(A) sets the admittance's frequency scale."),
        Seed = Var::integer("seed").parameter().start_integer(1).range_integer(i32::MIN, i32::MAX)
            .description("Seed of the gust generator: the same seed gives the same record."),
        Spectrum = Var::enumeration("spectrum", &SPECTRUM).parameter().start_integer(1)
            .description("Gust spectrum: davenport (default), paper (H3/H10), off."),
        Form = Var::enumeration("torque_form", &TORQUE_FORM).parameter().start_integer(1)
            .description("Torque law: quadratic (default) or the paper's linearised form."),
        CoefficientFile = Var::string("coefficient_file").parameter().start_string("wind_coefficients.csv")
            .description("Torque coefficient table (CSV, documented in the file); relative paths are looked up in the resources folder. The shipped wind_coefficients.csv is a synthetic stand-in, not measured data: replace it with measured surfaces."),
        Kappa = Var::real("wind.kappa", "1").calculated_parameter()
            .description("Terrain drag coefficient kappa = 1 / (2.5 ln(z/z0))^2."),
        Sigma = Var::real("wind.sigma", "m/s").calculated_parameter()
            .description("Standard deviation of the gust, sqrt(6 kappa) v_m (Davenport) or that of the paper's filter."),
        Intensity = Var::real("wind.turbulence_intensity", "1").calculated_parameter()
            .description("Turbulence intensity sigma / v_m."),
        Admittance = Var::integer("wind.admittance").parameter().start_integer(1).range_integer(0, 2)
            .description("Aerodynamic admittance of the loads: 0 = coherent (chi = 1, the point gust acts on the whole dish: the seed paper's model), 1 = Vickery, chi^2(n) = 1 / [1 + (2 n sqrt(A) / U)^(4/3)]^2 (Holmes, Wind Loading of Structures), fitted within 0.06 dB, 2 = Davenport's size factor for the square of equal area, chi^2 = J^2(xi)^2, J^2(xi) = 2/xi - 2 (1 - e^-xi) / xi^2, xi = C n sqrt(A) / U (C = wind.coherence_decay), fitted within 0.055 dB. Applies to the torques and forces, not to wind.speed and wind.gust."),
        DragCoefficient = Var::real("dish.drag_coefficient", "1").parameter().start(1.3).min(0.0).max(2.5)
            .description("Face-on drag coefficient C_D0 of the dish; drag coefficient C_D0 |cos(el) cos(yaw)|. Estimate: 1.3, range 1.1-1.6 (about 1.2-1.4 for a solid parabolic dish, weak sources; docs/wind-model.md)."),
        LiftCoefficient = Var::real("dish.lift_coefficient", "1").parameter().start(0.3).min(0.0).max(1.5)
            .description("Largest cross-flow coefficient C_L0 of the dish: vertical lift coefficient -C_L0 sin(2 el) cos(yaw), horizontal side force coefficient C_L0 cos^2(el) sin(2 yaw). Estimate: 0.3, range 0.1-0.6 (docs/wind-model.md)."),
        LoadGust = Var::real("wind.load_gust", "m/s").output()
            .description("The gust that drives the torques and forces: wind.gust through the aerodynamic admittance (equal to wind.gust when wind.admittance = 0)."),
        LoadSigma = Var::real("wind.load_sigma", "m/s").calculated_parameter()
            .description("Standard deviation of wind.load_gust (exact, from the joint covariance of gust and admittance filter); equal to wind.sigma when coherent."),
        Drag = Var::real("force.drag", "N").output().depends_on(&[WindVar::Azimuth as u32, WindVar::Elevation as u32])
            .description("Wind drag on the dish along the flow (positive downwind): C_D 0.5 rho A v|v| with v = v_m + wind.load_gust."),
        DragMean = Var::real("force.drag_mean", "N").output().depends_on(&[WindVar::Azimuth as u32, WindVar::Elevation as u32])
            .description("Mean part of the drag, C_D 0.5 rho A v_m^2."),
        Lift = Var::real("force.lift", "N").output().depends_on(&[WindVar::Azimuth as u32, WindVar::Elevation as u32])
            .description("Wind lift on the dish, the vertical force (positive up): C_L 0.5 rho A v|v| with v = v_m + wind.load_gust."),
        LiftMean = Var::real("force.lift_mean", "N").output().depends_on(&[WindVar::Azimuth as u32, WindVar::Elevation as u32])
            .description("Mean part of the lift, C_L 0.5 rho A v_m^2."),
        CDrag = Var::real("coefficient.drag", "1").output().depends_on(&[WindVar::Azimuth as u32, WindVar::Elevation as u32])
            .description("Drag coefficient C_D = C_D0 |cos(el) cos(yaw)| at the current pointing (estimate, docs/wind-model.md)."),
        CLift = Var::real("coefficient.lift", "1").output().depends_on(&[WindVar::Azimuth as u32, WindVar::Elevation as u32])
            .description("Vertical lift coefficient C_L = -C_L0 sin(2 el) cos(yaw) at the current pointing (estimate, docs/wind-model.md)."),
        CoherenceDecay = Var::real("wind.coherence_decay", "1").parameter().start(8.0).min(1.0).max(20.0)
            .description("Decay constant C of the gust's exponential coherence exp(-C n r / U), used by wind.admittance = 2 only. Estimate: 8, range 7-10 (docs/research/antenna-parameters-survey.md, section 4)."),
        ParameterFile = Var::string("parameter_file").parameter().start_string("")
            .description("A file of name = value lines applied when this parameter is set (relative paths are looked up in the resources folder): realistic.params holds the realistic antenna's wind parameters (docs/parameters.md), defaults.params every default."),
        Axial = Var::real("force.axial", "N").output().depends_on(&[WindVar::Azimuth as u32, WindVar::Elevation as u32])
            .description("The horizontal wind force (drag and side force) resolved along the horizontal projection of the boresight, force.drag cos(yaw) + force.side sin(yaw): positive pushes the dish backwards, from its reflector face towards its back (a wind blowing into the face, yaw 0, gives +drag; a wind from behind, yaw 180, -drag). The input force.axial of the Structure FMU."),
        AxialMean = Var::real("force.axial_mean", "N").output().depends_on(&[WindVar::Azimuth as u32, WindVar::Elevation as u32])
            .description("Mean part of force.axial, force.drag_mean cos(yaw) + force.side_mean sin(yaw)."),
        Lateral = Var::real("force.lateral", "N").output().depends_on(&[WindVar::Azimuth as u32, WindVar::Elevation as u32])
            .description("The horizontal wind force (drag and side force) resolved across the boresight (cross-elevation), -force.drag sin(yaw) + force.side cos(yaw): positive pushes the dish towards increasing azimuth (clockwise seen from above; to the right seen from behind the dish looking out along the boresight), as a wind from its left (negative yaw) does. With force.axial and force.lift a right-handed frame. The input force.lateral of the Structure FMU."),
        LateralMean = Var::real("force.lateral_mean", "N").output().depends_on(&[WindVar::Azimuth as u32, WindVar::Elevation as u32])
            .description("Mean part of force.lateral, -force.drag_mean sin(yaw) + force.side_mean cos(yaw)."),
        Side = Var::real("force.side", "N").output().depends_on(&[WindVar::Azimuth as u32, WindVar::Elevation as u32])
            .description("Wind side force on the dish, the horizontal part of the cross-flow force (positive to the left of the flow looking downwind, 90 degrees anticlockwise from the downwind direction seen from above): C_S 0.5 rho A v|v| with v = v_m + wind.load_gust. force.axial and force.lateral include it."),
        SideMean = Var::real("force.side_mean", "N").output().depends_on(&[WindVar::Azimuth as u32, WindVar::Elevation as u32])
            .description("Mean part of the side force, C_S 0.5 rho A v_m^2."),
        CSide = Var::real("coefficient.side", "1").output().depends_on(&[WindVar::Azimuth as u32, WindVar::Elevation as u32])
            .description("Side force coefficient C_S = C_L0 cos^2(el) sin(2 yaw) at the current pointing: the horizontal part of the cross-flow force whose vertical part is the lift (estimate, docs/wind-model.md)."),
        // The enumerations' Integer twins (appended: existing value references keep their numbers).
        SpectrumNumber = Var::integer("spectrum_number").parameter().start_integer(0).range_integer(0, 3)
            .description("spectrum as an Integer, for masters that ignore FMI enumerations (libcosim and ecos do): 1 davenport, 2 paper, 3 off; 0 (the default) leaves the choice to spectrum. When it is not 0 it wins."),
        FormNumber = Var::integer("torque_form_number").parameter().start_integer(0).range_integer(0, 2)
            .description("torque_form as an Integer, for masters that ignore FMI enumerations: 1 quadratic, 2 linearised; 0 (the default) leaves the choice to torque_form. When it is not 0 it wins."),
        // The feed support's drag (appended: existing value references keep their numbers).
        FeedDragArea = Var::real("feed.drag_area", "m2").parameter().start(0.0).min(0.0).max(100.0)
            .description("Drag area (C_D A) of the feed support: MeerKAT's single feed-support arm, the 3.8 m sub-reflector and the feed indexer. Its drag 0.5 rho (C_D A) v|v| along the flow (the same load gust as the dish), applied at the centre of pressure given by feed.boresight_distance and feed.offset, adds its moments to torque.azimuth and torque.elevation. 0 (the paper's model, the start value) leaves it out; the realistic antenna's estimate is 8 m2, range 4-15 (docs/parameters.md, docs/wind-model.md)."),
        FeedBoresightDistance = Var::real("feed.boresight_distance", "m").parameter().start(7.0).min(-30.0).max(30.0)
            .description("Distance of the feed support's centre of pressure ahead of the elevation axis along the boresight. Estimate: 7 m, range 5-9 (docs/wind-model.md)."),
        FeedOffset = Var::real("feed.offset", "m").parameter().start(-3.0).min(-30.0).max(30.0)
            .description("Distance of the feed support's centre of pressure from the boresight line through the elevation axis, in the plane of boresight and zenith, positive towards the zenith when the dish points at the horizon (negative: below the boresight, as MeerKAT's feed-down sub-reflector). Estimate: -3 m, range -5 to -1 (docs/wind-model.md)."),
    }
}

/// An enumeration's item, where its Integer twin (for masters that ignore enumerations) wins
/// unless it is 0.
fn enumeration_or_twin(values: &Values<WindVar>, enumeration: WindVar, twin: WindVar) -> i32 {
    match values.integer(twin) {
        0 => values.integer(enumeration),
        number => number,
    }
}

/// The wind FMU.
pub struct WindModel {
    /// Where the instance runs: a restored state rebuilds the coefficient table from it.
    context: Context,
    generator: Option<GustGenerator>,
    torque: Option<WindTorqueModel>,
    kappa: f64,
}

impl WindModel {
    fn spectrum_item(values: &Values<WindVar>) -> &'static str {
        SPECTRUM.name_of(enumeration_or_twin(values, WindVar::Spectrum, WindVar::SpectrumNumber)).unwrap_or("davenport")
    }

    fn build(
        values: &Values<WindVar>,
        context: &Context,
    ) -> Result<(Option<GustGenerator>, WindTorqueModel, f64), WindFmuError> {
        let v_mean = values.real(WindVar::MeanSpeed);
        let davenport = Davenport::new(v_mean, values.real(WindVar::Height), values.real(WindVar::Roughness))?;
        let filter = match Self::spectrum_item(values) {
            "paper" => Some(ShapingFilter::paper_at_site(v_mean, davenport.z, davenport.z0)?),
            "off" => None,
            _ => Some(ShapingFilter::davenport(&davenport)),
        };
        let seed = seed_from_fmi_integer(values.integer(WindVar::Seed));
        let diameter = values.real(WindVar::Diameter);
        let admittance = match values.integer(WindVar::Admittance) {
            0 => None,
            2 => Some(AdmittanceFilter::davenport_size(v_mean, diameter, values.real(WindVar::CoherenceDecay))?),
            _ => Some(AdmittanceFilter::vickery(v_mean, diameter)?),
        };
        let generator = filter.map(|f| GustGenerator::with_admittance(f, admittance, seed));
        let table = Self::coefficients(values.string(WindVar::CoefficientFile), context)?;
        let form = if enumeration_or_twin(values, WindVar::Form, WindVar::FormNumber) == 2 {
            TorqueForm::Linearised
        } else {
            TorqueForm::Quadratic
        };
        let forces = ForceCoefficients {
            drag_face_on: values.real(WindVar::DragCoefficient),
            lift_max: values.real(WindVar::LiftCoefficient),
        };
        let feed = FeedDrag {
            drag_area: values.real(WindVar::FeedDragArea),
            boresight_distance: values.real(WindVar::FeedBoresightDistance),
            offset: values.real(WindVar::FeedOffset),
        };
        let torque = WindTorqueModel::new(table, values.real(WindVar::Density), diameter, form)
            .and_then(|model| model.with_forces(forces))
            .and_then(|model| model.with_feed(feed))?;
        Ok((generator, torque, davenport.kappa()))
    }

    /// The coefficient table named by the parameter: relative names are looked up in the
    /// resources folder; the shipped default is also built in, so the FMU works without one.
    fn coefficients(name: &str, context: &Context) -> Result<CoefficientTable, WindFmuError> {
        if name.is_empty() {
            return CoefficientTable::from_csv_str(DEFAULT_TABLE_CSV).map_err(WindFmuError::DefaultTable);
        }
        let path = std::path::PathBuf::from(name);
        let path = match (&context.resource_dir, path.is_absolute()) {
            (Some(dir), false) => dir.join(path),
            (None, false) if name == "wind_coefficients.csv" => {
                return CoefficientTable::from_csv_str(DEFAULT_TABLE_CSV).map_err(WindFmuError::DefaultTable)
            }
            _ => path,
        };
        CoefficientTable::from_file(&path).map_err(|table| WindFmuError::CoefficientFile { path, table })
    }

    /// The outputs that depend on the gust only.
    fn write_gust(&self, values: &mut Values<WindVar>) {
        let v_mean = values.real(WindVar::MeanSpeed);
        let gust = self.generator.as_ref().map_or(0.0, |g| g.gust());
        values.set_real(WindVar::Speed, v_mean + gust);
        values.set_real(WindVar::Gust, gust);
        values.set_real(WindVar::NormalisedGust, normalised_gust(gust, self.kappa, v_mean));
        values.set_real(WindVar::LoadGust, self.load_gust());
    }

    /// The gust the loads see (the admitted gust, or the gust itself when coherent), m/s.
    fn load_gust(&self) -> f64 {
        self.generator.as_ref().map_or(0.0, GustGenerator::load_gust)
    }

    /// An error naming the first output that is not finite, if any: the FMU never hands one out.
    fn check_outputs_finite(values: &Values<WindVar>) -> Result<(), WindFmuError> {
        let outputs = [
            WindVar::Speed,
            WindVar::Gust,
            WindVar::NormalisedGust,
            WindVar::LoadGust,
            WindVar::AzTorque,
            WindVar::ElTorque,
            WindVar::Drag,
            WindVar::Lift,
        ];
        match outputs.iter().find(|v| !values.real(**v).is_finite()) {
            Some(v) => Err(WindFmuError::NonFiniteOutput {
                name: v.var().name,
                value: values.real(*v),
                v_mean: values.real(WindVar::MeanSpeed),
                diameter: values.real(WindVar::Diameter),
                density: values.real(WindVar::Density),
            }),
            None => Ok(()),
        }
    }

    /// What the loads are computed from: the mean speed and the load gust (m/s), the wind's
    /// direction and the antenna's azimuth and elevation (deg).
    fn load_inputs(&self, values: &Values<WindVar>) -> [f64; 5] {
        [
            values.real(WindVar::MeanSpeed),
            self.load_gust(),
            values.real(WindVar::Direction),
            values.real(WindVar::Azimuth),
            values.real(WindVar::Elevation),
        ]
    }

    /// The torques, their coefficients and the yaw: the outputs that depend on the pointing
    /// inputs (direct feedthrough) that every coupled master reads ([`TORQUE_GROUP`]).
    fn write_torques(&self, values: &mut Values<WindVar>) {
        let Some(torque) = &self.torque else { return };
        let [v_mean, gust, direction, azimuth, elevation] = self.load_inputs(values);
        let t = torque.torques(v_mean, gust, direction, azimuth, elevation);
        values.set_real(WindVar::AzTorque, t.azimuth());
        values.set_real(WindVar::AzTorqueMean, t.azimuth_mean);
        values.set_real(WindVar::AzTorqueGust, t.azimuth_gust);
        values.set_real(WindVar::ElTorque, t.elevation());
        values.set_real(WindVar::ElTorqueMean, t.elevation_mean);
        values.set_real(WindVar::ElTorqueGust, t.elevation_gust);
        values.set_real(WindVar::TauAz, t.tau_az);
        values.set_real(WindVar::TauEl, t.tau_el);
        values.set_real(WindVar::Yaw, t.yaw_deg);
    }

    /// The forces on the dish and their coefficients, the other outputs with direct
    /// feedthrough ([`FORCE_GROUP`]): a master whose structure takes no force never reads
    /// them, and their two `sincos` and thirteen outputs were about a tenth of the unit's step.
    fn write_forces(&self, values: &mut Values<WindVar>) {
        let Some(torque) = &self.torque else { return };
        let [v_mean, gust, direction, azimuth, elevation] = self.load_inputs(values);
        let f = torque.forces(v_mean, gust, direction, azimuth, elevation);
        values.set_real(WindVar::Drag, f.drag());
        values.set_real(WindVar::DragMean, f.drag_mean);
        values.set_real(WindVar::Lift, f.lift());
        values.set_real(WindVar::LiftMean, f.lift_mean);
        values.set_real(WindVar::Axial, f.axial());
        values.set_real(WindVar::AxialMean, f.axial_mean());
        values.set_real(WindVar::Lateral, f.lateral());
        values.set_real(WindVar::LateralMean, f.lateral_mean());
        values.set_real(WindVar::Side, f.side());
        values.set_real(WindVar::SideMean, f.side_mean);
        values.set_real(WindVar::CSide, f.c_side);
        values.set_real(WindVar::CDrag, f.c_drag);
        values.set_real(WindVar::CLift, f.c_lift);
    }
}

/// The feedthrough group of the torques (see [`Model::feedthrough_group`]).
const TORQUE_GROUP: u32 = 0;
/// The feedthrough group of the dish forces.
const FORCE_GROUP: u32 = 1;

/// The outputs that [`WindModel::write_forces`] writes.
const FORCE_OUTPUTS: [WindVar; 13] = [
    WindVar::Drag,
    WindVar::DragMean,
    WindVar::Lift,
    WindVar::LiftMean,
    WindVar::Axial,
    WindVar::AxialMean,
    WindVar::Lateral,
    WindVar::LateralMean,
    WindVar::Side,
    WindVar::SideMean,
    WindVar::CSide,
    WindVar::CDrag,
    WindVar::CLift,
];

impl Model for WindModel {
    type Var = WindVar;
    type Error = WindFmuError;

    fn info() -> ModelInfo {
        ModelInfo {
            model_identifier: "Wind",
            model_name: "Wind",
            description: "Davenport wind gusts for any mean speed (Eq. 2 of the seed paper, or its H3/H10 filters) and the yawing and pitching torques, drag and lift they put on a 13.5 m dish through an aerodynamic admittance (Vickery, or coherent as in the paper), following the antenna's pointing. Step-size independent and reproducible from a seed.",
            author: "MeerKAT antenna positioner reference model contributors",
            version: env!("CARGO_PKG_VERSION"),
            default_experiment: DefaultExperiment { start_time: 0.0, stop_time: 600.0, step_size: 0.01 },
        }
    }

    fn new(_values: &Values<WindVar>, context: &Context) -> Result<Self, WindFmuError> {
        Ok(WindModel { context: context.clone(), generator: None, torque: None, kappa: 0.0 })
    }

    fn initialize(
        &mut self,
        values: &mut Values<WindVar>,
        context: &Context,
        _notes: &mut Notes,
    ) -> Result<(), WindFmuError> {
        let (generator, torque, kappa) = Self::build(values, context)?;
        let v_mean = values.real(WindVar::MeanSpeed);
        let sigma = generator.as_ref().map_or(0.0, |g| g.filter().stationary_variance().sqrt());
        values.set_real(WindVar::Kappa, kappa);
        values.set_real(WindVar::Sigma, sigma);
        values.set_real(WindVar::Intensity, sigma / v_mean);
        let load_sigma = generator.as_ref().map_or(0.0, |g| {
            if g.admittance().is_some() {
                g.load_stationary_variance().sqrt()
            } else {
                sigma
            }
        });
        values.set_real(WindVar::LoadSigma, load_sigma);
        self.generator = generator;
        self.torque = Some(torque);
        self.kappa = kappa;
        self.write_gust(values);
        self.update_feedthrough(values);
        Self::check_outputs_finite(values)
    }

    fn do_step(
        &mut self,
        values: &mut Values<WindVar>,
        _time: f64,
        step: f64,
        _notes: &mut Notes,
    ) -> Result<(), WindFmuError> {
        if self.torque.is_none() {
            return Err(WindFmuError::NotInitialised);
        }
        if let Some(generator) = &mut self.generator {
            generator.step(step);
        }
        // The torques are written by `update_feedthrough`, which the runtime calls before the
        // next get: the master usually sets the new pointing first, and computing them here
        // too would be wasted work.
        self.write_gust(values);
        // The gusts are finite for every parameter the ranges admit; this guards the rest
        // (the loads are finite multiples of them). A refused step leaves an error the master
        // sees as fmi2Error with this cause.
        Self::check_outputs_finite(values)
    }

    fn update_feedthrough(&mut self, values: &mut Values<WindVar>) {
        self.write_torques(values);
        self.write_forces(values);
    }

    fn feedthrough_group(var: WindVar) -> u32 {
        if FORCE_OUTPUTS.contains(&var) {
            FORCE_GROUP
        } else {
            TORQUE_GROUP
        }
    }

    fn update_feedthrough_groups(&mut self, values: &mut Values<WindVar>, groups: u32) {
        if groups & 1 << TORQUE_GROUP != 0 {
            self.write_torques(values);
        }
        if groups & 1 << FORCE_GROUP != 0 {
            self.write_forces(values);
        }
    }

    fn string_changed(
        &mut self,
        var: WindVar,
        values: &mut Values<WindVar>,
        context: &Context,
    ) -> Result<(), WindFmuError> {
        if var == WindVar::ParameterFile {
            fmu_runtime::params::load_file::<Self>(var, values, context)?;
        }
        Ok(())
    }

    type State = WindState;

    fn save_state(&self) -> WindState {
        if self.torque.is_none() {
            return WindState::NotInitialized;
        }
        WindState::Initialized { gusts: self.generator.as_ref().map(GustGenerator::save_state) }
    }

    fn save_state_into(&self, state: &mut WindState) {
        match (&self.generator, state) {
            (Some(generator), WindState::Initialized { gusts: Some(kept) }) if self.torque.is_some() => {
                generator.save_state_into(kept)
            }
            (_, state) => *state = self.save_state(),
        }
    }

    fn load_state(&mut self, state: WindState, values: &Values<WindVar>) -> Result<(), StateError> {
        let WindState::Initialized { gusts } = state else {
            self.generator = None;
            self.torque = None;
            return Ok(());
        };
        let (generator, torque, kappa) = Self::build(values, &self.context).map_err(StateError::model)?;
        let generator = match (generator, gusts) {
            (Some(mut g), Some(saved)) => {
                g.load_state(saved)?;
                Some(g)
            }
            (None, None) => None,
            _ => return Err(StateError::Parts { part: "the gust generator" }),
        };
        self.generator = generator;
        self.torque = Some(torque);
        self.kappa = kappa;
        Ok(())
    }
}

/// The wind model's part of an FMU state.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum WindState {
    NotInitialized,
    /// The gust generator's state; none when the parameters switch the gusts off.
    Initialized {
        gusts: Option<GustState>,
    },
}

/// The FMUs this crate ships: `Wind`, with its default coefficient table and parameters.
pub fn fmus() -> Vec<FmuSpec> {
    vec![FmuSpec::of::<WindModel>("fmu_wind_ffi", || {
        vec![
            ("defaults.params".into(), default_parameter_file::<WindModel>().into_bytes()),
            ("wind_coefficients.csv".into(), DEFAULT_TABLE_CSV.as_bytes().to_vec()),
        ]
    })]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_output_that_would_not_be_finite_is_refused_with_its_name_and_the_parameters() {
        let mut values = Values::<WindVar>::at_start();
        assert!(WindModel::check_outputs_finite(&values).is_ok());
        values.set_real(WindVar::Drag, f64::INFINITY);
        let error = WindModel::check_outputs_finite(&values).unwrap_err().to_string();
        assert!(error.contains("'force.drag' would be inf") && error.contains("D = 13.5 m"), "{error}");
        values.set_real(WindVar::Drag, 0.0);
        values.set_real(WindVar::LoadGust, f64::NAN);
        assert!(WindModel::check_outputs_finite(&values).unwrap_err().to_string().contains("wind.load_gust"));
    }

    #[test]
    fn the_admittance_parameter_selects_the_law_and_coherent_leaves_no_stage() {
        let context = Context::default();
        let mut values = Values::<WindVar>::at_start();
        let orders: Vec<Option<usize>> = [0, 1, 2]
            .into_iter()
            .map(|law| {
                values.set_integer(WindVar::Admittance, law);
                let (generator, _, _) = WindModel::build(&values, &context).unwrap();
                generator.unwrap().admittance().map(|a| a.order())
            })
            .collect();
        assert_eq!(orders, [None, Some(7), Some(4)]);
    }
}
