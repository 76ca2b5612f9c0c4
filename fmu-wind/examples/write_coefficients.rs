//! Writes the default coefficient table (`resources/wind_coefficients.csv`) from
//! `fmu_wind::coefficients::reference_model` to standard output.
fn main() {
    print!("{}", fmu_wind::coefficients::reference_table_csv());
}
