//! Issue 37: the facade's scene reader opens only regular files: a FIFO
//! (which blocked it for ever), a folder or a device is an error saying
//! what it is, and so is a mesh file of the scene; a byte-order mark is
//! skipped.
#![cfg(unix)]

use hookean::scene::Scene;
use hookean_testkit::special::{special_files, within_time};

#[test]
fn a_scene_or_its_mesh_that_is_a_fifo_a_folder_or_a_device_is_refused_without_blocking() {
    let dir = special_files("scene", "s.toml");
    hookean_testkit::special::make_fifo(&dir.join("m.obj"));
    for (name, kind) in [
        ("s.toml", "a FIFO (named pipe)"),
        ("folder", "a folder"),
        ("null", "a character device"),
    ] {
        let path = dir.join(name);
        let e = within_time(move || Scene::from_file(path, &[]).map(|_| ())).unwrap_err();
        let m = e.to_string();
        assert!(
            m.contains(name) && m.contains(&format!("it is {kind}, not a regular file")),
            "{m}"
        );
    }
    // A scene whose collider mesh is a FIFO: refused when it is built.
    let scene = dir.join("c.toml");
    std::fs::write(
        &scene,
        "\u{feff}duration = 0.05\n[cloth]\nn = 4\n[[collider]]\nkind = \"mesh\"\npath = \"m.obj\"\n",
    )
    .unwrap();
    let e = within_time(move || Scene::from_file(scene, &[]).and_then(|s| s.build().map(|_| ())))
        .unwrap_err();
    assert!(
        e.to_string().contains("m.obj: it is a FIFO (named pipe)"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
