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
}
