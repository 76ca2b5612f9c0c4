//! Draws `wind-admittance.png` (into out/, or the path given; `cargo xtask docs` writes docs/figures): Vickery's aerodynamic admittance `chi^2(n)` (the
//! formula as Holmes gives it) and the stored rational fit the Wind FMU uses, for the 13.5 m
//! dish at the requirement scenarios' mean speeds, with the fit's dB error; prints the standard
//! deviation of the load gust against the point gust's (the numbers in docs/wind-model.md).
//!
//! `cargo run --release -p fmu-wind --example admittance_figure [output.png]` (default out/wind-admittance.png)
use antenna_plot::{Figure, LegendPosition, Panel};
use fmu_wind::admittance::{
    davenport_size_chi_squared_db, vickery_chi_squared_db, AdmittanceFilter, AdmittanceSpec, VICKERY,
};
use fmu_wind::davenport::Davenport;
use fmu_wind::gust::GustGenerator;
use fmu_wind::prototype::log_grid;
use fmu_wind::shaping::ShapingFilter;

const DIAMETER: f64 = 13.5;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let output = std::env::args().nth(1).unwrap_or_else(|| "out/wind-admittance.png".into());
    let frequency = log_grid(1e-3, 30.0, 801);
    let mut response = Panel::new("Vickery's admittance chi^2(n) = 1 / [1 + (2 n sqrt(A) / U)^(4/3)]^2 (Holmes) and the FMU's rational fit, D = 13.5 m")
        .x_label("n (Hz)")
        .y_label("chi^2 (dB)")
        .log_x()
        .y_range(-70.0, 3.0)
        .legend(LegendPosition::LowerLeft);
    for v in [2.9, 9.8, 25.0] {
        let filter = AdmittanceFilter::vickery(v, DIAMETER)?;
        let formula: Vec<f64> =
            frequency.iter().map(|&n| vickery_chi_squared_db(filter.normalised_frequency(n))).collect();
        let fit: Vec<f64> = frequency.iter().map(|&n| 10.0 * filter.magnitude_squared(n).log10()).collect();
        response = response.line(&format!("formula, U = {v} m/s"), &frequency, &formula).dashed(
            &format!("fit, U = {v} m/s"),
            &frequency,
            &fit,
        );
    }
    let davenport = AdmittanceFilter::davenport_size(9.8, DIAMETER, 8.0)?;
    let formula: Vec<f64> =
        frequency.iter().map(|&n| davenport_size_chi_squared_db(davenport.normalised_frequency(n))).collect();
    let fit: Vec<f64> = frequency.iter().map(|&n| 10.0 * davenport.magnitude_squared(n).log10()).collect();
    response = response
        .line("Davenport size factor (C = 8), U = 9.8 m/s", &frequency, &formula)
        .dashed("its fit", &frequency, &fit);
    let spec = AdmittanceSpec::default();
    let x = log_grid(spec.x_lo, spec.x_hi, 2001);
    let prototype = VICKERY.to_prototype();
    let error: Vec<f64> = x.iter().map(|&x| prototype.magnitude_squared_db(x) - vickery_chi_squared_db(x)).collect();
    let errors = Panel::new("fit minus formula over the fitted band (the same at every U and D)")
        .x_label("x = n sqrt(A) / U")
        .y_label("error (dB)")
        .log_x()
        .legend(LegendPosition::LowerLeft)
        .line("|G(j 2 pi x)|^2 - chi^2(x)", &x, &error)
        .horizontal_line("+0.06 dB", 0.06)
        .horizontal_line("-0.06 dB", -0.06);
    if let Some(folder) = std::path::Path::new(&output).parent().filter(|f| !f.as_os_str().is_empty()) {
        std::fs::create_dir_all(folder)?;
    }
    Figure::new(1100, 1100).panel(response).panel(errors).save_png(&output)?;
    println!("wrote {output}");
    println!(
        "largest fit error over x in [{:e}, {:e}]: {:.4} dB",
        spec.x_lo,
        spec.x_hi,
        prototype.max_error_db(spec.x_lo, spec.x_hi, 20001)
    );
    println!("| admittance | v_m (m/s) | z0 (m) | sigma (m/s) | load-gust sigma (m/s) | ratio | variance ratio |");
    for (v, z0) in [(2.9, 0.026), (9.8, 0.0105), (3.0, 0.4), (9.5, 0.4), (20.0, 0.0105)] {
        let d = Davenport::new(v, 10.0, z0)?;
        for (name, stage) in [
            ("Vickery", AdmittanceFilter::vickery(v, DIAMETER)?),
            ("Davenport C = 7", AdmittanceFilter::davenport_size(v, DIAMETER, 7.0)?),
            ("Davenport C = 8", AdmittanceFilter::davenport_size(v, DIAMETER, 8.0)?),
            ("Davenport C = 10", AdmittanceFilter::davenport_size(v, DIAMETER, 10.0)?),
        ] {
            let g = GustGenerator::with_admittance(ShapingFilter::davenport(&d), Some(stage), 1);
            let (point, load) = (g.filter().stationary_variance(), g.load_stationary_variance());
            let ratio = load / point;
            println!(
                "| {name} | {v} | {z0} | {:.4} | {:.4} | {:.4} | {ratio:.4} |",
                point.sqrt(),
                load.sqrt(),
                ratio.sqrt()
            );
        }
    }
    Ok(())
}
