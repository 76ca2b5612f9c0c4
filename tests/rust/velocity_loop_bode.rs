//! The closed velocity loop identified on the packaged controller and plant FMUs (velocity
//! mode, white-noise command on a constant speed, H1; `antenna_sim::frequency_response::velocity_loop`, the
//! experiment behind docs/figures/velocity-loop-bode-*.png) against the analytic closed loop of
//! `fmu_controller::linear` and the seed paper's 10-15 Hz.

use antenna_sim::frequency_response::velocity_loop::{identify_velocity_loop, VelocityBode, VelocityBodeConfig};
use antenna_sim::frequency_response::{Axis, MeasuredResponse};

/// Compared up to here, Hz: past the anti-resonance (19-22 Hz) and the resonance (about
/// 35 Hz), and far enough below the 500 Hz Nyquist frequency that the aliases the analytic
/// model leaves out stay negligible.
const MAX_FREQUENCY_HZ: f64 = 100.0;

/// The paper's velocity-loop bandwidth ("about 10-15 Hz").
const PAPER_BANDWIDTH_HZ: (f64, f64) = (10.0, 15.0);

fn identify(axis: Axis) -> VelocityBode {
    let directory = antenna_fmus::fmu_directory();
    let result = identify_velocity_loop(&directory, &VelocityBodeConfig::paper(axis))
        .unwrap_or_else(|e| panic!("{}: {e}; package the FMUs first (cargo xtask package)", axis.name()));
    assert!(
        result.linear_regime_held(),
        "{}: the run left the linear regime (smallest motor speed {} rad/s, largest torque {} N m against the bias fade start {}, {} flank changes)",
        axis.name(),
        result.min_motor_speed_rad_per_s,
        result.max_torque_nm,
        result.bias_fade_start_nm,
        result.flank_changes
    );
    result
}

#[test]
fn the_identified_closed_velocity_loop_matches_the_analytic_one_and_the_papers_bandwidth() {
    for axis in [Axis::Azimuth, Axis::Elevation] {
        let started = std::time::Instant::now();
        let r = identify(axis);
        let all: Vec<usize> = (0..r.frequency_hz.len()).filter(|&i| r.frequency_hz[i] <= MAX_FREQUENCY_HZ).collect();
        let coherent = r.coherent_bins(0.9, MAX_FREQUENCY_HZ);
        let (db, at) = r.max_magnitude_error_db(&coherent);
        let phase = r.max_phase_error_deg(&coherent);
        let measured = r.measured_bandwidth_hz.expect("the measured response falls below -3 dB");
        let analytic = r.analytic_bandwidth_hz.expect("the analytic response falls below -3 dB");
        println!(
            "{}: -3 dB bandwidth {measured:.2} Hz measured, {analytic:.2} Hz analytic (model at {:.2} deg); {} of {} bins up to {MAX_FREQUENCY_HZ} Hz with coherence > 0.9; largest difference {db:.3} dB at {at:.2} Hz, {phase:.2} deg; {:.2} s",
            axis.name(),
            r.model_elevation_deg,
            coherent.len(),
            all.len(),
            started.elapsed().as_secs_f64()
        );
        // The comparison covers the band: the loop is linear in this experiment, so the
        // coherence must be high nearly everywhere, and in particular around the bandwidth.
        assert!(
            coherent.len() * 10 >= all.len() * 9,
            "{}: only {} of {} bins coherent",
            axis.name(),
            coherent.len(),
            all.len()
        );
        assert!(
            (0..r.frequency_hz.len())
                .filter(|&i| (8.0..=16.0).contains(&r.frequency_hz[i]))
                .all(|i| coherent.contains(&i)),
            "{}: the coherence is below 0.9 near the bandwidth",
            axis.name()
        );
        assert!(db < 1.0, "{}: the magnitude differs by {db} dB at {at} Hz", axis.name());
        // One sample of delay more or less would show as 0.36 deg per Hz, 7 deg at 20 Hz.
        assert!(phase < 5.0, "{}: the phase differs by {phase} deg", axis.name());
        assert!(
            (PAPER_BANDWIDTH_HZ.0..=PAPER_BANDWIDTH_HZ.1).contains(&measured),
            "{}: measured bandwidth {measured} Hz outside the paper's {PAPER_BANDWIDTH_HZ:?} Hz",
            axis.name()
        );
        // The estimate interpolates between bins 1/segment apart.
        let resolution = 1.0 / r.config.segment_s;
        assert!(
            (measured - analytic).abs() < resolution,
            "{}: {measured} Hz measured against {analytic} Hz analytic",
            axis.name()
        );
    }
}
