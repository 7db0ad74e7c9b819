//! `hookean reproduce`: the table and the record of a run. CI runs the
//! command's cheap claims in the debug build (the whole `--quick` run takes
//! about 6 s in release): 2 (stability
//! limits on y' = -15 y), 3 (stability regions and figure 4), 9 (filtered
//! CG on constraints) and 14 (figure 8 with every method, on 8 x 8 and
//! 16 x 16 drapes for half a second). The full list is checked by hand with
//! the release build (README, "Reproducing the papers").

mod common;
use common::*;

#[test]
fn a_quick_subset_writes_the_table_the_record_and_the_figures() {
    let dir = std::env::temp_dir().join(format!("hookean-reproduce-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let o = hookean(&[
        "reproduce",
        "--quick",
        "--claims",
        "2,3,9,14",
        "--out",
        dir.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    let stderr = String::from_utf8_lossy(&o.stderr);
    let record: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("claims.json")).unwrap()).unwrap();
    let claims = record["claims"].as_array().unwrap();
    assert_eq!(claims.len(), 4);
    for c in claims {
        for key in ["claim", "paper_value", "measured", "tolerance"] {
            assert!(!c[key].as_str().unwrap().is_empty(), "{key} of {c}");
        }
    }
    // Claims 2, 3 and 9 are exact to their tolerances whatever the machine;
    // 14 is a timing (it may miss on a loaded machine: then the exit code is 1).
    for c in &claims[..3] {
        assert_eq!(c["pass"], true, "{c}");
    }
    let all_pass = claims.iter().all(|c| c["pass"] == true);
    assert_eq!(o.status.success(), all_pass, "{stderr}");
    assert!(
        stdout
            .contains("| # | paper | claim | paper's value | measured | tolerance | pass | note |")
    );
    let md = std::fs::read_to_string(dir.join("claims.md")).unwrap();
    assert!(md.contains("| 14 | filter |"));
    // Figure 8: both panels name every method, IMEX included.
    for panel in ["fig8-particles.svg", "fig8-k0.svg"] {
        let svg = std::fs::read_to_string(dir.join(panel)).unwrap();
        for name in [
            "FB Euler",
            "filtered RK4",
            "Verlet",
            "IMEX (EEH00)",
            "backward Euler (BW98",
        ] {
            assert!(svg.contains(name), "{name} missing from {panel}");
        }
    }
    let csv = std::fs::read_to_string(dir.join("fig8.csv")).unwrap();
    assert!(
        csv.lines()
            .any(|l| l.contains("IMEX (EEH00)") && l.contains("true"))
    );
    assert!(dir.join("fig4-regions.svg").exists());
    // A second run refuses the folder without --force.
    let again = hookean(&["reproduce", "--claims", "2", "--out", dir.to_str().unwrap()]);
    assert_input_error(&again, "--force");
    let _ = std::fs::remove_dir_all(&dir);
}
