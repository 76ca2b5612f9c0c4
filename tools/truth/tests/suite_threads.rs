//! The suite's files do not depend on how many threads generate them.

use antenna_truth::suite::{write_suite, write_suite_parallel, SuiteConfig};
use antenna_truth::TruthConfig;

#[test]
fn a_suite_generated_on_one_or_three_threads_is_the_serial_suite_byte_for_byte() {
    let config = SuiteConfig {
        kinds: vec!["coulomb".into(), "delay".into()],
        sizes: vec![10.0],
        seeds: vec![11],
        clean_seeds: vec![101],
        pairs: Vec::new(),
        base: TruthConfig { duration: 3.0, ..TruthConfig::default() },
        ..SuiteConfig::default()
    };
    let root = std::env::temp_dir().join(format!("suite-threads-{}", std::process::id()));
    let serial = write_suite(&root.join("serial"), &config, &mut |_| {}).unwrap();
    for threads in [1, 3] {
        let dir = root.join(format!("threads-{threads}"));
        let parallel = write_suite_parallel(&dir, &config, threads, &|_| {}).unwrap();
        assert_eq!(parallel, serial, "truths on {threads} threads");
        for entry in std::fs::read_dir(root.join("serial")).unwrap() {
            let name = entry.unwrap().file_name();
            let expected = std::fs::read(root.join("serial").join(&name)).unwrap();
            assert_eq!(std::fs::read(dir.join(&name)).unwrap(), expected, "{name:?} on {threads} threads");
        }
    }
    std::fs::remove_dir_all(&root).unwrap();
}
