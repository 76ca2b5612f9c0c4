//! The integration tests of the packaged FMUs and the repository's rules, as one test binary:
//! each file of this folder is a module (`cargo test --release -p antenna-tests --test
//! integration -- wind_fmu::` runs one of them). `plant_silence` stays a binary of its own: it
//! re-runs itself as a child whose output must stay empty, which the test harness would spoil.

mod controller_fmu;
mod coupled_antenna;
mod coupled_lanes;
mod enumeration_twins;
mod fmu_binaries;
mod house_rules;
mod loop_margins;
mod model_structure;
mod packaging;
mod parameter_table;
mod plant_identification;
mod plant_linear_step;
mod plant_misuse;
mod plant_sensors;
mod plant_state;
mod plant_step_size;
mod plant_threads;
mod pointing_model;
mod realistic_parameter_file;
mod step_arithmetic;
mod structure_fmu;
mod structure_servo;
mod sweep;
mod velocity_loop_bode;
mod wind_fmu;
