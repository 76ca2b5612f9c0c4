//! The elevation's direction-dependent friction-torque feedforward: a constant torque in the
//! direction of the reference motion, with separate levels for raising and lowering the dish
//! (the jackscrew's friction differs with the direction of the load), built up smoothly over a
//! small velocity band so that the torque command stays continuous through zero velocity.
//!
//! ```text
//! s(x) = x (3 - x^2) / 2 for |x| < 1,  sign(x) otherwise     (C1 at |x| = 1)
//! T_ff(v) = T_up s(v / v_b)    for v >= 0
//!         = T_down s(v / v_b)  for v < 0
//! ```
//!
//! `v` is the reference (feedforward) velocity: the profile's velocity during a step, the
//! command velocity while tracking, the velocity reference in velocity mode. Using the intended
//! motion rather than the loop's corrections keeps the feedforward from flipping sign with
//! every small position correction around a stationary target.

use crate::params::FrictionFeedforwardParams;

/// The smooth odd step `s(x)`: 0 at 0, +-1 for `|x| >= 1`, continuous slope.
pub fn smooth_sign(x: f64) -> f64 {
    if x.abs() >= 1.0 {
        x.signum()
    } else {
        0.5 * x * (3.0 - x * x)
    }
}

/// The feedforward torque (N m at the motor) for a reference velocity (axis rad/s).
pub fn friction_feedforward(reference_velocity_rad_per_s: f64, params: &FrictionFeedforwardParams) -> f64 {
    if !params.enabled {
        return 0.0;
    }
    let x = reference_velocity_rad_per_s / params.velocity_band_deg_per_s.to_radians();
    let level = if x >= 0.0 { params.raising_torque_nm } else { params.lowering_torque_nm };
    level * smooth_sign(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> FrictionFeedforwardParams {
        FrictionFeedforwardParams {
            raising_torque_nm: 0.5,
            lowering_torque_nm: 0.3,
            ..FrictionFeedforwardParams::default()
        }
    }

    #[test]
    fn feedforward_has_the_sign_of_the_motion_and_its_direction_dependent_level() {
        let p = params();
        let band = p.velocity_band_deg_per_s.to_radians();
        assert_eq!(friction_feedforward(2.0 * band, &p), 0.5);
        assert_eq!(friction_feedforward(-2.0 * band, &p), -0.3);
        assert_eq!(friction_feedforward(0.0, &p), 0.0);
        assert!(friction_feedforward(0.1 * band, &p) > 0.0);
        assert!(friction_feedforward(-0.1 * band, &p) < 0.0);
        let off = FrictionFeedforwardParams { enabled: false, ..p };
        assert_eq!(friction_feedforward(2.0 * band, &off), 0.0);
    }

    #[test]
    fn feedforward_is_continuous_with_a_bounded_slope_across_the_band() {
        let p = params();
        let band = p.velocity_band_deg_per_s.to_radians();
        // The steepest slope of level * s(v/v_b) is 1.5 level / v_b, at v = 0.
        let max_slope = 1.5 * 0.5 / band;
        let dv = band * 1e-4;
        let mut previous = friction_feedforward(-3.0 * band, &p);
        for k in 1..=60_000 {
            let v = -3.0 * band + k as f64 * dv;
            let now = friction_feedforward(v, &p);
            assert!((now - previous).abs() <= max_slope * dv * (1.0 + 1e-6), "jump at v = {v}");
            assert!(now >= previous - 1e-15, "not monotonic at v = {v}");
            previous = now;
        }
    }

    #[test]
    fn smooth_sign_has_zero_slope_where_it_saturates() {
        let h = 1e-7;
        let slope_inside = (smooth_sign(1.0) - smooth_sign(1.0 - h)) / h;
        assert!(slope_inside.abs() < 1e-6, "{slope_inside}");
        assert_eq!(smooth_sign(1.0), 1.0);
        assert_eq!(smooth_sign(-1.0), -1.0);
    }
}
