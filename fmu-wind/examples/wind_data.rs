//! Writes the data behind the wind-model figures, and prints the headline numbers.
//!
//! * `filter_response.csv`: Eq. 2, the paper's H3/H10 and this crate's Davenport filter, as
//!   one-sided spectra per hertz on Eq. 2's angular-frequency axis, 0.001-30 rad/s, for
//!   v_m = 3 and 9.5 m/s (z = 10 m, z0 = 0.4 m), with dB errors against Eq. 2.
//! * `gust_psd.csv`: Welch estimates from 2 h records (10 ms steps) at 3 and 9.5 m/s, with the
//!   95 % confidence band for the true spectrum, the estimator's exact expectation, the
//!   filter's spectrum and Eq. 2.
//!
//! Usage: `cargo run --release -p fmu-wind --example wind_data [output directory]`
//! (default: `fmu-wind/data`).

use antenna_dsp::{expected_lpsd, lpsd, ChiSquaredInterval};
use fmu_wind::analysis::{record, sample_variance_std, sampled_autocovariance};
use fmu_wind::davenport::Davenport;
use fmu_wind::gust::GustGenerator;
use fmu_wind::prototype::log_grid;
use fmu_wind::shaping::ShapingFilter;
use std::f64::consts::PI;
use std::fmt::Write as _;

fn db(x: f64) -> f64 {
    10.0 * x.log10()
}

fn main() -> std::io::Result<()> {
    let dir = std::env::args()
        .nth(1)
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data"));
    std::fs::create_dir_all(&dir)?;
    let d3 = Davenport::new(3.0, 10.0, 0.4).unwrap();
    let d95 = Davenport::new(9.5, 10.0, 0.4).unwrap();
    let (ours3, ours95) = (ShapingFilter::davenport(&d3), ShapingFilter::davenport(&d95));
    let (h3, h10) = (ShapingFilter::paper(3.0).unwrap(), ShapingFilter::paper(9.5).unwrap());

    // Exact filter responses.
    let mut csv = String::from(
        "omega_rad_s,eq2_v3,h3,ours_v3,eq2_v9p5,h10,ours_v9p5,h3_err_db,ours_v3_err_db,h10_err_db,ours_v9p5_err_db\n",
    );
    for w in log_grid(1e-3, 30.0, 401) {
        let (e3, e95) = (d3.psd_at_omega(w), d95.psd_at_omega(w));
        let (a, b, c, e) = (h3.psd_at_omega(w), ours3.psd_at_omega(w), h10.psd_at_omega(w), ours95.psd_at_omega(w));
        writeln!(
            csv,
            "{w:.6e},{e3:.6e},{a:.6e},{b:.6e},{e95:.6e},{c:.6e},{e:.6e},{:.4},{:.4},{:.4},{:.4}",
            db(a / e3),
            db(b / e3),
            db(c / e95),
            db(e / e95)
        )
        .unwrap();
    }
    std::fs::write(dir.join("filter_response.csv"), csv)?;

    // Paper filters: level and shape against Eq. 2 over 0.01-10 rad/s.
    for (name, f, d) in [("H3", &h3, &d3), ("H10", &h10, &d95)] {
        let errs: Vec<f64> =
            log_grid(0.01, 10.0, 301).iter().map(|&w| db(f.psd_at_omega(w) / d.psd_at_omega(w))).collect();
        let mean = errs.iter().sum::<f64>() / errs.len() as f64;
        let (lo, hi) = errs.iter().fold((f64::MAX, f64::MIN), |(l, h), e| (l.min(e - mean), h.max(e - mean)));
        println!(
            "{name}: variance ratio to 6 kappa v^2 = {:.2} dB; mean log ratio 0.01-10 rad/s = {mean:.2} dB; shape after removing it {lo:+.2}/{hi:+.2} dB; DC gain {:.1} dB",
            db(f.stationary_variance() / d.variance()),
            db(f.magnitude_squared(0.0))
        );
    }
    // Our filter's worst error over 0.001-30 rad/s for v_m in 0.5-25 m/s.
    let mut worst: f64 = 0.0;
    for k in 0..=245 {
        let d = Davenport::new(0.5 + 0.1 * k as f64, 10.0, 0.4).unwrap();
        let f = ShapingFilter::davenport(&d);
        for w in log_grid(1e-3, 30.0, 601) {
            worst = worst.max(db(f.psd_at_omega(w) / d.psd_at_omega(w)).abs());
        }
    }
    println!("Davenport filter: order {}, worst |error| over 0.001-30 rad/s, v_m 0.5-25 m/s: {worst:.4} dB; level correction {:.4} dB", ours3.order(), ours3.level_correction_db());
    for v in [3.0, 9.5, 20.0] {
        let d = Davenport::new(v, 10.0, 0.4).unwrap();
        let f = ShapingFilter::davenport(&d);
        let g = GustGenerator::new(f.clone(), 1);
        let rel = 0.5 * sample_variance_std(&f, 7200.0) / d.variance();
        println!(
            "v_m = {v}: 6 kappa v^2 = {:.5}; Lyapunov continuous {:.5}; discrete at 1/10/100 ms {:.5}/{:.5}/{:.5}; 2 h sample std scatter {:.1} %",
            d.variance(),
            f.stationary_variance(),
            g.discrete_stationary_variance(1e-3),
            g.discrete_stationary_variance(1e-2),
            g.discrete_stationary_variance(1e-1),
            100.0 * rel
        );
    }

    // Welch spectra of 2 h records.
    let mut csv = String::from(
        "v_mean,f_hz,omega_rad_s,psd_estimate,true_psd_ci95_lo,true_psd_ci95_hi,dof,expected_estimate,filter_psd,eq2\n",
    );
    let (step, bins) = (0.01, 8.0);
    for (d, f) in [(&d3, &ours3), (&d95, &ours95)] {
        let r = record(f, 2024, step, 7200.0);
        for e in lpsd(&r, 1.0 / step, &log_grid(0.005, 4.7, 40), bins) {
            let (lo, hi) =
                ChiSquaredInterval::new(e.dof, 0.95).expect("a Welch estimate has positive dof").estimate_factors();
            writeln!(
                csv,
                "{},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{:.1},{:.6e},{:.6e},{:.6e}",
                d.v_mean,
                e.frequency_hz,
                2.0 * PI * e.frequency_hz,
                e.psd,
                e.psd / hi,
                e.psd / lo,
                e.dof,
                expected_lpsd(sampled_autocovariance(f, step), 1.0 / step, e.frequency_hz, bins),
                f.psd_one_sided_per_hz(e.frequency_hz),
                d.psd_one_sided_per_hz(e.frequency_hz)
            )
            .unwrap();
        }
    }
    std::fs::write(dir.join("gust_psd.csv"), csv)?;

    // Timing of one step (release build), at a fixed step size (cached discretisation).
    let mut g = GustGenerator::new(ours95.clone(), 3);
    let n = 5_000_000;
    let start = std::time::Instant::now();
    let mut sink = 0.0;
    for _ in 0..n {
        sink += g.step(0.01);
    }
    let ns = start.elapsed().as_secs_f64() * 1e9 / n as f64;
    println!("one generator step: {ns:.0} ns ({} states, checksum {sink:.3e})", ours95.order());
    println!("wrote {} and {}", dir.join("filter_response.csv").display(), dir.join("gust_psd.csv").display());
    Ok(())
}
