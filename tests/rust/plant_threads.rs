//! Thread safety of the packaged plant FMUs: FMI 2.0 allows a master to run distinct instances
//! of one FMU on several threads at once, and to move an instance between threads as long as
//! calls do not overlap. Instances of both plants, sharing one loaded library each, run
//! concurrently and must give bitwise the results they give one after another. The two plants
//! ship the same library, which the importer loads once for both: an instance on the shared
//! copy must give what it gives on a copy of its own.

use std::sync::Arc;

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

#[test]
fn fmus_that_ship_the_same_library_share_one_loaded_copy() {
    let [azimuth, elevation] = PLANTS.map(open);
    assert!(Arc::ptr_eq(&azimuth.library, &elevation.library), "the two plants loaded their library twice");
    let [azimuth_controller, elevation_controller] = ["AzimuthController", "ElevationController"].map(open);
    assert!(Arc::ptr_eq(&azimuth_controller.library, &elevation_controller.library));
    // Different bytes never share.
    assert!(!Arc::ptr_eq(&azimuth.library, &azimuth_controller.library));
    assert!(!Arc::ptr_eq(&azimuth.library, &open("Wind").library));
}

/// The elevation plant unpacked into a folder of its own, with its model description saying that
/// its library can hold only one instance per process, so that the importer loads it apart.
fn elevation_plant_on_a_library_of_its_own(folder: &std::path::Path) -> Fmu {
    let file = std::fs::File::open(antenna_tests::fmu_path("ElevationPlant")).unwrap();
    zip::ZipArchive::new(file).unwrap().extract(folder).unwrap();
    let description = folder.join("modelDescription.xml");
    let xml = std::fs::read_to_string(&description).unwrap();
    let once = r#"canBeInstantiatedOnlyOncePerProcess="false""#;
    assert!(xml.contains(once), "the plant's description no longer says {once}");
    std::fs::write(&description, xml.replace(once, r#"canBeInstantiatedOnlyOncePerProcess="true""#)).unwrap();
    Fmu::open_unpacked(folder).unwrap()
}

#[test]
fn a_plant_on_the_shared_library_gives_what_it_gives_on_a_library_of_its_own() {
    let azimuth = open("AzimuthPlant");
    let shared = open("ElevationPlant");
    let folder = std::env::temp_dir().join(format!("meerkat-own-library-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&folder);
    let own = elevation_plant_on_a_library_of_its_own(&folder);
    assert!(Arc::ptr_eq(&azimuth.library, &shared.library));
    assert!(!Arc::ptr_eq(&shared.library, &own.library), "a library for one instance per process was shared");

    // Instances of both models interleaved on the shared library, against the elevation plant
    // alone on its own copy.
    let mut azimuth_instance = initialized(&azimuth, "azimuth", &[]);
    let mut on_shared = initialized(&shared, "shared", &[]);
    let mut on_own = initialized(&own, "own", &[]);
    for ms in 0..STEPS {
        set_reals(&azimuth, &mut azimuth_instance, &inputs("AzimuthPlant", ms, 3));
        azimuth_instance.do_step(ms as f64 * 1e-3, 1e-3).unwrap();
        let shared_bits = run(&shared, "ElevationPlant", &mut on_shared, 3, ms, ms + 1);
        let own_bits = run(&own, "ElevationPlant", &mut on_own, 3, ms, ms + 1);
        assert!(shared_bits == own_bits, "step {ms}: the plant on the shared library differs from its own copy");
    }
    drop((on_own, own));
    let _ = std::fs::remove_dir_all(&folder);
}
