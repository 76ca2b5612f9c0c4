//! Prints the rational fit of Vickery's aerodynamic admittance designed by
//! `admittance::design_vickery` in the form stored in `src/admittance.rs`, with its accuracy.
use fmu_wind::admittance::{design_vickery, AdmittanceSpec};

fn main() {
    let spec = AdmittanceSpec::default();
    let started = std::time::Instant::now();
    let p = design_vickery(&spec);
    let elapsed = started.elapsed();
    let fmt = |v: &[f64]| v.iter().map(|x| format!("{x:e}")).collect::<Vec<_>>().join(", ");
    println!("const VICKERY_ZEROS: [f64; {}] = [{}];", p.zeros.len(), fmt(&p.zeros));
    println!("const VICKERY_POLES: [f64; {}] = [{}];", p.poles.len(), fmt(&p.poles));
    println!(
        "// max |error| over x in [{:e}, {:e}]: {:.4} dB",
        spec.x_lo,
        spec.x_hi,
        p.max_error_db(spec.x_lo, spec.x_hi, 20001)
    );
    for (lo, hi) in [(4.8e-4, 718.0), (1e-3, 10.0), (1e-3, 1.0)] {
        println!("// max |error| over x in [{lo:e}, {hi:e}]: {:.4} dB", p.max_error_db(lo, hi, 20001));
    }
    println!("// designed in {:.1} ms", elapsed.as_secs_f64() * 1e3);
    let spec = fmu_wind::admittance::AdmittanceSpec::davenport_size();
    let d = fmu_wind::admittance::design_davenport_size(&spec);
    println!("const DAVENPORT_SIZE_ZEROS: [f64; {}] = [{}];", d.zeros.len(), fmt(&d.zeros));
    println!("const DAVENPORT_SIZE_POLES: [f64; {}] = [{}];", d.poles.len(), fmt(&d.poles));
    let error = |lo: f64, hi: f64| {
        fmu_wind::prototype::log_grid(lo, hi, 20001)
            .iter()
            .map(|&xi| (d.magnitude_squared_db(xi) - fmu_wind::admittance::davenport_size_chi_squared_db(xi)).abs())
            .fold(0.0, f64::max)
    };
    println!("// max |error| over xi in [{:e}, {:e}]: {:.4} dB", spec.x_lo, spec.x_hi, error(spec.x_lo, spec.x_hi));
    println!(
        "// max |error| over xi in [3.4e-3, 7180] (C = 7-10, the 13.5 m dish at 0.5-25 m/s, 0.001-30 Hz): {:.4} dB",
        error(3.4e-3, 7180.0)
    );
}
