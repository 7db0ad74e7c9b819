//! Issue 37: the OBJ readers (`read_obj_file`, `read_surface`) open only
//! regular files: a FIFO (which blocked them for ever), a folder or a
//! device is an error saying what it is; a byte-order mark does not cost
//! the first vertex.
#![cfg(unix)]

use hookean_massspring::{read_obj_file, read_surface};
use hookean_testkit::special::{special_files, within_time};

#[test]
fn a_fifo_a_folder_or_a_device_is_refused_without_blocking() {
    let dir = special_files("obj", "m.obj");
    for (name, kind) in [
        ("m.obj", "a FIFO (named pipe)"),
        ("folder", "a folder"),
        ("null", "a character device"),
    ] {
        let path = dir.join(name);
        let p = path.clone();
        let e = within_time(move || read_surface(p, 1.0, [0.0; 3]).map(|_| ())).unwrap_err();
        let m = e.to_string();
        assert!(
            m.contains(name) && m.contains(&format!("it is {kind}, not a regular file")),
            "{m}"
        );
        let e = within_time(move || read_obj_file(path).map(|_| ())).unwrap_err();
        assert!(e.to_string().contains(&format!("it is {kind}")), "{e}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_byte_order_mark_keeps_the_first_vertex() {
    let dir = std::env::temp_dir().join(format!("hookean-bom-obj-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("m.obj");
    std::fs::write(&p, "\u{feff}v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let (obj, mesh) = read_surface(&p, 1.0, [0.0; 3]).unwrap();
    assert_eq!(
        obj.positions,
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    );
    assert_eq!(mesh.triangles(), [[0, 1, 2]]);
    std::fs::remove_dir_all(&dir).unwrap();
}
