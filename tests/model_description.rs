//! The checked-in `modelDescription/<name>.xml` of every shipped FMU must be byte-identical
//! to what the generator writes for `fmu/<name>/scene.toml`.

use std::path::{Path, PathBuf};

use geardyn::fmi::description::check_checked_in;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn checked_in_descriptions_match_the_generator() {
    let problems = check_checked_in(&root().join("fmu"), &root().join("modelDescription"), false)
        .expect("generator runs");
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn drift_is_detected() {
    // Oracle for the check itself: copies with one changed byte, a missing file and a stray
    // file must each be reported.
    let tmp = std::env::temp_dir().join(format!("geardyn-md-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    std::fs::create_dir_all(&tmp).unwrap();
    let md = root().join("modelDescription/spur_pair.xml");
    let text = std::fs::read_to_string(&md).unwrap();
    let copy = tmp.join("spur_pair.xml");
    std::fs::write(&copy, text.replacen("stepSize=\"", "stepSize=\"1", 1)).unwrap();
    let p = check_checked_in(&root().join("fmu"), &tmp, false).unwrap();
    assert!(p.iter().any(|m| m.contains("out of date")), "{p:?}");
    std::fs::remove_file(&copy).unwrap();
    let p = check_checked_in(&root().join("fmu"), &tmp, false).unwrap();
    assert!(p.iter().any(|m| m.contains("missing")), "{p:?}");
    std::fs::write(&copy, &text).unwrap();
    std::fs::write(tmp.join("old_model.xml"), "<x/>").unwrap();
    let p = check_checked_in(&root().join("fmu"), &tmp, false).unwrap();
    assert_eq!(p.len(), 1, "{p:?}");
    assert!(p[0].contains("old_model.xml"));
    let _ = std::fs::remove_dir_all(Path::new(&tmp));
}
