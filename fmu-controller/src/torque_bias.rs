//! The azimuth's two-motor features: the torque bias that splits the total torque between the
//! motors so that they push against each other at low torque (taking up the pinion backlash),
//! and the superimposed differential speed controller that keeps the two motors together.
//!
//! Bias law, with `T` the total torque, `b0` the bias, `T_a`/`T_b` the fade start/end:
//!
//! ```text
//! b(T) = b0                                  |T| <= T_a
//!      = b0 (T_b - |T|) / (T_b - T_a)        T_a < |T| < T_b
//!      = 0                                   |T| >= T_b
//! T_1 = T/2 + b(T),   T_2 = T/2 - b(T)
//! ```
//!
//! so `T_1 + T_2 = T` always, both torques are continuous in `T`, and with `T_b - T_a >= 2 b0`
//! neither falls while `T` rises. With the default `T_a = 2 b0` motor 2 holds the negative
//! flank until `T = T_a`, where its torque reaches zero; above `T_b` both drive equally.
//!
//! Differential loop: `Delta = K_d (w_2 - w_1)`, limited, added to motor 1 and subtracted from
//! motor 2. It leaves the sum unchanged and damps the mode in which the two motors swing against
//! each other on their pinion stiffnesses (about 19.5 Hz with the default plant, damping ratio
//! 0.04 on its own).

use crate::params::{DifferentialLoopParams, TorqueBiasParams};

/// The bias `b(T)` for a total torque `T`, both N m.
pub fn bias_torque(total_torque_nm: f64, params: &TorqueBiasParams) -> f64 {
    if !params.enabled {
        return 0.0;
    }
    let magnitude = total_torque_nm.abs();
    if magnitude <= params.fade_start_torque_nm {
        params.bias_torque_nm
    } else if magnitude >= params.fade_end_torque_nm {
        0.0
    } else {
        params.bias_torque_nm * (params.fade_end_torque_nm - magnitude)
            / (params.fade_end_torque_nm - params.fade_start_torque_nm)
    }
}

/// The two motor torques `[T/2 + b, T/2 - b]` for a total torque `T`, N m.
pub fn split_torque(total_torque_nm: f64, params: &TorqueBiasParams) -> [f64; 2] {
    let bias = bias_torque(total_torque_nm, params);
    let half = 0.5 * total_torque_nm;
    [half + bias, half - bias]
}

/// The differential speed controller's gain, N m per rad/s of speed difference: designed as
/// `K_d = 2 pi f J_motor / 2` unless overridden. The speed difference obeys
/// `J_motor d(w_1 - w_2)/dt = 2 Delta + ...`, so this gives a loop crossover at `f`.
pub fn differential_gain(params: &DifferentialLoopParams, motor_inertia_kg_m2: f64) -> f64 {
    params.gain_override_nm_s_per_rad.unwrap_or(std::f64::consts::TAU * params.bandwidth_hz * motor_inertia_kg_m2 / 2.0)
}

/// The differential torque `Delta` added to motor 1 (and subtracted from motor 2), N m.
pub fn differential_torque(motor_speeds_rad_per_s: [f64; 2], gain: f64, params: &DifferentialLoopParams) -> f64 {
    if !params.enabled {
        return 0.0;
    }
    (gain * (motor_speeds_rad_per_s[1] - motor_speeds_rad_per_s[0])).clamp(-params.max_torque_nm, params.max_torque_nm)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> TorqueBiasParams {
        TorqueBiasParams::default()
    }

    fn totals() -> impl Iterator<Item = f64> {
        (-30_000..=30_000).map(|k| k as f64 * 1e-3)
    }

    #[test]
    fn motor_torques_always_sum_to_the_total() {
        for t in totals() {
            let [t1, t2] = split_torque(t, &params());
            assert!((t1 + t2 - t).abs() <= 1e-12 * (1.0 + t.abs()), "T = {t}: {t1} + {t2}");
        }
    }

    #[test]
    fn bias_law_is_continuous_and_never_lets_a_motor_torque_fall_as_demand_rises() {
        let p = params();
        let step = 1e-3;
        let mut previous = split_torque(-30.0, &p);
        for t in totals().skip(1) {
            let now = split_torque(t, &p);
            for k in 0..2 {
                let change = now[k] - previous[k];
                // Continuity: a change no larger than the total's change.
                assert!(change.abs() <= step * (1.0 + 1e-9), "T = {t}: motor {k} jumps by {change}");
                // Monotonicity.
                assert!(change >= -1e-12, "T = {t}: motor {k} torque falls by {change}");
            }
            previous = now;
        }
    }

    #[test]
    fn motors_oppose_each_other_at_low_torque_and_pull_together_at_high_torque() {
        let p = params();
        let [t1, t2] = split_torque(0.0, &p);
        assert_eq!((t1, t2), (p.bias_torque_nm, -p.bias_torque_nm));
        for t in [-0.5 * p.fade_start_torque_nm, 0.5 * p.fade_start_torque_nm] {
            let [t1, t2] = split_torque(t, &p);
            assert!(t1 > 0.0 && t2 < 0.0, "T = {t}: preload lost ({t1}, {t2})");
        }
        for t in [p.fade_end_torque_nm, 2.0 * p.fade_end_torque_nm] {
            assert_eq!(split_torque(t, &p), [t / 2.0, t / 2.0]);
            assert_eq!(split_torque(-t, &p), [-t / 2.0, -t / 2.0]);
        }
        let off = TorqueBiasParams { enabled: false, ..p };
        assert_eq!(split_torque(1.0, &off), [0.5, 0.5]);
    }

    #[test]
    fn differential_torque_slows_the_faster_motor() {
        let p = DifferentialLoopParams::default();
        let gain = differential_gain(&p, 0.006);
        assert!((gain - std::f64::consts::TAU * 15.0 * 0.006 / 2.0).abs() < 1e-15);
        let delta = differential_torque([101.0, 100.0], gain, &p);
        assert!(delta < 0.0, "motor 1 is faster, so it must be braked: {delta}");
        assert_eq!(differential_torque([100.0, 100.0], gain, &p), 0.0);
        assert_eq!(differential_torque([0.0, 1e6], gain, &p), p.max_torque_nm);
        let off = DifferentialLoopParams { enabled: false, ..p };
        assert_eq!(differential_torque([101.0, 100.0], gain, &off), 0.0);
    }
}
