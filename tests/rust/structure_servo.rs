//! The structure's lowest mode under the servo: the linear model of one axis with its mode and
//! the closed cascade (`antenna_sim::frequency_response::structure_loop`) against the coupled
//! antenna holding at 45 deg in normal wind with every friction level of both plants at zero,
//! so that the axes are free to move as they are while sliding in a track.
//!
//! The frequency response from the wind's torque about each axis to the beam's pointing on the
//! sky (load angle, times `cos(el)` for azimuth, plus the structure's offset) is estimated from
//! the run (H1, Welch) and compared with the model's on the same bins, through the same fit: a
//! second-order rational function over the mode's band, whose pole gives the peak's frequency
//! and damping. The model is not tuned to the run; both take the shipped parameters.
//!
//! `cargo test --release -p antenna-tests --test integration -- structure_servo:: --nocapture` prints the
//! figures of docs/structure-model.md ("The mode under the servo").

use std::f64::consts::TAU;

use antenna_dsp::{transfer_function_h1, TransferEstimate, WelchConfig};
use antenna_sim::frequency_response::structure_loop::{figure, AxisWithMode};
use antenna_sim::frequency_response::Axis;
use antenna_sim::scenario::{normal_wind, tracking_table};
use antenna_sim::{AntennaConfig, Configuration, CoupledAntenna, FmuSet, ParameterValue, Trace};
use nalgebra::{Complex, DMatrix, DVector};

type C64 = Complex<f64>;

const ARCSEC_PER_RAD: f64 = 180.0 / std::f64::consts::PI * 3600.0;
const ELEVATION_DEG: f64 = 45.0;
/// Long enough for a few hundred Welch averages at 0.06 Hz resolution: near 6 Hz the wind's
/// torque is weak against the sensors' noise (coherence 0.3-0.6), and the estimate's random
/// error per bin is about `sqrt((1 - c) / (2 c n))`, 5-8 % with 290 averages. The coupled
/// antenna runs it in a few seconds.
const SIMULATED_S: f64 = 2400.0;
/// The start, where the loops and the mode settle from rest, is left out.
const SETTLING_S: f64 = 10.0;
/// The mode's band for the fit: wide enough for the free axis's broad peak (half-power widths
/// 0.9 and 1.3 Hz predicted), narrow enough that a second-order function describes the
/// response within it.
const BAND_HZ: (f64, f64) = (4.5, 7.5);

/// Every static and Coulomb friction level of both plants (docs/parameters.csv's targets).
const FRICTION_LEVELS: [(&str, &[&str]); 2] = [
    (
        "AzimuthPlant",
        &[
            "bearing.coulomb_friction",
            "bearing.static_friction",
            "motor1.coulomb_friction",
            "motor1.static_friction",
            "motor2.coulomb_friction",
            "motor2.static_friction",
        ],
    ),
    (
        "ElevationPlant",
        &[
            "motor.coulomb_friction",
            "motor.static_friction",
            "jackscrew.coulomb_friction",
            "jackscrew.static_friction",
            "pivot.coulomb_friction",
            "pivot.static_friction",
        ],
    ),
];

/// The realistic antenna with every friction level at zero: the structure coupled both ways,
/// the sensors' errors and noise as shipped.
fn frictionless_realistic_config() -> AntennaConfig {
    let mut config = Configuration::Realistic.antenna_config();
    for (unit, names) in FRICTION_LEVELS {
        let overrides = if unit == "AzimuthPlant" { &mut config.azimuth_plant } else { &mut config.elevation_plant };
        // Replaced rather than appended, so that no earlier value of the same name can win.
        overrides.retain(|(name, _)| !names.contains(&name.as_str()));
        overrides.extend(names.iter().map(|name| (name.to_string(), ParameterValue::Real(0.0))));
    }
    config
}

/// The report's hold in normal wind (azimuth 30 deg) at an elevation, run for `SIMULATED_S`.
fn hold_in_normal_wind(config: &mut AntennaConfig, elevation_deg: f64) -> Trace {
    let fmus = FmuSet::open(&antenna_fmus::fmu_directory()).expect("run `cargo xtask package` first");
    config.wind = normal_wind(30.0, 101);
    let table = tracking_table((30.0, elevation_deg), (0.0, 0.0), SIMULATED_S);
    let mut antenna = CoupledAntenna::new(&fmus, config, &table).unwrap();
    let mut trace = Trace::default();
    let steps = (SIMULATED_S / config.step_s).round() as u64;
    antenna.run_steps(&table, steps, Some(&mut trace), &mut |_| {}).unwrap();
    trace
}

/// H1 from the wind's torque about `axis` (N m) to the beam's pointing on the sky along it (rad).
fn measured_response(trace: &Trace, axis: Axis, step_s: f64, elevation_deg: f64) -> TransferEstimate {
    let skip = (SETTLING_S / step_s).round() as usize;
    let sky = elevation_deg.to_radians().cos();
    let (torque, pointing): (Vec<f64>, Vec<f64>) = match axis {
        Axis::Azimuth => (
            trace.wind_torque_azimuth_nm[skip..].to_vec(),
            trace.azimuth_deg[skip..]
                .iter()
                .zip(&trace.beam_offset_arcsec[skip..])
                .map(|(axis_deg, beam)| axis_deg.to_radians() * sky + beam[0] / ARCSEC_PER_RAD)
                .collect(),
        ),
        Axis::Elevation => (
            trace.wind_torque_elevation_nm[skip..].to_vec(),
            trace.elevation_deg[skip..]
                .iter()
                .zip(&trace.beam_offset_arcsec[skip..])
                .map(|(axis_deg, beam)| axis_deg.to_radians() + beam[1] / ARCSEC_PER_RAD)
                .collect(),
        ),
    };
    transfer_function_h1(&torque, &pointing, 1.0 / step_s, &WelchConfig::new(1 << 14)).unwrap()
}

/// A second-order rational function `(b0 + b1 x + b2 x^2) / (a0 + a1 x + x^2)` in the scaled
/// variable `x = s / w_ref`, fitted to a response.
#[derive(Debug, Clone, Copy)]
struct SecondOrderFit {
    numerator: [f64; 3],
    denominator: [f64; 2],
    reference_rad_per_s: f64,
    /// The band it was fitted over, Hz.
    band_hz: (f64, f64),
}

impl SecondOrderFit {
    /// Weighted least squares on `N(s) - D(s) H = 0` (Levy), repeated with the weights divided
    /// by the last `|D|^2` (Sanathanan-Koerner), which removes Levy's bias towards the band's
    /// upper end. `weights` are the bins' inverse variances relative to `|H|^2`.
    fn fit(frequency_hz: &[f64], response: &[C64], weights: &[f64]) -> SecondOrderFit {
        let reference = TAU * 6.0;
        let x: Vec<C64> = frequency_hz.iter().map(|f| C64::new(0.0, TAU * f / reference)).collect();
        let mut last_denominator: Vec<f64> = vec![1.0; x.len()];
        let band_hz = (frequency_hz[0], frequency_hz[frequency_hz.len() - 1]);
        let mut fit =
            SecondOrderFit { numerator: [0.0; 3], denominator: [0.0; 2], reference_rad_per_s: reference, band_hz };
        for _ in 0..20 {
            let rows = 2 * x.len();
            let mut a = DMatrix::<f64>::zeros(rows, 5);
            let mut b = DVector::<f64>::zeros(rows);
            for (k, (&xk, &h)) in x.iter().zip(response).enumerate() {
                let w = (weights[k] / last_denominator[k]).sqrt() / h.norm();
                let columns = [C64::new(1.0, 0.0), xk, xk * xk, -h, -h * xk];
                let target = h * xk * xk;
                for (j, c) in columns.iter().enumerate() {
                    a[(2 * k, j)] = w * c.re;
                    a[(2 * k + 1, j)] = w * c.im;
                }
                b[2 * k] = w * target.re;
                b[2 * k + 1] = w * target.im;
            }
            let solution = a.svd(true, true).solve(&b, 1e-14).expect("the fit's least squares solve");
            fit.numerator = [solution[0], solution[1], solution[2]];
            fit.denominator = [solution[3], solution[4]];
            last_denominator = x.iter().map(|&xk| fit.denominator_at(xk).norm_sqr()).collect();
        }
        fit
    }

    fn denominator_at(&self, x: C64) -> C64 {
        self.denominator[0] + self.denominator[1] * x + x * x
    }

    fn at(&self, frequency_hz: f64) -> C64 {
        let x = C64::new(0.0, TAU * frequency_hz / self.reference_rad_per_s);
        (self.numerator[0] + self.numerator[1] * x + self.numerator[2] * x * x) / self.denominator_at(x)
    }

    /// The pole's natural frequency, Hz, and damping ratio.
    fn pole(&self) -> (f64, f64) {
        let natural = self.denominator[0].sqrt();
        (natural * self.reference_rad_per_s / TAU, self.denominator[1] / (2.0 * natural))
    }

    /// The frequency of the largest magnitude within the band, Hz, and that magnitude.
    fn peak(&self) -> (f64, f64) {
        let points = 30_000;
        (0..=points)
            .map(|k| self.band_hz.0 + (self.band_hz.1 - self.band_hz.0) * k as f64 / points as f64)
            .map(|f| (f, self.at(f).norm()))
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .expect("the grid is not empty")
    }
}

/// The figures of one axis's comparison.
struct AxisFigures {
    measured: SecondOrderFit,
    model: SecondOrderFit,
    /// The spread of the measurement about the model and about the clamped mode: rms of the
    /// log magnitude ratio over the band's bins.
    rms_log_error_free: f64,
    rms_log_error_clamped: f64,
}

/// The run against the model over a band, Hz.
impl AxisFigures {
    /// The simulated peak against the predicted: frequency and pole within 1.5 %, damping
    /// within 25 %, height within 15 %; and the run nearer the prediction than the clamped mode
    /// (its rms log-magnitude difference under 0.3 of the clamped mode's).
    ///
    /// The fit's own bias cancels between the two (the same bins, weights and function); what
    /// remains is the estimate's random error and the co-simulation's coupling through the step
    /// (within 0.1 point of damping at 1 ms, docs/structure-model.md). Three gust seeds
    /// (101-103) put the simulated peak at 45 deg within 0.4 % of the prediction, the damping
    /// within 0.3 point and the height within 2 %: the limits are three to four times that.
    /// With the friction of the realistic antenna the azimuth peak stays at 5.991 Hz with 1.7 %
    /// damping (the clamped mode), 2.8 % above the prediction, and fails here.
    fn assert_within_limits(&self, case: &str) {
        let (measured_peak_hz, measured_peak) = self.measured.peak();
        let (model_peak_hz, model_peak) = self.model.peak();
        let (measured_pole_hz, measured_damping) = self.measured.pole();
        let (model_pole_hz, model_damping) = self.model.pole();
        let within = |what: &str, measured: f64, model: f64, limit: f64| {
            assert!((measured / model - 1.0).abs() < limit, "{case}: simulated {what} {measured}, predicted {model}");
        };
        within("peak (Hz)", measured_peak_hz, model_peak_hz, 0.015);
        within("pole (Hz)", measured_pole_hz, model_pole_hz, 0.015);
        within("damping", measured_damping, model_damping, 0.25);
        within("peak height", measured_peak, model_peak, 0.15);
        // The prediction is not the clamped mode's: the run is far from that one.
        assert!(
            self.rms_log_error_free < 0.3 * self.rms_log_error_clamped,
            "{case}: the run is as close to the clamped mode ({}) as to the free model ({})",
            self.rms_log_error_clamped,
            self.rms_log_error_free
        );
    }
}

fn compare(estimate: &TransferEstimate, model: &AxisWithMode, band_hz: (f64, f64)) -> AxisFigures {
    let bins: Vec<usize> = (0..estimate.frequency_hz.len())
        .filter(|&k| estimate.frequency_hz[k] >= band_hz.0 && estimate.frequency_hz[k] <= band_hz.1)
        .collect();
    let frequency_hz: Vec<f64> = bins.iter().map(|&k| estimate.frequency_hz[k]).collect();
    let measured: Vec<C64> = bins.iter().map(|&k| estimate.h1[k]).collect();
    // The H1 estimate's relative variance is (1 - c) / (2 c n): the weights are its inverse.
    let weights: Vec<f64> = bins.iter().map(|&k| estimate.coherence[k] / (1.0 - estimate.coherence[k])).collect();
    let free: Vec<C64> = frequency_hz.iter().map(|f| model.beam_per_wind_torque_free(TAU * f)).collect();
    let clamped: Vec<C64> = frequency_hz.iter().map(|f| model.beam_per_wind_torque_clamped(TAU * f)).collect();
    let rms_log = |reference: &[C64]| {
        let sum: f64 = measured.iter().zip(reference).map(|(m, r)| (m.norm() / r.norm()).ln().powi(2)).sum();
        (sum / measured.len() as f64).sqrt()
    };
    AxisFigures {
        measured: SecondOrderFit::fit(&frequency_hz, &measured, &weights),
        model: SecondOrderFit::fit(&frequency_hz, &free, &weights),
        rms_log_error_free: rms_log(&free),
        rms_log_error_clamped: rms_log(&clamped),
    }
}

/// Where the beam's spectrum peaks between 4.8 and 7.2 Hz (the report's search band, 0.8-1.2
/// times the mode's 6 Hz), and its peak over its level at 4.9 Hz: from `response` (a function
/// of Hz) squared times the wind torque's spectrum, or, where `response` gives NaN, the
/// simulated pointing's own spectrum. The wind's torque falls steeply with frequency, so the
/// spectrum's peak sits below the response's.
fn spectral_peak(estimate: &TransferEstimate, response: impl Fn(f64) -> C64) -> (f64, f64) {
    let spectrum = |k: usize| {
        let h = response(estimate.frequency_hz[k]);
        if h.re.is_nan() {
            estimate.syy[k]
        } else {
            h.norm_sqr() * estimate.sxx[k]
        }
    };
    let bins: Vec<usize> =
        (0..estimate.frequency_hz.len()).filter(|&k| (4.8..=7.2).contains(&estimate.frequency_hz[k])).collect();
    let peak = *bins.iter().max_by(|a, b| spectrum(**a).total_cmp(&spectrum(**b))).expect("bins in the band");
    let reference = estimate.frequency_hz.iter().position(|f| *f >= 4.9).expect("a bin at 4.9 Hz");
    (estimate.frequency_hz[peak], spectrum(peak) / spectrum(reference))
}

/// The models against the run, for docs/figures/ (`name`), into `out/`.
fn write_figure(name: &str, title: &str, drawn: &[(AxisWithMode, Vec<f64>, Vec<C64>)]) {
    let directory = antenna_fmus::workspace_root().join("out");
    std::fs::create_dir_all(&directory).unwrap();
    let path = directory.join(name);
    let axes: Vec<_> = drawn.iter().map(|(model, f, h)| (model, Some((f.as_slice(), h.as_slice())))).collect();
    figure(title, &axes, 1.0, 12.0).save_png(&path).unwrap();
    println!("wrote {}", path.display());
}

#[test]
fn with_friction_zeroed_a_held_axis_loads_the_structural_mode_as_the_linear_servo_model_predicts() {
    let started = std::time::Instant::now();
    let mut config = frictionless_realistic_config();
    let trace = hold_in_normal_wind(&mut config, ELEVATION_DEG);
    let simulated = started.elapsed();
    println!("coupled antenna, friction zeroed, hold at {ELEVATION_DEG} deg in normal wind: {SIMULATED_S} s simulated in {simulated:.1?}");
    println!("| axis | case | peak (Hz) | pole (Hz) | damping (pole) | damping (half power) | peak height / clamped |");
    println!("|---|---|---|---|---|---|---|");
    let mut drawn = Vec::new();
    for axis in Axis::BOTH {
        let model = AxisWithMode::shipped(axis, ELEVATION_DEG);
        let free = model.free_resonance(3.0, 9.0);
        let clamped = model.clamped_resonance(3.0, 9.0);
        let half_power = |d: Option<f64>| d.map_or("-".to_string(), |d| format!("{:.2} %", 100.0 * d));
        for (case, r) in [("model, axis clamped", &clamped), ("model, axis free", &free)] {
            println!(
                "| {} | {case} | {:.3} | {:.3} | {:.2} % | {} | {:.3} |",
                axis.name(),
                r.peak_hz,
                r.pole_frequency_hz(),
                100.0 * r.pole_damping(),
                half_power(r.half_power_damping),
                r.peak_magnitude / clamped.peak_magnitude
            );
        }
        let estimate = measured_response(&trace, axis, config.step_s, ELEVATION_DEG);
        let figures = compare(&estimate, &model, BAND_HZ);
        drawn.push((model.clone(), estimate.frequency_hz.clone(), estimate.h1.clone()));
        for (case, fit) in
            [("model, free, fitted on the bins", &figures.model), ("simulated, fitted", &figures.measured)]
        {
            let (peak_hz, peak) = fit.peak();
            let (pole_hz, damping) = fit.pole();
            println!(
                "| {} | {case} | {peak_hz:.3} | {pole_hz:.3} | {:.2} % | | {:.3} |",
                axis.name(),
                100.0 * damping,
                peak / clamped.peak_magnitude
            );
        }
        println!(
            "{}: rms log-magnitude difference over {:?} Hz, simulation against the free model {:.3}, against the clamped mode {:.3}",
            axis.name(),
            BAND_HZ,
            figures.rms_log_error_free,
            figures.rms_log_error_clamped
        );
        let (spectral_peak_hz, spectral_rise) = spectral_peak(&estimate, |f| model.beam_per_wind_torque_free(TAU * f));
        let (simulated_spectral_peak_hz, simulated_spectral_rise) =
            spectral_peak(&estimate, |_| C64::new(f64::NAN, 0.0));
        println!(
            "{}: the beam's spectrum in this wind (the response squared times the wind torque's spectrum) peaks at {spectral_peak_hz:.2} Hz, {spectral_rise:.2} times its level at 4.9 Hz (simulated: {simulated_spectral_peak_hz:.2} Hz, {simulated_spectral_rise:.2})",
            axis.name()
        );
        figures.assert_within_limits(axis.name());
    }
    write_figure(
        "structure-servo-45deg.png",
        "The structural mode under the servo: wind torque to beam pointing, holding at 45 deg",
        &drawn,
    );
    println!("test time {:.1?}", started.elapsed());
}

/// The shipped azimuth mode made to change with elevation: 6 Hz at the zenith as shipped, 7 Hz
/// at the horizon (a dish's inertia about the vertical axis is largest with its boresight
/// vertical, as the azimuth plant's is: 9.5e5 kg m^2 at the zenith, 7.5e5 at the horizon).
fn azimuth_mode_changing_with_elevation() -> fmu_structure::modes::Mode {
    let shipped = AxisWithMode::shipped(Axis::Azimuth, 90.0).mode;
    fmu_structure::modes::Mode { horizon_frequency_hz: Some(7.0), ..shipped }
}

#[test]
fn a_mode_that_changes_with_elevation_loads_the_held_azimuth_axis_as_predicted_at_each_elevation() {
    use fmu_structure::modes::{parse_modes, write_modes, DEFAULT_MODES};
    let started = std::time::Instant::now();
    let mut modes = parse_modes(DEFAULT_MODES, "shipped").unwrap();
    modes[0] = azimuth_mode_changing_with_elevation();
    let directory = std::env::temp_dir().join(format!("structure-servo-{}", std::process::id()));
    std::fs::create_dir_all(&directory).unwrap();
    let file = directory.join("elevation.params");
    std::fs::write(&file, write_modes(&modes, "the shipped modes, azimuth 7 Hz at the horizon")).unwrap();
    let mut peaks = Vec::new();
    let mut drawn = Vec::new();
    for elevation_deg in [15.0, 60.0] {
        let mut config = frictionless_realistic_config();
        config
            .structure
            .as_mut()
            .expect("the realistic antenna has the structure")
            .push(("modes_file".into(), ParameterValue::Text(file.display().to_string())));
        let trace = hold_in_normal_wind(&mut config, elevation_deg);
        // The model takes the mode at the centre of the elevation cell the structure and the
        // azimuth plant hold it in.
        let shipped = AxisWithMode::shipped(Axis::Azimuth, elevation_deg);
        let frozen = fmu_plant::AzimuthParams::default().frozen_elevation_deg(elevation_deg);
        let model = AxisWithMode { mode: modes[0].at_elevation(frozen), ..shipped };
        let clamped_hz = model.mode.frequency_hz;
        let band = (0.75 * clamped_hz, 1.25 * clamped_hz);
        let estimate = measured_response(&trace, Axis::Azimuth, config.step_s, elevation_deg);
        let figures = compare(&estimate, &model, band);
        let (measured_hz, measured_peak) = figures.measured.peak();
        let (model_hz, model_peak) = figures.model.peak();
        let (measured_damping, model_damping) = (figures.measured.pole().1, figures.model.pole().1);
        println!(
            "azimuth at {elevation_deg} deg, the mode clamped at {clamped_hz:.3} Hz: simulated peak {measured_hz:.3} Hz, damping {:.2} %; predicted {model_hz:.3} Hz, {:.2} %; height ratio {:.3}",
            100.0 * measured_damping,
            100.0 * model_damping,
            measured_peak / model_peak
        );
        // The limits of the 45 deg test: the master leaves the mode's inertia at this
        // elevation out of the azimuth plant, so that drive and mode move as the model's.
        figures.assert_within_limits(&format!("azimuth at {elevation_deg} deg"));
        drawn.push((model.clone(), estimate.frequency_hz.clone(), estimate.h1.clone()));
        peaks.push(measured_hz);
    }
    write_figure(
        "structure-servo-elevation.png",
        "An azimuth mode of 6 Hz (zenith) and 7 Hz (horizon) under the servo, held at 15 and 60 deg",
        &drawn,
    );
    // At 15 deg the mode is clamped at 6.92 Hz, at 60 deg at 6.21 Hz: the peak
    // moves with it.
    assert!(
        peaks[0] > 1.1 * peaks[1],
        "the peak at 15 deg ({}) is not above the one at 60 deg ({})",
        peaks[0],
        peaks[1]
    );
    println!("test time {:.1?}", started.elapsed());
}
