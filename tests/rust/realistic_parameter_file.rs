//! The packaged `resources/realistic.params` of each FMU against the coupled master's realistic
//! antenna: a master that loads only these files (and keeps the Structure FMU's shipped modes)
//! runs, step for step and bit for bit, the antenna the Rust master runs by default. That is
//! what lets fmpy, OMSimulator or Simulink users reproduce the requirement report without the
//! `--trace` export of every override.

use antenna_fmus::parameters::REALISTIC_PARAMETER_FILE;
use antenna_sim::scenario::{normal_wind, tracking_table, SIDEREAL_RATE_DEG_PER_S};
use antenna_sim::{AntennaConfig, Configuration, CoupledAntenna, FmuSet, ParameterValue, Trace};

fn fmus() -> FmuSet {
    let directory = antenna_fmus::fmu_directory();
    FmuSet::open(&directory).unwrap_or_else(|e| {
        panic!("cannot open the FMUs in {}: {e}; package them first (cargo xtask package)", directory.display())
    })
}

fn trace(fmus: &FmuSet, config: &AntennaConfig, seconds: f64) -> Trace {
    let rate = SIDEREAL_RATE_DEG_PER_S;
    let table = tracking_table((30.0, 45.0), (rate, rate), seconds + 1.0);
    let mut antenna = CoupledAntenna::new(fmus, config, &table).unwrap_or_else(|e| panic!("coupled antenna: {e}"));
    antenna.run(&table, seconds, &mut |_| {}).unwrap_or_else(|e| panic!("run: {e}"))
}

#[test]
fn loading_the_packaged_realistic_parameter_files_runs_the_masters_realistic_antenna_bit_for_bit() {
    let fmus = fmus();
    let wind = normal_wind(30.0, 11);
    let realistic = AntennaConfig { wind: wind.clone(), ..Configuration::Realistic.antenna_config() };
    assert!(realistic.wind_load_scale == 1.0, "a load scale is the master's, not a file's: this test needs 1");
    let file = || vec![("parameter_file".to_string(), ParameterValue::Text(REALISTIC_PARAMETER_FILE.to_string()))];
    let from_files = AntennaConfig {
        azimuth_plant: file(),
        elevation_plant: file(),
        azimuth_controller: if realistic.azimuth_controller.is_empty() { Vec::new() } else { file() },
        elevation_controller: if realistic.elevation_controller.is_empty() { Vec::new() } else { file() },
        wind_unit: file(),
        structure: Some(Vec::new()),
        ..AntennaConfig { wind: wind.clone(), ..AntennaConfig::bare() }
    };
    assert_eq!(realistic.structure, Some(Vec::new()), "the realistic structure is the shipped modes file");
    // Two seconds of tracking in normal wind: the sensors' noise, the admittance and the
    // friction all act within it.
    let (a, b) = (trace(&fmus, &realistic, 2.0), trace(&fmus, &from_files, 2.0));
    assert_eq!(a.time_s.len(), 2000);
    let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    for (name, x, y) in [
        ("encoder azimuth", &a.encoder_azimuth_deg, &b.encoder_azimuth_deg),
        ("encoder elevation", &a.encoder_elevation_deg, &b.encoder_elevation_deg),
        ("azimuth", &a.azimuth_deg, &b.azimuth_deg),
        ("elevation", &a.elevation_deg, &b.elevation_deg),
        ("wind torque azimuth", &a.wind_torque_azimuth_nm, &b.wind_torque_azimuth_nm),
    ] {
        assert!(bits(x) == bits(y), "{name} differs");
    }
    let beam = |t: &Trace| t.beam_offset_arcsec.iter().flat_map(|p| p.map(f64::to_bits)).collect::<Vec<_>>();
    assert!(beam(&a) == beam(&b), "the beam offsets differ");
    // The files do change the model: the paper's start values give another run.
    let paper = trace(&fmus, &AntennaConfig { wind, ..Configuration::Paper.antenna_config() }, 2.0);
    assert!(bits(&paper.encoder_azimuth_deg) != bits(&a.encoder_azimuth_deg));
}
