//! The binaries inside every packaged FMU: each exports exactly the 44 functions of the FMI 2.0
//! C API (read from the shared object's dynamic symbol table, independently of the loader),
//! loads through the importer, and reports FMI version "2.0" and the "default" types platform.
//! Every `.fmu` in the packaging folder is checked, so FMUs added later are covered.

use std::collections::BTreeSet;
use std::io::Read;

use antenna_tests::packaged_fmus;
use fmu_import::{Fmu, ModelDescription, ALL_FUNCTIONS};

/// The 44 functions of `fmi2Functions.h` (FMI 2.0.x), typed out here from the standard rather
/// than taken from the importer, so that a gap in either list fails this test.
const FMI2_FUNCTIONS: [&str; 44] = [
    // Common functions.
    "fmi2GetTypesPlatform",
    "fmi2GetVersion",
    "fmi2SetDebugLogging",
    "fmi2Instantiate",
    "fmi2FreeInstance",
    "fmi2SetupExperiment",
    "fmi2EnterInitializationMode",
    "fmi2ExitInitializationMode",
    "fmi2Terminate",
    "fmi2Reset",
    "fmi2GetReal",
    "fmi2GetInteger",
    "fmi2GetBoolean",
    "fmi2GetString",
    "fmi2SetReal",
    "fmi2SetInteger",
    "fmi2SetBoolean",
    "fmi2SetString",
    "fmi2GetFMUstate",
    "fmi2SetFMUstate",
    "fmi2FreeFMUstate",
    "fmi2SerializedFMUstateSize",
    "fmi2SerializeFMUstate",
    "fmi2DeSerializeFMUstate",
    "fmi2GetDirectionalDerivative",
    // Model exchange.
    "fmi2EnterEventMode",
    "fmi2NewDiscreteStates",
    "fmi2EnterContinuousTimeMode",
    "fmi2CompletedIntegratorStep",
    "fmi2SetTime",
    "fmi2SetContinuousStates",
    "fmi2GetDerivatives",
    "fmi2GetEventIndicators",
    "fmi2GetContinuousStates",
    "fmi2GetNominalsOfContinuousStates",
    // Co-simulation.
    "fmi2SetRealInputDerivatives",
    "fmi2GetRealOutputDerivatives",
    "fmi2DoStep",
    "fmi2CancelStep",
    "fmi2GetStatus",
    "fmi2GetRealStatus",
    "fmi2GetIntegerStatus",
    "fmi2GetBooleanStatus",
    "fmi2GetStringStatus",
];

/// Names of the defined, globally visible functions in an ELF64 little-endian shared object's
/// dynamic symbol table (`.dynsym`), which is what `dlsym` searches and what stripping keeps.
fn exported_functions(elf: &[u8]) -> Result<BTreeSet<String>, String> {
    let u16_at = |o: usize| elf.get(o..o + 2).map(|b| u16::from_le_bytes([b[0], b[1]])).ok_or("truncated ELF");
    let u32_at = |o: usize| elf.get(o..o + 4).map(|b| u32::from_le_bytes(b.try_into().unwrap())).ok_or("truncated ELF");
    let u64_at = |o: usize| elf.get(o..o + 8).map(|b| u64::from_le_bytes(b.try_into().unwrap())).ok_or("truncated ELF");
    if elf.get(0..4) != Some(b"\x7fELF") || elf.get(4) != Some(&2) || elf.get(5) != Some(&1) {
        return Err("not a 64-bit little-endian ELF file".into());
    }
    let section_offset = u64_at(0x28)? as usize;
    let section_size = u16_at(0x3A)? as usize;
    let sections = u16_at(0x3C)? as usize;
    let section = |i: usize| section_offset + i * section_size;
    const SHT_DYNSYM: u32 = 11;
    let dynsym = (0..sections).find(|&i| u32_at(section(i) + 4) == Ok(SHT_DYNSYM)).ok_or("no .dynsym section")?;
    let (offset, size, link, entry) = (
        u64_at(section(dynsym) + 0x18)? as usize,
        u64_at(section(dynsym) + 0x20)? as usize,
        u32_at(section(dynsym) + 0x28)? as usize,
        u64_at(section(dynsym) + 0x38)? as usize,
    );
    let strings = u64_at(section(link) + 0x18)? as usize;
    let mut names = BTreeSet::new();
    for symbol in (offset..offset + size).step_by(entry.max(1)) {
        let name_offset = u32_at(symbol)? as usize;
        let info = *elf.get(symbol + 4).ok_or("truncated ELF")?;
        let section_index = u16_at(symbol + 6)?;
        let (binding, kind) = (info >> 4, info & 0xF);
        // Defined (section index not SHN_UNDEF), GLOBAL or WEAK, of type FUNC.
        if section_index != 0 && (binding == 1 || binding == 2) && kind == 2 {
            let start = strings + name_offset;
            let end = start
                + elf
                    .get(start..)
                    .ok_or("bad string offset")?
                    .iter()
                    .position(|&b| b == 0)
                    .ok_or("unterminated name")?;
            names.insert(String::from_utf8_lossy(&elf[start..end]).to_string());
        }
    }
    Ok(names)
}

#[test]
fn the_importer_checks_the_full_list_of_fmi2_functions() {
    let standard: BTreeSet<&str> = FMI2_FUNCTIONS.into_iter().collect();
    let importer: BTreeSet<&str> = ALL_FUNCTIONS.into_iter().collect();
    assert_eq!(standard.len(), 44, "the list above has duplicates");
    assert_eq!(importer, standard, "fmu_import::ALL_FUNCTIONS is not the FMI 2.0 function list");
}

#[test]
fn every_packaged_fmu_exports_exactly_the_44_fmi2_functions() {
    let standard: BTreeSet<String> = FMI2_FUNCTIONS.iter().map(|s| s.to_string()).collect();
    for path in packaged_fmus() {
        let mut archive = zip::ZipArchive::new(std::fs::File::open(&path).unwrap()).unwrap();
        let mut xml = String::new();
        archive.by_name("modelDescription.xml").unwrap().read_to_string(&mut xml).unwrap();
        let md = ModelDescription::parse(&xml).unwrap();
        let binary_name = format!("binaries/linux64/{}.so", md.model_identifier);
        let mut binary = Vec::new();
        archive
            .by_name(&binary_name)
            .unwrap_or_else(|e| panic!("{}: no {binary_name}: {e}", path.display()))
            .read_to_end(&mut binary)
            .unwrap();
        let exported = exported_functions(&binary).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let fmi2: BTreeSet<String> = exported.iter().filter(|n| n.starts_with("fmi2")).cloned().collect();
        let missing: Vec<&String> = standard.difference(&fmi2).collect();
        let extra: Vec<&String> = fmi2.difference(&standard).collect();
        assert!(
            missing.is_empty() && extra.is_empty(),
            "{}: missing {missing:?}, unexpected {extra:?}",
            path.display()
        );

        // And the importer, which resolves all 44 with dlsym, loads it.
        let fmu = Fmu::open(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!(fmu.library.version(), "2.0", "{}", path.display());
        assert_eq!(fmu.library.types_platform(), "default", "{}", path.display());
        assert_eq!(fmu.description.fmi_version, "2.0", "{}", path.display());
    }
}
