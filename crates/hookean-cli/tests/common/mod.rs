//! What every CLI test file needs: run the binary, find the repository's
//! files, and check the error convention (one line, exit code 2).

#![allow(dead_code)] // each test file uses its own subset

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs `hookean` with `args` from the crate's folder.
pub fn hookean(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hookean"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the hookean binary runs")
}

/// A path in the repository (scenes/, data/), as a string.
pub fn repo(path: &str) -> String {
    let p: PathBuf = [env!("CARGO_MANIFEST_DIR"), "..", "..", path]
        .iter()
        .collect();
    p.to_string_lossy().into_owned()
}

/// The command succeeded; shows its stderr otherwise.
pub fn assert_ok(out: &Output) {
    assert!(
        out.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Bad input: exit code 2, one `hookean: error: ...` line naming `needle`, no panic.
pub fn assert_input_error(out: &Output, needle: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "stderr: {stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "one line: {stderr}");
    assert!(stderr.starts_with("hookean: error: "), "{stderr}");
    assert!(stderr.contains(needle), "expected '{needle}' in: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

/// Runs `hookean run SCENE` (a path in the repository) into `out` with the
/// `--set` overrides `sets`; returns its `summary.json`.
pub fn run_scene(out: &Path, scene: &str, sets: &[String]) -> serde_json::Value {
    let mut args = vec![
        "run".to_string(),
        repo(scene),
        "--out".into(),
        out.to_string_lossy().into_owned(),
        "--quiet".into(),
    ];
    for s in sets {
        args.extend(["--set".to_string(), s.clone()]);
    }
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    assert_ok(&hookean(&args));
    serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap()
}

/// Runs the drape with `cloth.n = n` for `duration` s at `frame_rate`
/// frames per second into `out`; returns its `summary.json`.
pub fn run_drape(out: &Path, n: usize, duration: f64, frame_rate: f64) -> serde_json::Value {
    run_scene(
        out,
        "scenes/drape.toml",
        &[
            format!("cloth.n={n}"),
            format!("duration={duration}"),
            format!("output.frame_rate={frame_rate}"),
        ],
    )
}

/// Decodes a PNG into (width, height, RGBA pixels).
pub fn decode_rgba(path: &Path) -> (usize, usize, Vec<[u8; 4]>) {
    let mut decoder =
        png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    let channels = info.color_type.samples();
    let px = buf[..info.buffer_size()]
        .chunks(channels)
        .map(|c| match channels {
            4 => [c[0], c[1], c[2], c[3]],
            3 => [c[0], c[1], c[2], 255],
            _ => [c[0], c[0], c[0], 255],
        })
        .collect();
    (info.width as usize, info.height as usize, px)
}
