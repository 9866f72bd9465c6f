//! Real programs from other projects (../shared/corpus, when it is there): none may make
//! nccomp panic; with a zero model each comes back byte for byte; with real errors each is
//! either compensated or refused with file:line:col.

use nccomp::Error;
use nccomp::compensate::{Compensator, Options};
use nccomp::model::{ErrorModel, error_file, machine_file};
use std::path::{Path, PathBuf};

fn corpus_files() -> Option<Vec<PathBuf>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/corpus");
    if !root.is_dir() {
        eprintln!("note: {} is not there; corpus test skipped", root.display());
        return None;
    }
    let mut files = Vec::new();
    let mut stack = vec![root];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.file_name().is_some_and(|n| n != "README.md") {
                files.push(path);
            }
        }
    }
    files.sort();
    Some(files)
}

#[test]
fn corpus_round_trips_with_a_zero_model_and_is_compensated_or_refused_otherwise() {
    let Some(files) = corpus_files() else { return };
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let machine = machine_file::load(&fixtures.join("ac_trunnion.machine.toml")).unwrap();
    let errors = error_file::load(&fixtures.join("ac_trunnion.errors.toml"), &machine).unwrap();
    let zero = ErrorModel::zero(&machine);
    let real = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let none = Compensator::new(&machine, &zero, Options::default()).unwrap();
    let (mut compensated, mut refused) = (0, 0);
    for path in &files {
        let src = std::fs::read(path).unwrap();
        let name = path.display().to_string();
        let mut out = Vec::new();
        none.run(&src, &name, &mut out).unwrap();
        assert!(out == src, "{name}: zero model changed the program");
        let mut out = Vec::new();
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            real.run(&src, &name, &mut out)
        }));
        match result {
            Err(_) => panic!("{name}: nccomp panicked"),
            Ok(Ok(_)) => compensated += 1,
            Ok(Err(Error::Inputs(diags))) => {
                assert!(!diags.is_empty());
                for d in &diags {
                    assert_eq!(d.path, name);
                    assert!(d.line >= 1 && d.column >= 1, "{d}");
                    assert!(!d.message.is_empty());
                }
                refused += 1;
            }
            Ok(Err(other)) => panic!("{name}: refused without a location: {other}"),
        }
    }
    eprintln!(
        "corpus: {} files; zero model: all byte-identical; AC trunnion errors: {compensated} compensated, {refused} refused with line:col",
        files.len()
    );
    assert_eq!(compensated + refused, files.len());
}
