//! Thread safety of the packaged plant FMUs: FMI 2.0 allows a master to run distinct instances
//! of one FMU on several threads at once, and to move an instance between threads as long as
//! calls do not overlap. Instances of both plants, sharing one loaded library each, run
//! concurrently and must give bitwise the results they give one after another.

use antenna_tests::{initialized, open, output_bits, set_reals, test_signal, PLANTS};
use fmu_import::{Fmu, Instance};

fn inputs(plant: &str, ms: usize, seed: u64) -> Vec<(&'static str, f64)> {
    let common = 1.5 * (std::f64::consts::TAU * ms as f64 * 1e-3).sin() + 0.5 * test_signal(ms as u64, seed);
    if plant == "AzimuthPlant" {
        vec![
            ("motor1.current_command", common + 1.0),
            ("motor2.current_command", common - 1.0),
            ("load.disturbance_torque", 1e3 * test_signal(ms as u64, seed + 100)),
        ]
    } else {
        vec![("motor.current_command", common), ("load.disturbance_torque", 1e3 * test_signal(ms as u64, seed + 100))]
    }
}

/// Runs an instance from millisecond `from` to `to` and returns every output's bits at the end
/// of each step.
fn run(fmu: &Fmu, plant: &str, instance: &mut Instance, seed: u64, from: usize, to: usize) -> Vec<Vec<u64>> {
    (from..to)
        .map(|ms| {
            set_reals(fmu, instance, &inputs(plant, ms, seed));
            instance.do_step(ms as f64 * 1e-3, 1e-3).unwrap();
            output_bits(fmu, instance)
        })
        .collect()
}

/// One run's key (plant, seed) and its outputs' bits at every step.
type Run<'a> = ((&'a str, u64), Vec<Vec<u64>>);

const STEPS: usize = 3000;
const INSTANCES_PER_PLANT: u64 = 3;

#[test]
fn instances_on_several_threads_give_the_results_they_give_one_after_another() {
    let fmus: Vec<(&str, Fmu)> = PLANTS.iter().map(|&p| (p, open(p))).collect();
    // Sequential reference: every (plant, seed) on this thread.
    let mut reference = Vec::new();
    for (plant, fmu) in &fmus {
        for seed in 0..INSTANCES_PER_PLANT {
            let mut instance = initialized(fmu, "sequential", &[]);
            reference.push(((*plant, seed), run(fmu, plant, &mut instance, seed, 0, STEPS)));
        }
    }
    // The same runs all at once, each instance on its own thread, created and freed there.
    for round in 0..3 {
        let concurrent: Vec<Run> = std::thread::scope(|scope| {
            let handles: Vec<_> = fmus
                .iter()
                .flat_map(|(plant, fmu)| (0..INSTANCES_PER_PLANT).map(move |seed| (*plant, fmu, seed)))
                .map(|(plant, fmu, seed)| {
                    scope.spawn(move || {
                        let mut instance = initialized(fmu, &format!("thread-{plant}-{seed}"), &[]);
                        ((plant, seed), run(fmu, plant, &mut instance, seed, 0, STEPS))
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().expect("a thread panicked")).collect()
        });
        for ((key, expected), (concurrent_key, got)) in reference.iter().zip(&concurrent) {
            assert_eq!(key, concurrent_key);
            assert!(expected == got, "round {round}: {key:?} on its own thread differs from the sequential run");
        }
    }
}

#[test]
fn an_instance_moved_to_another_thread_continues_exactly() {
    for plant in PLANTS {
        let fmu = open(plant);
        let mut staying = initialized(&fmu, "staying", &[]);
        let expected = run(&fmu, plant, &mut staying, 7, 0, 2000);

        let mut moving = initialized(&fmu, "moving", &[]);
        let mut got = run(&fmu, plant, &mut moving, 7, 0, 1000);
        let (moving, second_half) = std::thread::scope(|scope| {
            scope
                .spawn(|| {
                    let mut moving = moving;
                    let record = run(&fmu, plant, &mut moving, 7, 1000, 2000);
                    (moving, record)
                })
                .join()
                .expect("the thread panicked")
        });
        got.extend(second_half);
        assert!(expected == got, "{plant}: the instance continued differently on another thread");
        // And it is freed on this thread again, when dropped here.
        drop(moving);
    }
}
