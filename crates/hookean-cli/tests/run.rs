//! `hookean run` end to end on small variants of the shipped scenes.

mod common;
use common::*;

use std::path::PathBuf;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hookean-run-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

#[test]
fn the_main_job_writes_every_promised_file_consistently() {
    // The README's main job on a small, short variant of the drape.
    let out = scratch("drape");
    let summary = run_drape(&out, 12, 0.3, 10.0);
    let csv = std::fs::read_to_string(out.join("steps.csv")).unwrap();
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(
        csv.lines().next().unwrap(),
        "t,h,newton_iterations,cg_iterations,kinetic,gravitational,spring,total"
    );
    // Counts agree between the summary and the per-step rows.
    assert_eq!(summary["steps"].as_u64().unwrap() as usize, rows.len());
    let newton: f64 = rows.iter().map(|r| r[2]).sum();
    let cg: f64 = rows.iter().map(|r| r[3]).sum();
    assert!(newton <= summary["newton_iterations"].as_f64().unwrap());
    assert!(cg <= summary["cg_iterations"].as_f64().unwrap());
    assert!((rows.last().unwrap()[0] - 0.3).abs() < 1e-9);
    assert_eq!(summary["particles"], 144);
    assert!(summary["simulated_s_per_wall_s"].as_f64().unwrap() > 0.0);
    // The cloth fell: gravitational energy decreased.
    assert!(rows.last().unwrap()[5] < rows[0][5]);
    // OBJ frames at 10 per second: t = 0, 0.1, 0.2, 0.3.
    let frames = summary["frames"].as_u64().unwrap();
    assert_eq!(frames, 4);
    for k in 0..frames {
        let obj = std::fs::read_to_string(out.join(format!("frame-{k:04}.obj"))).unwrap();
        assert_eq!(obj.lines().filter(|l| l.starts_with("v ")).count(), 144);
        assert!(obj.lines().any(|l| l.starts_with("f ")));
    }
    // The picture decodes, has the configured size and is not blank.
    let (w, h, px) = decode_rgba(&out.join("final.png"));
    assert_eq!((w, h), (800, 600));
    let coloured = px.iter().filter(|p| p[..3] != [255, 255, 255]).count();
    assert!(coloured > w * h / 20, "only {coloured} coloured pixels");
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn an_existing_output_folder_is_not_overwritten_without_force() {
    let out = scratch("existing");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("keep.txt"), "mine").unwrap();
    let args = [
        "run",
        &repo("scenes/rope.toml"),
        "--out",
        out.to_str().unwrap(),
        "--set",
        "duration=0.05",
        "--quiet",
    ];
    let o = hookean(&args);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--force"));
    assert!(!out.join("summary.json").exists());
    // --force replaces only the output of an earlier run: a folder of the
    // user's own files is refused, and left as it was.
    let mut forced = args.to_vec();
    forced.push("--force");
    assert_input_error(&hookean(&forced), "is not hookean's output");
    assert_eq!(
        std::fs::read_to_string(out.join("keep.txt")).unwrap(),
        "mine"
    );
    assert!(!out.join("summary.json").exists());
    let _ = std::fs::remove_dir_all(&out);
}

/// `--force` leaves exactly what this run wrote, and a run that fails
/// leaves the earlier results as they were (its partial output dropped).
#[test]
fn force_replaces_a_run_whole_and_a_failed_run_changes_nothing() {
    let out = scratch("replace");
    let files = |dir: &std::path::Path| {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    };
    let long = run_scene(
        &out,
        "scenes/drape.toml",
        &["cloth.n=8".into(), "duration=0.5".into()],
    );
    assert_eq!(long["frames"], 6);
    let before = files(&out);
    let summary_before = std::fs::read_to_string(out.join("summary.json")).unwrap();

    // `hookean run scenes/drape.toml --out OUT --force --set cloth.n=8 --set ...`.
    let forced = |sets: &[&str]| {
        let scene = repo("scenes/drape.toml");
        let mut args = vec!["run", &scene, "--out", out.to_str().unwrap(), "--force"];
        for s in ["cloth.n=8"].iter().chain(sets) {
            args.extend(["--set", s]);
        }
        hookean(&args)
    };

    // FB Euler at h = 0.01 on this cloth blows up: exit 1, nothing changed.
    let o = forced(&["duration=3", "integrator.method=fb-euler"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("is unchanged"), "{stderr}");
    assert_eq!(files(&out), before);
    assert_eq!(
        std::fs::read_to_string(out.join("summary.json")).unwrap(),
        summary_before
    );
    // Nothing else is left beside the folder.
    let parent = out.parent().unwrap();
    let name = out.file_name().unwrap().to_string_lossy().into_owned();
    let hidden: Vec<String> = std::fs::read_dir(parent)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(&format!(".{name}.")))
        .collect();
    assert!(hidden.is_empty(), "{hidden:?}");

    // A shorter run with --force: only its own 3 frames remain.
    let o = forced(&["duration=0.2"]);
    assert_ok(&o);
    let after = files(&out);
    let objs = after.iter().filter(|f| f.ends_with(".obj")).count();
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!((objs, summary["frames"].as_u64()), (3, Some(3)));
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn a_bad_scene_names_its_line_and_column() {
    let dir = scratch("bad");
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("bad.toml");
    std::fs::write(&scene, "duration = 1.0\n[cloth]\nn = 8\nstiffness = -5.0\n").unwrap();
    let o = hookean(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        dir.join("out").to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("bad.toml:4:13"), "{stderr}");
    assert!(stderr.contains("must lie in (0, inf), got -5"), "{stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1);
    let o = hookean(&["run", "/nonexistent/scene.toml"]);
    assert_eq!(o.status.code(), Some(2));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn every_shipped_scene_parses() {
    for entry in std::fs::read_dir(repo("scenes")).unwrap() {
        let path = entry.unwrap().path();
        hookean::scene::Scene::from_file_with::<hookean_cli::scene::ProgramKeys>(&path, &[])
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    }
}

#[test]
fn tutorial_example_1_matches_the_implicit_euler_recurrence() {
    let out = scratch("tutorial1");
    let o = hookean(&[
        "run",
        &repo("scenes/tutorial1.toml"),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    // Implicit Euler on y' = -15 y with h = 0.01: y_100 = (1 + 0.15)^-100 (eq. 26).
    let expected = 1.15f64.powi(-100);
    let y = s["y_final"].as_f64().unwrap();
    assert!((y / expected - 1.0).abs() < 1e-10, "{y} vs {expected}");
    assert!((s["exact_final"].as_f64().unwrap() - (-15.0f64).exp()).abs() < 1e-18);
    assert_eq!(s["steps"], 100);
    let csv = std::fs::read_to_string(out.join("steps.csv")).unwrap();
    assert_eq!(csv.lines().count(), 101);
    assert!(out.join("final.png").exists());
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn tutorial_example_2_with_bdf2_is_second_order_accurate() {
    // Halving h divides BDF2's error at t = 10 by about 4.
    let mut errors = Vec::new();
    for h in ["0.02", "0.01"] {
        let out = scratch(&format!("tutorial2-{h}"));
        let o = hookean(&[
            "run",
            &repo("scenes/tutorial2.toml"),
            "--out",
            out.to_str().unwrap(),
            "--set",
            &format!("integrator.h={h}"),
            "--quiet",
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let s: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap())
                .unwrap();
        errors.push(s["error_final"].as_f64().unwrap());
        let _ = std::fs::remove_dir_all(&out);
    }
    let ratio = errors[0] / errors[1];
    assert!((3.5..4.5).contains(&ratio), "{errors:?}");
}

/// Speeds are coloured on the run's fixed scale, not the frame's: the jelly
/// block, at rest on its plane at the end (kinetic energy ~1e-13 J), is drawn
/// in the colour of zero speed, with no red (the top of the scale) in the view.
#[test]
fn a_jelly_at_rest_is_drawn_blue_not_red() {
    let out = scratch("jelly");
    let summary = run_scene(&out, "scenes/jelly.toml", &[]);
    assert!(summary["final_kinetic_energy"].as_f64().unwrap() < 1e-6);
    let (w, _, px) = decode_rgba(&out.join("final.png"));
    // The 3D view: everything left of the colour bar strip.
    let view: Vec<&[u8; 4]> = px
        .iter()
        .enumerate()
        .filter(|(k, _)| k % w < w - 130)
        .map(|(_, p)| p)
        .collect();
    let red = view
        .iter()
        .filter(|p| p[0] > 160 && p[1] < 120 && p[2] < 100)
        .count();
    let blue = view
        .iter()
        .filter(|p| p[2] > 120 && p[0] < 90 && p[2] > p[1] + 40)
        .count();
    assert_eq!(red, 0, "red pixels in the view of a body at rest");
    assert!(blue > 2000, "only {blue} blue pixels");
    let _ = std::fs::remove_dir_all(&out);
}

/// The sphere of cloth-sphere is drawn: a disc of warm grey shades (the
/// cloth is blue to red, the ground a light grey above 230).
#[test]
fn the_sphere_collider_is_drawn_in_final_png() {
    let out = scratch("sphere");
    run_scene(
        &out,
        "scenes/cloth-sphere.toml",
        &["cloth.n=8".into(), "duration=0.05".into()],
    );
    let (w, h, px) = decode_rgba(&out.join("final.png"));
    let sphere = px
        .iter()
        .filter(|p| {
            let (r, g, b) = (p[0] as i32, p[1] as i32, p[2] as i32);
            r < 215 && r > 40 && r >= g && g >= b && (5..=40).contains(&(r - b))
        })
        .count();
    // r = 0.3 m in a view fitted to about 1 m: a disc of a few percent of the picture.
    assert!(sphere > w * h / 50, "only {sphere} sphere-coloured pixels");
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn the_drape_runs_with_the_multigrid_preconditioner() {
    // 24 x 24 particles: 1 728 unknowns, so the hierarchy has two levels
    // and every Newton iteration refills it.
    let runs: Vec<serde_json::Value> = ["amg", "mic0"]
        .iter()
        .map(|p| {
            let out = scratch(&format!("drape-{p}"));
            let sets = [
                "cloth.n=24".to_string(),
                "duration=0.1".to_string(),
                format!("solver.preconditioner={p}"),
            ];
            let summary = run_scene(&out, "scenes/drape.toml", &sets);
            let _ = std::fs::remove_dir_all(&out);
            summary
        })
        .collect();
    let (amg, mic0) = (&runs[0], &runs[1]);
    assert_eq!(amg["steps"], 10);
    assert_eq!(amg["rejected_steps"], 0);
    // Multigrid needs fewer CG iterations than MIC(0) for the same
    // Newton tolerances.
    let cg = |v: &serde_json::Value| v["cg_iterations"].as_u64().unwrap();
    assert!(cg(amg) < cg(mic0), "{amg} {mic0}");
}

/// Sizes no machine can hold are refused before anything is built, naming
/// the key: a cloth of 10^10 (or 2^64) particles, a picture 2^32 pixels wide;
/// the memory cap is a flag.
#[test]
fn absurd_sizes_are_input_errors_naming_the_key() {
    let out = scratch("sizes");
    let run = |sets: &[&str], extra: &[&str]| {
        let scene = repo("scenes/drape.toml");
        let mut args = vec!["run", &scene, "--out", out.to_str().unwrap(), "--quiet"];
        for s in sets {
            args.extend(["--set", s]);
        }
        args.extend(extra);
        hookean(&args)
    };
    assert_input_error(&run(&["cloth.n=100000"], &[]), "cloth.n");
    assert_input_error(&run(&["cloth.n=4294967296"], &[]), "cloth.n");
    assert_input_error(&run(&["output.width=4294967296"], &[]), "pixels");
    assert!(!out.exists(), "nothing was written");
    // An 8 x 8 cloth needs about 0.2 MiB: refused under a 0.1 MiB cap.
    let small = ["cloth.n=8", "duration=0.01"];
    assert_input_error(&run(&small, &["--max-memory", "0.0001"]), "--max-memory");
    assert_input_error(&run(&small, &["--max-memory", "-1"]), "--max-memory");
    assert_ok(&run(&small, &[]));
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn two_runs_with_the_same_thread_count_write_identical_frames() {
    // 48 x 48 = 2 304 particles: above hookean_sparse::par::MIN_PARALLEL_BLOCKS,
    // so the threaded kernels (row-split SpMV, tree-summed dot products) run.
    const { assert!(48 * 48 >= hookean_sparse::par::MIN_PARALLEL_BLOCKS) };
    let run = |name: &str, threads: &str, extra: &[&str]| {
        let out = scratch(name);
        let out_s = out.to_str().unwrap().to_string();
        let drape = repo("scenes/drape.toml");
        let mut args = vec![
            "run",
            &drape,
            "--set",
            "cloth.n=48",
            "--set",
            "duration=0.05",
            "--set",
            "output.frame_rate=100",
            "--set",
            "output.width=8",
            "--set",
            "output.height=8",
            "--out",
            &out_s,
        ];
        if !threads.is_empty() {
            args.extend(["--threads", threads]);
        }
        args.extend(extra);
        assert_ok(&hookean(&args));
        out
    };
    let files = |dir: &PathBuf| {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".obj") || n == "steps.csv")
            .collect();
        names.sort();
        names
    };
    let a = run("threads-a", "2", &[]);
    let b = run("threads-b", "2", &[]);
    let names = files(&a);
    assert_eq!(names.len(), 7, "6 frames and steps.csv: {names:?}");
    assert_eq!(names, files(&b));
    for name in &names {
        let (x, y) = (
            std::fs::read(a.join(name)).unwrap(),
            std::fs::read(b.join(name)).unwrap(),
        );
        assert!(x == y, "{name} differs between two 2-thread runs");
    }
    let summary = |dir: &PathBuf| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
    };
    assert_eq!(summary(&a)["threads"], 2);
    // The scene's `threads` key applies without --threads; --threads wins.
    let c = run("threads-c", "", &["--set", "threads=1"]);
    assert_eq!(summary(&c)["threads"], 1);
    let d = run("threads-d", "2", &["--set", "threads=1"]);
    assert_eq!(summary(&d)["threads"], 2);
    for dir in [a, b, c, d] {
        let _ = std::fs::remove_dir_all(dir);
    }
    let o = hookean(&["--threads", "0", "view", "x"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("threads from 1 to 1024"));
}

#[test]
fn a_bad_animated_collider_exits_2_naming_the_file_or_key_and_writes_nothing() {
    let dir = scratch("anim");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::copy(repo("data/platform.obj"), dir.join("f0.obj")).unwrap();
    // Frame 1 with one vertex more than frame 0.
    let mut more = std::fs::read_to_string(dir.join("f0.obj")).unwrap();
    more.push_str("v 9 9 9\n");
    std::fs::write(dir.join("f1.obj"), more).unwrap();
    let base = "duration = 0.1\n[cloth]\nn = 4\norigin = [-0.5, -0.5, 1.0]\n[[collider]]\nkind = \"mesh\"\npath = \"f0.obj\"\n";
    for (name, extra, named) in [
        ("count", "frames = [\"f1.obj\"]\n", "f1.obj"),
        ("missing", "frames = [\"f2.obj\"]\n", "f2.obj"),
        (
            "nan",
            "keys = [{ t = 0.0 }, { t = 1.0, rotation = [0.0, nan, 0.0] }]\n",
            "keys.rotation",
        ),
    ] {
        let scene = dir.join(format!("{name}.toml"));
        std::fs::write(&scene, format!("{base}{extra}")).unwrap();
        let out = dir.join(format!("out-{name}"));
        let o = hookean(&[
            "run",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{name}: {stderr}");
        assert!(stderr.contains(named), "{name}: {stderr}");
        assert!(!out.exists(), "{name}: wrote {}", out.display());
    }
    let _ = std::fs::remove_dir_all(&dir);
}
