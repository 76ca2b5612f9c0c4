//! Prints the expected 3-s gust factors of Davenport's spectrum at z = 10 m, and the roughness
//! lengths that reproduce the specification's gust factors, for several averaging periods.
use fmu_wind::davenport::{expected_gust, roughness_for_gust_factor, Davenport};

fn main() {
    let scenarios = [("optimal", 2.9, 4.1), ("normal", 9.8, 13.4)];
    println!(
        "averaging period | scenario | target G | z0 for target (m) | I = sqrt(6 kappa) | g | sigma_band/v | nu (Hz)"
    );
    for t0 in [60.0, 300.0, 600.0, 3600.0] {
        for (name, v, gust) in scenarios {
            let z0 = roughness_for_gust_factor(v, 10.0, gust / v, 3.0, t0).unwrap();
            let d = Davenport::new(v, 10.0, z0).unwrap();
            let e = expected_gust(&d, 3.0, t0);
            println!(
                "{t0:>6} s | {name:>7} | {:.3} | {z0:.4} | {:.3} | {:.2} | {:.3} | {:.3}",
                gust / v,
                d.turbulence_intensity(),
                e.peak_factor,
                e.sigma_band / v,
                e.crossing_rate_hz
            );
        }
    }
    println!();
    println!("gust factor G (3 s in 600 s) for given z0:");
    for z0 in [0.01, 0.0105, 0.02, 0.026, 0.03, 0.05, 0.1, 0.4] {
        let g: Vec<String> = [2.9, 9.8]
            .iter()
            .map(|&v| format!("{:.3}", expected_gust(&Davenport::new(v, 10.0, z0).unwrap(), 3.0, 600.0).gust_factor))
            .collect();
        println!(
            "z0 = {z0:<6} m: I = {:.3}, G(2.9) = {}, G(9.8) = {}",
            Davenport::new(1.0, 10.0, z0).unwrap().turbulence_intensity(),
            g[0],
            g[1]
        );
    }
}
