//! What a start must satisfy for contact to conserve energy (issue 37,
//! docs/CONTACT.md): no particle inside a collider, a self-collision
//! thickness below the smallest altitude of the model's triangles, a mesh
//! thickness within the mesh's size.

use hookean_massspring::{
    ClothParams, ClothPins, Collider, MassSpringError, MeshCollider, SelfCollision, TriMesh, cloth,
};

/// The closed box `[lo, hi]` as 12 outward triangles.
fn box_mesh(lo: [f64; 3], hi: [f64; 3]) -> TriMesh {
    let (v, t) = hookean_testkit::intersect::box_triangles(lo, hi);
    TriMesh::new(v, t).unwrap()
}

#[test]
fn particles_inside_counts_each_collider_s_inside_and_skips_pinned_ones() {
    // A 4 x 4 cloth of side 0.3 at z = 0.5 (x, y in {0, 0.1, 0.2, 0.3}),
    // its corner (0.3, 0.3) pinned; the counts below are by hand.
    let params = ClothParams {
        width: 0.3,
        height: 0.3,
        origin: [0.0, 0.0, 0.5],
        pins: ClothPins::Particles(vec![15]),
        ..ClothParams::drape(4)
    };
    let (mut model, state) = cloth(&params).unwrap();
    // Particle 15 is the corner (0.3, 0.3).
    assert!((state.x[45] - 0.3).abs() < 1e-15 && (state.x[46] - 0.3).abs() < 1e-15);
    model.add_collider(Collider::mesh(
        MeshCollider::new(box_mesh([0.05, 0.05, 0.0], [1.0, 1.0, 1.0]), 0.005).unwrap(),
    ));
    // A floor at z = 0.5 exactly (on it is not inside) and a plane tilted
    // so that the particles with y > 0.15 are below it.
    model.add_collider(Collider::plane([0.0, 0.0, 0.5], [0.0, 0.0, 1.0], 0.0).unwrap());
    model.add_collider(Collider::plane([0.0, 0.15, 0.5], [0.0, -1.0, 0.0], 0.0).unwrap());
    model.add_collider(Collider::sphere([0.0, 0.0, 0.5], 0.15, 0.0).unwrap());
    let inside = model.particles_inside(&state.x);
    // Box: x, y in {0.1, 0.2, 0.3}, 9 less the pin; plane 2: y in {0.2,
    // 0.3}, 8 less the pin; sphere: |(x, y)| < 0.15: (0, 0), (0.1, 0),
    // (0, 0.1), (0.1, 0.1).
    assert_eq!(inside, vec![8, 0, 7, 4]);
}

#[test]
fn the_self_thickness_limit_is_the_smallest_altitude_and_is_checked() {
    // A grid of spacing s = 1 / 7: the right triangles' smallest altitude
    // is the distance of the right angle from the diagonal, s / sqrt 2.
    let (mut model, state) = cloth(&ClothParams::drape(8)).unwrap();
    let s = 1.0 / 7.0;
    let limit = model.self_thickness_limit(&state.x);
    assert!((limit - s / 2f64.sqrt()).abs() < 1e-15, "{limit}");
    for (thickness, ok) in [(0.004, true), (0.1, true), (0.102, false), (0.5, false)] {
        model
            .set_self_collision(Some(SelfCollision {
                thickness,
                ..Default::default()
            }))
            .unwrap();
        match model.check_self_thickness(&state.x) {
            Ok(()) => assert!(ok, "{thickness}"),
            Err(MassSpringError::InvalidParameter { name, message }) => {
                assert!(!ok, "{thickness}");
                assert_eq!(name, "self_thickness");
                assert!(message.contains("(0, 0.101015)"), "{message}");
            }
            Err(e) => panic!("{e}"),
        }
    }
}

#[test]
fn a_mesh_thickness_beyond_the_mesh_s_diagonal_is_refused() {
    // The unit box's diagonal is sqrt 3.
    let d = 3f64.sqrt();
    assert!(MeshCollider::new(box_mesh([0.0; 3], [1.0; 3]), d).is_ok());
    for bad in [d * (1.0 + 1e-12), 1e300, f64::INFINITY, f64::NAN, -0.001] {
        match MeshCollider::new(box_mesh([0.0; 3], [1.0; 3]), bad) {
            Err(MassSpringError::InvalidParameter { name, message }) => {
                assert_eq!(name, "thickness");
                assert!(message.contains("[0, 1.732051] m"), "{message}");
            }
            other => panic!("{bad}: {other:?}"),
        }
    }
}
