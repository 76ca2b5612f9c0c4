//! Prints the Davenport prototype designed by `prototype::design_prototype` in the form stored
//! in `src/prototype.rs`, with its accuracy.
use fmu_wind::prototype::{design_prototype, PrototypeSpec};

fn main() {
    let spec = PrototypeSpec::default();
    let started = std::time::Instant::now();
    let p = design_prototype(&spec);
    let elapsed = started.elapsed();
    let fmt = |v: &[f64]| v.iter().map(|x| format!("{x:e}")).collect::<Vec<_>>().join(", ");
    println!("const PROTOTYPE_GAIN: f64 = {:e};", p.gain);
    println!("const PROTOTYPE_ZEROS: [f64; {}] = [{}];", p.zeros.len(), fmt(&p.zeros));
    println!("const PROTOTYPE_POLES: [f64; {}] = [{}];", p.poles.len(), fmt(&p.poles));
    println!("// max |error| over the fitted band: {:.4} dB", p.max_error_db(spec.x_lo, spec.x_hi, 20001));
    println!("// designed in {:.1} ms", elapsed.as_secs_f64() * 1e3);
}
