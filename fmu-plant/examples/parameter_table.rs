//! Prints the quantities derived from the default parameters (reflected inertias, stiffness
//! spreads, anti-resonances, speeds, torque capacities), as quoted in docs/plant-model.md.
//!
//! Run with `cargo run -p fmu-plant --example parameter_table`.

use fmu_plant::{AzimuthParams, ElevationParams};

fn main() {
    let rpm = 60.0 / std::f64::consts::TAU;
    let az = AzimuthParams::default();
    println!("AZIMUTH (N = {})", az.gear_ratio);
    for el in [0.0, 15.0, 45.0, 88.0, 90.0] {
        let t = az.two_mass_at(el);
        println!(
            "  el {el:5.1} deg: J_axis {:.4e} kg m^2, J_L refl {:.4e} (2 J_M {:.4e}, ratio {:.2}), K_s refl {:.2} N m/rad, \
             K_cv refl {:.4e}, f_AR {:.2} Hz, f_R {:.2} Hz, zeta_AR {:.3}",
            az.axis_inertia_kg_m2(el),
            t.load_inertia,
            t.motor_inertia,
            t.load_inertia / t.motor_inertia,
            t.shaft_stiffness,
            t.cross_coupled_damping,
            t.anti_resonance_hz(),
            t.resonance_rad_per_s() / std::f64::consts::TAU,
            t.anti_resonance_damping_ratio()
        );
    }
    let m = az.motors[0];
    println!(
        "  motor speed at 2 deg/s: {:.0} rpm; peak axis torque (both motors at the current limit) {:.3e} N m; \
         peak acceleration at 15 deg {:.2} deg/s^2",
        az.gear_ratio * 2f64.to_radians() * rpm,
        2.0 * m.torque_constant_nm_per_a * m.current_limit_a * az.gear_ratio,
        (2.0 * m.torque_constant_nm_per_a * m.current_limit_a * az.gear_ratio
            / (az.axis_inertia_kg_m2(15.0) + 2.0 * m.inertia_kg_m2 * az.gear_ratio.powi(2)))
        .to_degrees()
    );
    println!(
        "  friction at the motor side: motors 2 x {} N m, bearing {:.3} N m (axis {} N m); backlash {:.1} arcsec axis = {:.3} motor rad",
        m.friction.coulomb_nm,
        az.bearing_friction.coulomb_nm / az.gear_ratio,
        az.bearing_friction.coulomb_nm,
        az.pinion_backlash_rad[0].to_degrees() * 3600.0,
        az.pinion_backlash_rad[0] * az.gear_ratio
    );
    println!("  encoder count {:.4} arcsec", 360.0 * 3600.0 / (1u64 << az.encoder_bits) as f64);

    let el = ElevationParams::default();
    let j = &el.jackscrew;
    println!("ELEVATION (n_s = {:.1} motor rad per m of nut travel)", j.motor_rad_per_m());
    let mut k_axis = Vec::new();
    let mut k_refl = Vec::new();
    let mut ratios = Vec::new();
    let mut f = Vec::new();
    for i in 0..=770 {
        let deg = el.travel_min_deg + (el.travel_max_deg - el.travel_min_deg) * i as f64 / 770.0;
        k_axis.push(el.axis_stiffness_at(deg));
        k_refl.push(el.two_mass_at(deg).shaft_stiffness);
        ratios.push(el.ratio_at(deg));
        f.push(el.anti_resonance_hz(deg));
    }
    let spread = |v: &[f64]| {
        let (lo, hi) = v.iter().fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
        (lo, hi, (hi - lo) / hi)
    };
    for deg in [15.0, 30.0, 45.0, 60.0, 75.0, 88.0, 92.0] {
        let t = el.two_mass_at(deg);
        let rad = f64::to_radians(deg);
        println!(
            "  el {deg:5.1} deg: L {:.3} m, h {:.3} m, nut {:.3} m, N {:.0}, k {:.3e} N/m, K_axis {:.3e} N m/rad, \
             K_s refl {:.2}, J_L refl {:.3e} (J_M {:.1e}, ratio {:.2}), f_AR {:.2} Hz, zeta_AR {:.3}",
            j.actuator_length_m(rad),
            j.lever_arm_m(rad),
            j.nut_position_m(rad),
            el.ratio_at(deg),
            j.axial_stiffness_n_per_m(rad),
            el.axis_stiffness_at(deg),
            t.shaft_stiffness,
            t.load_inertia,
            t.motor_inertia,
            t.load_inertia / t.motor_inertia,
            t.anti_resonance_hz(),
            t.anti_resonance_damping_ratio()
        );
    }
    let (ka_lo, ka_hi, ka_spread) = spread(&k_axis);
    let (kr_lo, kr_hi, kr_spread) = spread(&k_refl);
    let (n_lo, n_hi, _) = spread(&ratios);
    let (f_lo, f_hi, _) = spread(&f);
    println!("  K_axis {ka_lo:.3e} .. {ka_hi:.3e} N m/rad, spread {:.1} % (of max)", 100.0 * ka_spread);
    println!("  K_s reflected {kr_lo:.2} .. {kr_hi:.2} N m/rad, spread {:.1} %", 100.0 * kr_spread);
    println!(
        "  N {n_lo:.0} .. {n_hi:.0}; motor speed for 1 deg/s at the largest N: {:.0} rpm",
        n_hi * 1f64.to_radians() * rpm
    );
    println!("  f_AR {f_lo:.2} .. {f_hi:.2} Hz over {} .. {} deg", el.travel_min_deg, el.travel_max_deg);
    let m = el.motor;
    println!(
        "  peak axis torque at the smallest N: {:.3e} N m; motor-side Coulomb friction {:.3} N m (motor {} + screw {} / G), pivot {:.3} N m at N = {n_lo:.0}",
        m.torque_constant_nm_per_a * m.current_limit_a * n_lo,
        m.friction.coulomb_nm + j.screw_friction.coulomb_nm / j.gearbox_ratio,
        m.friction.coulomb_nm,
        j.screw_friction.coulomb_nm,
        el.pivot_friction.coulomb_nm / n_lo
    );
}
