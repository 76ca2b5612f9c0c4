//! The coupled master on two threads (`Lanes::Two`: the azimuth plant, its controller and the
//! structure on a second thread) against the same master on one: the same values exchanged, so
//! the same run bit for bit, and a unit's error ends the run with that error on either thread instead of leaving the
//! other waiting.

use antenna_sim::scenario::{normal_wind, step_table, tracking_table, SIDEREAL_RATE_DEG_PER_S};
use antenna_sim::{AntennaConfig, CommandTable, Configuration, CoupledAntenna, FmuSet, Lanes, Trace};

fn fmus() -> FmuSet {
    let directory = antenna_fmus::fmu_directory();
    FmuSet::open(&directory).unwrap_or_else(|e| {
        panic!("cannot open the FMUs in {}: {e}; package them first (cargo xtask package)", directory.display())
    })
}

fn trace(fmus: &FmuSet, config: &AntennaConfig, table: &CommandTable, seconds: f64, lanes: Lanes) -> Trace {
    let mut antenna = CoupledAntenna::new(fmus, config, table).unwrap_or_else(|e| panic!("coupled antenna: {e}"));
    antenna.set_lanes(lanes);
    antenna.run(table, seconds, &mut |_| {}).unwrap_or_else(|e| panic!("run on {lanes:?}: {e}"))
}

#[test]
fn two_threads_run_the_realistic_antenna_in_normal_wind_bit_for_bit_as_one() {
    let fmus = fmus();
    let config = AntennaConfig { wind: normal_wind(30.0, 5), ..Configuration::Realistic.antenna_config() };
    assert!(config.structure.is_some(), "the realistic antenna has a structure: this test needs its lane");
    // A step exercises the profiler, both loops, the structure's inertial load and the wind's
    // position dependence; tracking afterwards the friction near rest.
    let table = step_table((30.0, 45.0), (34.0, 49.0), 0.5, 4.0);
    let one = trace(&fmus, &config, &table, 3.0, Lanes::One);
    let two = trace(&fmus, &config, &table, 3.0, Lanes::Two);
    assert_eq!(one.time_s.len(), 3000);
    assert!(one == two, "the traces differ (first row: {:?})", first_difference(&one, &two));
    let moved = one.azimuth_deg.last().unwrap() - one.azimuth_deg[0];
    assert!(moved > 1.0, "the step moved the antenna ({moved} deg): the comparison covers motion");
}

#[test]
fn a_run_in_steps_equals_one_run_whatever_the_lanes_of_each_piece() {
    let fmus = fmus();
    let config = AntennaConfig { wind: normal_wind(30.0, 9), ..Configuration::Realistic.antenna_config() };
    let rate = SIDEREAL_RATE_DEG_PER_S;
    let table = tracking_table((30.0, 45.0), (rate, rate), 2.0);
    let whole = trace(&fmus, &config, &table, 1.0, Lanes::One);
    let pieces = [1, 299, 200, 500];
    for lanes in [[Lanes::One; 4], [Lanes::Two; 4], [Lanes::Two, Lanes::One, Lanes::One, Lanes::Two]] {
        let mut antenna = CoupledAntenna::new(&fmus, &config, &table).unwrap();
        let mut traced = Trace::default();
        for (steps, lanes) in pieces.into_iter().zip(lanes) {
            antenna.set_lanes(lanes);
            antenna.run_steps(&table, steps, Some(&mut traced), &mut |_| {}).unwrap();
        }
        assert!((antenna.time_s() - 1.0).abs() < 1e-12);
        assert!(
            traced == whole,
            "{lanes:?}: pieces differ from one run (first row: {:?})",
            first_difference(&whole, &traced)
        );
    }
}

#[test]
fn an_error_in_either_lane_or_in_the_wind_exchange_ends_the_run_with_that_error() {
    let fmus = fmus();
    let config = AntennaConfig { wind: normal_wind(30.0, 3), ..Configuration::Realistic.antenna_config() };
    let rate = SIDEREAL_RATE_DEG_PER_S;
    let table = tracking_table((30.0, 45.0), (rate, rate), 2.0);
    type Breaker = fn(&mut CoupledAntenna);
    let breakers: [(&str, Breaker); 6] = [
        ("azimuth plant", |a| drop(a.azimuth_plant.terminate())),
        // On two lanes the azimuth controller steps ahead of the loads (the pipelined part).
        ("azimuth controller", |a| drop(a.azimuth_controller.terminate())),
        ("elevation controller", |a| drop(a.elevation_controller.terminate())),
        ("structure", |a| drop(a.structure.as_mut().expect("realistic").terminate())),
        ("elevation plant", |a| drop(a.elevation_plant.terminate())),
        ("wind", |a| drop(a.wind.terminate())),
    ];
    for lanes in [Lanes::One, Lanes::Two] {
        for (unit, break_it) in breakers {
            let mut antenna = CoupledAntenna::new(&fmus, &config, &table).unwrap();
            antenna.set_lanes(lanes);
            antenna.run_steps(&table, 50, None, &mut |_| {}).unwrap();
            // A terminated unit refuses the next set: the run must stop there, on its thread.
            break_it(&mut antenna);
            let error = antenna
                .run_steps(&table, 50, None, &mut |_| {})
                .expect_err(&format!("{lanes:?}: a terminated {unit} must end the run"));
            assert!(
                error.to_string().contains("fmi2SetReal"),
                "{lanes:?}, {unit}: the error names the refused call: {error}"
            );
            assert!((antenna.time_s() - 0.05).abs() < 1e-12, "{lanes:?}, {unit}: no step counted after the error");
        }
    }
}

/// The first trace row where two traces differ, as (row, time).
fn first_difference(a: &Trace, b: &Trace) -> Option<(usize, f64)> {
    let rows = |t: &Trace| t.to_csv().lines().map(str::to_string).collect::<Vec<_>>();
    let (ra, rb) = (rows(a), rows(b));
    ra.iter()
        .zip(&rb)
        .position(|(x, y)| x != y)
        .map(|k| (k, a.time_s.get(k.saturating_sub(1)).copied().unwrap_or(f64::NAN)))
}
