//! The two-encoder check: what the measured twist (motor encoder referred to the axis minus the
//! load encoder) says that the torque equations cannot.
//!
//! The twist of a drive path is its shaft torque over its stiffness, plus the lost motion at
//! the contact side, plus the encoders' zero offsets. Regressed on those terms it splits into:
//! - a **timing skew** between the encoders: a load encoder read `tau` later than the motor
//!   encoder adds `tau v_L` to the twist, a term proportional to the load speed that no
//!   stiffness, backlash or inertia produces (a load-side viscous torque would, as `c v_L / K`,
//!   but then with a different `tau` on every axis of a robot, not one number). Left in the
//!   data, it reads as load-side damping in a two-mass model and as a phase error everywhere;
//!   it is a property of the data acquisition, so the tool corrects the data (the load encoder
//!   is shifted back by `tau`) and validates again, rather than adding it to the plant;
//! - the **compliance** `1/K` and the **lost motion** `b`, against the shaft torque the model
//!   says the motor delivers into the path (measured torque less motor inertia, friction and
//!   cogging, as the plant FMU puts its friction at the motor). With a rigid starting set these
//!   are the drive path the model lacks; they are reported with their uncertainty. They are
//!   not written into the corrected set, because a compliant plant also needs the split of
//!   the inertia between motor and load, which a rigid set does not have; with a two-mass
//!   starting set they are the candidate library's stiffness and backlash, judged there;
//! - a **position-dependent twist**, a smooth function of the axis angle that no torque
//!   explains: the gear's transmission error and the encoders' eccentricity. Reported, and kept
//!   in the regression so that its slow drift does not hide the other terms.
//!
//! Standard deviations come from least squares with the residual's correlation time (the
//! effective number of independent samples); a term is significant when its Wald statistic
//! passes the level of a [`TwistOptions::z_threshold`]-sigma test and it adds at least
//! [`TwistOptions::min_effect_to_noise`] times the twist's sensor noise in RMS. A skew must also
//! be at least [`TwistOptions::min_skew_samples`] of a sample interval: below that it changes
//! nothing a sampled comparison can see.

use super::equation_error::{cogging_torque, static_friction_curve, EquationData, Structure};
use super::parameters::{names, ParameterSet};
use crate::measured_log::{MeasuredLog, Signal};
use antenna_dsp::conditioning::shift_samples;
use antenna_dsp::weighted_least_squares;

/// Thresholds of the twist check. Documented in docs/validation.md.
#[derive(Debug, Clone)]
pub struct TwistOptions {
    pub z_threshold: f64,
    pub min_effect_to_noise: f64,
    pub min_skew_samples: f64,
}

impl Default for TwistOptions {
    fn default() -> Self {
        TwistOptions { z_threshold: 5.0, min_effect_to_noise: 3.0, min_skew_samples: 0.1 }
    }
}

/// One fitted term of the twist.
#[derive(Debug, Clone, PartialEq)]
pub struct TwistTerm {
    pub name: &'static str,
    pub unit: &'static str,
    pub value: f64,
    pub sd: f64,
    /// RMS of what the term adds to the twist (rad).
    pub rms: f64,
    pub significant: bool,
}

/// What the twist says.
#[derive(Debug, Clone, PartialEq)]
pub struct TwistAnalysis {
    pub structure: Structure,
    /// The samples the regression used (the motor sliding, after the search).
    pub samples: usize,
    /// Sensor noise of the twist, from the two encoders' noise estimates (rad).
    pub noise: f64,
    /// Correlation time of the residual (samples).
    pub correlation_time: f64,
    /// Skew (s), compliance change (rad/N m: 1/K less the model's 1/K), lost motion change
    /// (rad) and the position-dependent twist (its RMS, rad), in that order.
    pub terms: Vec<TwistTerm>,
    /// RMS (rad) of the measured twist less the model's twist (and its best constant offset),
    /// and after the significant terms are added.
    pub rms_before: f64,
    pub rms_after: f64,
    /// Time (s), the measured twist less the model's (centred), and what the constant and the
    /// significant terms fit of it (rad), for the figure.
    pub time: Vec<f64>,
    pub before: Vec<f64>,
    pub fitted: Vec<f64>,
}

impl TwistAnalysis {
    pub fn skew(&self) -> &TwistTerm {
        &self.terms[0]
    }

    pub fn compliance(&self) -> &TwistTerm {
        &self.terms[1]
    }

    pub fn lost_motion(&self) -> &TwistTerm {
        &self.terms[2]
    }

    pub fn position_dependent(&self) -> &TwistTerm {
        &self.terms[3]
    }

    /// The skew to correct the data by, when it is significant.
    pub fn claimed_skew(&self) -> Option<f64> {
        self.skew().significant.then_some(self.skew().value)
    }

    /// The stiffness the compliance term implies when the starting set is rigid (N m/rad,
    /// with its standard deviation).
    pub fn rigid_stiffness(&self) -> Option<(f64, f64)> {
        let c = self.compliance();
        (self.structure != Structure::TwoMass && c.significant && c.value > 0.0)
            .then(|| (1.0 / c.value, c.sd / (c.value * c.value)))
    }
}

/// The shaft torque the model says the motor delivers into the drive path (axis side, N m):
/// the measured torque (delayed and scaled as the parameters say) less the motor's inertia,
/// viscous and static friction and cogging.
pub fn motor_side_shaft_torque(data: &EquationData, params: &ParameterSet) -> Vec<f64> {
    let gear = data.gear_ratio;
    let motor_inertia = params.value(names::MOTOR_INERTIA) * gear * gear;
    let viscous = params.value(names::VISCOUS);
    let scale = params.value(names::TORQUE_CONSTANT_SCALE);
    let delay = params.value(names::DELAY);
    let torque = if delay != 0.0 { data.torque_delayed(delay) } else { data.torque.clone() };
    let friction =
        data.smooth(&data.motor_vel_inner.iter().map(|&v| static_friction_curve(params, v)).collect::<Vec<_>>());
    let cogging = cogging_torque(data, params);
    (0..data.len())
        .map(|i| {
            scale * torque[i]
                - motor_inertia * data.motor_acc[i]
                - viscous * data.motor_vel[i]
                - friction[i]
                - cogging[i]
        })
        .collect()
}

/// Analyses the twist of a two-encoder log with a parameter set (normally the corrected one,
/// so the motor-side friction is the fitted one). `None` for a one-encoder log.
///
/// Samples where the motor sticks are left out, as in the torque equation: the friction that
/// holds a sticking motor is whatever the drive asks of it up to the breakaway level, so no
/// static law gives the shaft torque there, and the model's twist (the shaft torque over the
/// stiffness) misses the measured one by up to the friction level over the stiffness. On the
/// second generator's logs (LuGre friction) that misfit read as a compliance change of -1.7e-8
/// rad/(N m) (-65 %) at 14 sigma and made the skew's standard deviation 0.12-0.20 ms; on the
/// moving samples alone the compliance change is below 3e-9 and the skew's sd 5e-6 to 5e-5 s.
pub fn analyse(data: &EquationData, params: &ParameterSet, options: &TwistOptions) -> Option<TwistAnalysis> {
    let used = data.sliding();
    let count = used.iter().filter(|u| **u).count();
    if data.structure == Structure::Rigid || count < 50 {
        return None;
    }
    let n = data.len();
    // The shaft torque rests on the motor-side friction, whose searched values can stand in
    // for part of a skew; on a two-mass set it is taken from the total-torque equation, where
    // the skew cancels.
    let refitted = (data.structure == Structure::TwoMass).then(|| total_torque_friction(data, params));
    let params = refitted.as_ref().unwrap_or(params);
    let TwistRegression { target, columns, two_mass } = twist_regression(data, params);
    // (name, unit, columns) per term; the constant (encoder offsets) is a nuisance.
    let groups: [(&'static str, &'static str, std::ops::Range<usize>); 4] = [
        ("encoder timing skew (load encoder behind motor encoder)", "s", 1..2),
        (
            if two_mass { "path compliance change (1/K less the model's 1/K)" } else { "path compliance 1/K" },
            "rad/(N m)",
            2..3,
        ),
        (if two_mass { "lost motion change" } else { "lost motion (backlash width)" }, "rad", 3..4),
        ("position-dependent twist (transmission error, encoder eccentricity): RMS", "rad", 4..7),
    ];
    let weights: Vec<f64> = used.iter().map(|&u| f64::from(u8::from(u))).collect();
    let (beta, inverse) = weighted_least_squares(&columns, &target, &weights);
    let part = |coefficients: &[f64], range: std::ops::Range<usize>, offset: usize| -> Vec<f64> {
        (0..n).map(|i| range.clone().map(|k| coefficients[k - offset] * columns[k][i]).sum::<f64>()).collect()
    };
    let centred_rms = |v: &[f64]| centred_rms_over(v, &used);
    let full = part(&beta, 0..columns.len(), 0);
    // The residual of the samples used, in their order.
    let residual: Vec<f64> = (0..n).filter(|&i| used[i]).map(|i| target[i] - full[i]).collect();
    let correlation_time = super::stats::correlation_time(&residual);
    let variance =
        residual.iter().map(|r| r * r).sum::<f64>() / residual.len().saturating_sub(columns.len()).max(1) as f64;
    let noise = (data.motor_pos_sigma.powi(2) + data.load_pos_sigma.powi(2)).sqrt();
    // A term's Wald statistic is tested at the level of a two-sided z-test at z_threshold.
    let level = antenna_dsp::distributions::chi_squared_sf(options.z_threshold * options.z_threshold, 1.0);
    let terms: Vec<TwistTerm> = groups
        .iter()
        .map(|(name, unit, range)| {
            let k = range.len();
            let covariance = |a: usize, b: usize| inverse[(a, b)] * variance * correlation_time;
            let wald = super::stats::wald(&beta, covariance, range.clone());
            let rms = centred_rms(&part(&beta, range.clone(), 0));
            let significant = antenna_dsp::distributions::chi_squared_sf(wald, k as f64) < level
                && rms >= options.min_effect_to_noise * noise;
            let (value, sd) = if k == 1 {
                (beta[range.start], covariance(range.start, range.start).sqrt())
            } else {
                (rms, rms / wald.max(f64::MIN_POSITIVE).sqrt())
            };
            TwistTerm { name, unit, value, sd, rms, significant }
        })
        .collect();
    let mut terms = terms;
    if terms[0].value.abs() < options.min_skew_samples * data.dt {
        terms[0].significant = false;
    }
    // With a two-mass starting set the model's own twist rests on the motor-side friction
    // model, whose form errors move the compliance and lost-motion terms; those effects are
    // the candidate library's stiffness and backlash, judged on both torque equations there.
    if two_mass {
        terms[1].significant = false;
        terms[2].significant = false;
    }
    let rms_before = centred_rms(&target);
    let (fitted, rms_after) = refit_significant(&columns, &terms, &groups, &target, &weights);
    let mean_target = target.iter().sum::<f64>() / n as f64;
    Some(TwistAnalysis {
        structure: data.structure,
        samples: count,
        noise,
        correlation_time,
        terms,
        rms_before,
        rms_after,
        time: data.time.clone(),
        before: target.iter().map(|t| t - mean_target).collect(),
        fitted: fitted.iter().map(|f| f - mean_target).collect(),
    })
}

/// The parameter set with its motor-side viscous and Coulomb friction re-estimated on the
/// total-torque equation (the motor and load equations summed, axis side) of a two-mass log.
///
/// A load encoder read `tau` late adds `tau v_L` to the measured twist, which puts `K tau v_L`
/// into the motor equation and takes it out of the load equation. A motor-side viscous
/// friction reproduces the first but for the twist rate, so a search on the skewed data finds
/// part of the skew as a viscous (or a Coulomb) change, and a shaft torque computed with it
/// hides that part of the skew from the twist. In the sum of the two equations the twist, and
/// with it the skew, cancels, while every motor-side friction stays: the friction fitted there
/// is the drive's. The constant, the axis acceleration and the first harmonic of the angle are
/// fitted beside it, so that an offset, an inertia or an unbalance the set lacks does not move
/// the friction.
pub(crate) fn total_torque_friction(data: &EquationData, params: &ParameterSet) -> ParameterSet {
    let n = data.len();
    let shaft = motor_side_shaft_torque(data, params);
    let load_inertia = params.value(names::LOAD_INERTIA);
    let amplitude = params.value(names::UNBALANCE_TORQUE);
    let phase = params.value(names::UNBALANCE_PHASE);
    let offset = params.value(names::TORQUE_OFFSET);
    let disturbance = data.disturbance.as_deref();
    // What the motor side delivers less what the load side takes (both axis side): the
    // total-torque residual, in which the shaft's twist terms have cancelled.
    let residual: Vec<f64> = (0..n)
        .map(|i| {
            let load_side = load_inertia * data.load_acc[i] + amplitude * (data.angle[i] + phase).cos() + offset
                - disturbance.map_or(0.0, |d| d[i]);
            shaft[i] - load_side
        })
        .collect();
    let sign =
        data.smooth(&data.motor_vel_inner.iter().map(|&v| if v == 0.0 { 0.0 } else { v.signum() }).collect::<Vec<_>>());
    let columns = vec![
        vec![1.0; n],
        data.motor_vel.clone(),
        sign,
        data.motor_acc.clone(),
        data.angle.iter().map(|a| a.cos()).collect(),
        data.angle.iter().map(|a| a.sin()).collect(),
    ];
    // Sticking samples are left out, as in the motor equation: friction there is not a
    // function of the speed.
    let weights: Vec<f64> = data.sliding().iter().map(|&s| f64::from(u8::from(s))).collect();
    let (beta, _) = weighted_least_squares(&columns, &residual, &weights);
    let mut refitted = params.clone();
    if beta.iter().all(|b| b.is_finite()) {
        refitted.set(names::VISCOUS, params.value(names::VISCOUS) + beta[1]);
        refitted.set(names::COULOMB, params.value(names::COULOMB) + beta[2]);
        if let Some(stat) = params.get(names::STATIC) {
            refitted.set(names::STATIC, stat + beta[2]);
        }
    }
    refitted
}

/// The twist the model does not explain, and the columns that regress it: a constant (encoder
/// offsets), the axis speed (a timing skew between the encoders), the shaft torque (a
/// compliance), the contact sign (lost motion) and three Legendre polynomials of the angle.
pub(crate) struct TwistRegression {
    pub(crate) target: Vec<f64>,
    pub(crate) columns: Vec<Vec<f64>>,
    two_mass: bool,
}

pub(crate) fn twist_regression(data: &EquationData, params: &ParameterSet) -> TwistRegression {
    let n = data.len();
    let shaft = motor_side_shaft_torque(data, params);
    // The model's own twist: the path deflection under the shaft torque for a two-mass set,
    // nothing for a rigid one.
    let (model_twist, backlash, two_mass) = if data.structure == Structure::TwoMass {
        let stiffness = params.value(names::STIFFNESS);
        let damping = params.value(names::DAMPING);
        let twist: Vec<f64> = (0..n).map(|i| (shaft[i] - damping * data.twist_rate[i]) / stiffness).collect();
        (twist, params.value(names::BACKLASH_WIDTH), true)
    } else {
        (vec![0.0; n], 0.0, false)
    };
    let width = (0.02 * antenna_dsp::rms(&shaft)).max(data.torque_sigma).max(f64::MIN_POSITIVE);
    // Half the smoothed sign of the shaft torque: its coefficient is the lost-motion width b.
    let contact: Vec<f64> = shaft.iter().map(|t| 0.5 * (t / width).tanh()).collect();
    let target: Vec<f64> = (0..n).map(|i| data.twist[i] - model_twist[i] - backlash * contact[i]).collect();
    // A smooth function of the axis angle (Legendre polynomials of order 1-3 over the angle
    // range): the gear's transmission error and the encoders' eccentricity, which no torque
    // explains. Without it their slow drift would stand in the residual, lengthen its
    // correlation time and hide the terms above.
    let (low, high) = data.load_pos.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &q| (a.min(q), b.max(q)));
    let span = (high - low).max(f64::MIN_POSITIVE);
    let x: Vec<f64> = data.load_pos.iter().map(|q| 2.0 * (q - low) / span - 1.0).collect();
    let mut columns = vec![vec![1.0; n], data.load_vel.clone(), shaft.clone(), contact];
    columns.push(x.clone());
    columns.push(x.iter().map(|x| 1.5 * x * x - 0.5).collect());
    columns.push(x.iter().map(|x| 2.5 * x * x * x - 1.5 * x).collect());
    TwistRegression { target, columns, two_mass }
}

/// After: the constant and the significant terms, refitted together; the fit and its RMS
/// misfit.
fn refit_significant(
    columns: &[Vec<f64>],
    terms: &[TwistTerm],
    groups: &[(&'static str, &'static str, std::ops::Range<usize>)],
    target: &[f64],
    weights: &[f64],
) -> (Vec<f64>, f64) {
    let n = target.len();
    let mut chosen: Vec<Vec<f64>> = vec![columns[0].clone()];
    for (term, (_, _, range)) in terms.iter().zip(groups) {
        if term.significant {
            chosen.extend(range.clone().map(|k| columns[k].clone()));
        }
    }
    let (refit, _) = weighted_least_squares(&chosen, target, weights);
    let fitted: Vec<f64> = (0..n).map(|i| chosen.iter().zip(&refit).map(|(c, b)| b * c[i]).sum::<f64>()).collect();
    // The RMS over the samples the fit used (those with weight).
    let (sum, count) = target
        .iter()
        .zip(&fitted)
        .zip(weights)
        .filter(|(_, w)| **w > 0.0)
        .fold((0.0, 0usize), |(sum, count), ((t, f), _)| (sum + (t - f).powi(2), count + 1));
    let rms_after = (sum / count.max(1) as f64).sqrt();
    (fitted, rms_after)
}

/// RMS about its mean of `v` over the samples `used` marks.
fn centred_rms_over(v: &[f64], used: &[bool]) -> f64 {
    let picked: Vec<f64> = v.iter().zip(used).filter(|(_, u)| **u).map(|(x, _)| *x).collect();
    let count = picked.len().max(1) as f64;
    let mean = picked.iter().sum::<f64>() / count;
    (picked.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / count).sqrt()
}

/// The log with its load encoder read `skew` seconds earlier (the value logged `skew` later),
/// which undoes a load encoder that lags the motor encoder by `skew`. Cubic interpolation on a
/// uniform log, linear on an uneven one; the ends are held.
pub fn shift_load_encoder(log: &MeasuredLog, skew: f64) -> MeasuredLog {
    shift_signals(log, &[Signal::LoadPos, Signal::LoadVel], skew)
}

/// The log with the columns of `signals` read `skew` seconds earlier (each row takes the value
/// logged `skew` later). Cubic interpolation on a uniform log, linear on an uneven one; the
/// ends are held.
pub fn shift_signals(log: &MeasuredLog, signals: &[Signal], skew: f64) -> MeasuredLog {
    let mut out = log.clone();
    let dt = log.sample_interval();
    let uneven = log.time.windows(2).any(|w| ((w[1] - w[0]) / dt - 1.0).abs() > 0.01);
    for channel in out.channels.iter_mut().filter(|c| signals.contains(&c.signal)) {
        channel.values = if uneven {
            log.time
                .iter()
                .map(|&t| antenna_dsp::conditioning::interpolate(&log.time, &channel.values, t + skew))
                .collect()
        } else {
            shift_samples(&channel.values, skew / dt)
        };
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measured_log::parse_str;

    /// A two-encoder log of a rigid drive moving sinusoidally, its load encoder read `skew`
    /// late, with torque J a + viscous v.
    fn rigid_log(skew: f64) -> MeasuredLog {
        let dt = 0.004;
        let mut text = String::from("time_s,motor_torque_Nm,motor_pos_rad,load_pos_rad\n");
        for i in 0..2500 {
            let t = i as f64 * dt;
            let q = |t: f64| 0.3 * (1.3 * t).sin() + 0.1 * (3.1 * t).sin();
            let v = 0.3 * 1.3 * (1.3 * t).cos() + 0.1 * 3.1 * (3.1 * t).cos();
            let a = -0.3 * 1.69 * (1.3 * t).sin() - 0.1 * 9.61 * (3.1 * t).sin();
            let torque = (500.0 * a + 2000.0 * v) / 100.0;
            text.push_str(&format!("{t},{torque},{},{}\n", q(t), q(t - skew)));
        }
        parse_str(&text).unwrap()
    }

    fn rigid_params() -> ParameterSet {
        let mut p = ParameterSet::new();
        p.set(names::GEAR_RATIO, 100.0);
        p.set(names::MOTOR_INERTIA, 0.05);
        p.set(names::TORQUE_CONSTANT, 1.0);
        p.set(names::VISCOUS, 2000.0);
        p
    }

    #[test]
    fn a_load_encoder_read_late_is_found_as_a_timing_skew() {
        let log = rigid_log(0.003);
        let params = rigid_params();
        let data = crate::equation_error::prepare(&log, &params, &Default::default()).unwrap();
        let twist = analyse(&data, &params, &TwistOptions::default()).unwrap();
        let skew = twist.claimed_skew().expect("skew claimed");
        assert!((skew - 0.003).abs() < 1e-4, "{skew}");
        assert!(twist.rms_after < 0.05 * twist.rms_before, "{} {}", twist.rms_after, twist.rms_before);
        assert!(!twist.compliance().significant && !twist.lost_motion().significant);
    }

    /// A two-encoder log of a two-mass drive moving sinusoidally (gear 100, K = 1e7 N m/rad,
    /// load inertia 500 kg m^2, motor-side viscous 2000 N m s/rad), its load encoder read
    /// `skew` late.
    fn two_mass_log(skew: f64) -> MeasuredLog {
        let dt = 0.002;
        let (k, load_inertia, motor_inertia, viscous) = (1e7, 500.0, 0.02 * 100.0 * 100.0, 2000.0);
        // Load angle and its first four derivatives.
        let load = |t: f64| {
            [(0.3, 1.3), (0.1, 3.1), (0.02, 7.3)].iter().fold([0.0; 5], |mut d, (x, w)| {
                let (sin, cos) = (w * t).sin_cos();
                let w2 = w * w;
                for (slot, value) in
                    d.iter_mut().zip([x * sin, x * w * cos, -x * w2 * sin, -x * w2 * w * cos, x * w2 * w2 * sin])
                {
                    *slot += value;
                }
                d
            })
        };
        let mut text = String::from("time_s,motor_torque_Nm,motor_pos_rad,load_pos_rad\n");
        for i in 0..20000 {
            let t = i as f64 * dt;
            let [q, v, a, j, snap] = load(t);
            // The load equation: K twist = J_L a_L; the motor leads the load by the twist.
            let ratio = load_inertia / k;
            let (motor_vel, motor_acc) = (v + ratio * j, a + ratio * snap);
            let torque = (motor_inertia * motor_acc + viscous * motor_vel + k * ratio * a) / 100.0;
            text.push_str(&format!("{t},{torque},{},{}\n", q + ratio * a, load(t - skew)[0]));
        }
        parse_str(&text).unwrap()
    }

    fn two_mass_params() -> ParameterSet {
        let mut p = rigid_params();
        p.set(names::STIFFNESS, 1e7);
        p.set(names::LOAD_INERTIA, 500.0);
        p.set(names::DAMPING, 0.0);
        p.set(names::MOTOR_INERTIA, 0.02);
        p
    }

    #[test]
    fn a_viscous_friction_standing_in_for_an_encoder_skew_does_not_hide_it() {
        // A search on the skewed data can take part of the skew (K tau v in the motor
        // equation) as a motor-side viscous change; the skew must still come out whole.
        let tau = 0.001;
        let log = two_mass_log(tau);
        let mut params = two_mass_params();
        let data = crate::equation_error::prepare(&log, &params, &Default::default()).unwrap();
        assert_eq!(data.structure, Structure::TwoMass);
        params.set(names::VISCOUS, 2000.0 - 0.5 * 1e7 * tau);
        let twist = analyse(&data, &params, &TwistOptions::default()).unwrap();
        let skew = twist.claimed_skew().expect("skew claimed");
        assert!((skew - tau).abs() < 0.05 * tau, "{skew}");
    }

    #[test]
    fn encoders_read_together_give_no_skew() {
        let log = rigid_log(0.0);
        let params = rigid_params();
        let data = crate::equation_error::prepare(&log, &params, &Default::default()).unwrap();
        let twist = analyse(&data, &params, &TwistOptions::default()).unwrap();
        assert_eq!(twist.claimed_skew(), None);
    }

    #[test]
    fn shifting_the_load_encoder_undoes_the_skew() {
        let log = rigid_log(0.003);
        let corrected = shift_load_encoder(&log, 0.003);
        let motor = corrected.signal(Signal::MotorPos).unwrap();
        let load = corrected.signal(Signal::LoadPos).unwrap();
        let worst = motor.iter().zip(load).skip(5).take(2490).map(|(m, l)| (m - l).abs()).fold(0.0, f64::max);
        assert!(worst < 1e-6, "{worst}");
    }
}
