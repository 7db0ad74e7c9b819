//! The OBJ reader and the mesh builder on mutated valid files
//! (`hookean_testkit::fuzz`): a model or a typed error, never a panic. A
//! million cases: docs/RELIABILITY.md.

use hookean_massspring::{MassSpringError, MeshParams, from_mesh, parse_obj};
use hookean_testkit::fuzz::mutate;
use proptest::prelude::*;

/// Valid meshes: a quad of two triangles with a comment, texture and
/// normal indices, negative (relative) indices; a tetrahedron.
const VALID: &[&str] = &[
    "# quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1\nf 1 3 4\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1 0.5\nf -4 -3 -2\nf 1 2 4\nf 1 3 4\nf 2 3 4\n",
];

proptest! {
    #![proptest_config(ProptestConfig { cases: 3000, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn mutated_meshes_give_a_model_or_a_typed_error(file in 0..VALID.len(), seed in any::<u64>()) {
        let bytes = mutate(VALID[file].as_bytes(), seed);
        match parse_obj(bytes.as_slice()) {
            Ok(mesh) => {
                if let Ok((model, state)) = from_mesh(&mesh, &MeshParams::default()) {
                    prop_assert_eq!(state.x.len(), 3 * model.n_particles());
                    prop_assert!(state.x.iter().all(|v| v.is_finite()));
                }
            }
            Err(MassSpringError::ObjParse { line, .. }) => {
                let lines = bytes.split(|&b| b == b'\n').count();
                prop_assert!(line >= 1 && line <= lines, "line {} of {}", line, lines);
            }
            Err(MassSpringError::Io { .. }) => {} // not UTF-8
            Err(e) => prop_assert!(false, "unexpected error kind: {e}"),
        }
    }
}

#[test]
fn the_valid_meshes_build() {
    for f in VALID {
        let mesh = parse_obj(f.as_bytes()).unwrap();
        from_mesh(&mesh, &MeshParams::default()).unwrap();
    }
}
