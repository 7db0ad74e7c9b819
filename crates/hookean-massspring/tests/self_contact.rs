//! Cloth self-collision on small models: proximity pairs repel, and the
//! continuous pass catches vertex-face and edge-edge crossings inside one
//! step (checked with the independent triangle-triangle test of
//! hookean-testkit).

use hookean_massspring::{MassSpringModel, ModelOptions, SecondOrderProblem, SelfCollision};
use hookean_sparse::Constraints;

/// Two triangles (particles 0-2 and 3-5), no springs, no gravity.
fn two_triangles(x: &[f64]) -> MassSpringModel {
    let mut m = MassSpringModel::new(
        vec![0.01; 6],
        vec![],
        ModelOptions {
            gravity: [0.0; 3],
            ..ModelOptions::default()
        },
    )
    .unwrap();
    m.set_faces(vec![[0, 1, 2], [3, 4, 5]]).unwrap();
    m.set_self_collision(Some(SelfCollision {
        thickness: 0.01,
        stiffness: 50.0,
        ..Default::default()
    }))
    .unwrap();
    let _ = x;
    m
}

#[test]
fn close_layers_make_proximity_pairs_that_push_apart() {
    // A vertex 5 mm above the middle of a horizontal triangle.
    let x = vec![
        0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, // lower triangle
        0.2, 0.2, 0.005, 0.2, 3.0, 0.5, 3.0, 0.2, 0.5, // upper: vertex 3 close
    ];
    let mut m = two_triangles(&x);
    let (mut xs, mut v) = (x.clone(), vec![0.0; 18]);
    let mut c = Constraints::new(6);
    m.begin_step(0.0, &mut xs, &mut v, &mut c);
    assert!(
        m.contact_stats().proximity_pairs >= 1,
        "{:?}",
        m.contact_stats()
    );
    let mut f = vec![0.0; 18];
    m.force(0.0, &xs, &v, &mut f);
    // Vertex 3 pushed up by k (h - d) = 50 (0.01 - 0.005) = 0.25 N.
    assert!((f[3 * 3 + 2] - 0.25).abs() < 1e-12, "{f:?}");
    // The triangle's vertices pushed down by the same total.
    let down: f64 = (0..3).map(|p| f[3 * p + 2]).sum();
    assert!((down + 0.25).abs() < 1e-12);
}

/// Runs `begin_step` at `x0`, moves every particle by `h v` (what an
/// implicit step with these velocities does) and runs `end_step`.
fn step_with(m: &mut MassSpringModel, x0: &[f64], v: &[f64], h: f64) -> (Vec<f64>, Vec<f64>) {
    let (mut x, mut vv) = (x0.to_vec(), v.to_vec());
    let mut c = Constraints::new(m.n_particles());
    m.begin_step(0.0, &mut x, &mut vv, &mut c);
    let start = x.clone();
    for k in 0..x.len() {
        x[k] += h * vv[k];
    }
    m.end_step(0.0, h, &start, &mut x, &mut vv);
    (x, vv)
}

fn tri(x: &[f64], t: usize) -> [[f64; 3]; 3] {
    std::array::from_fn(|k| {
        let p = 3 * t + k;
        [x[3 * p], x[3 * p + 1], x[3 * p + 2]]
    })
}

/// A vertex falls through the middle of a triangle within one step: the
/// uncorrected end state has the triangles crossing (independent test),
/// the continuous pass catches the impact and the state after the step
/// has them apart, the vertex still above.
#[test]
fn a_point_triangle_crossing_inside_one_step_is_caught() {
    let x0 = vec![
        0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, // lower, at rest
        0.2, 0.2, 0.05, 0.25, 0.2, 0.6, 0.2, 0.25, 0.6, // upper, tip 5 cm above
    ];
    let mut v = vec![0.0; 18];
    for p in 3..6 {
        v[3 * p + 2] = -20.0; // 10 cm in a step of 5 ms
    }
    let h = 0.005;
    let moved: Vec<f64> = x0.iter().zip(&v).map(|(x, v)| x + h * v).collect();
    assert!(hookean_testkit::intersect::triangles_intersect(
        &tri(&moved, 0),
        &tri(&moved, 1)
    ));
    let mut m = two_triangles(&x0);
    let (x, v) = step_with(&mut m, &x0, &v, h);
    let s = m.contact_stats();
    assert!(s.impacts >= 1, "{s:?}");
    assert!(!hookean_testkit::intersect::triangles_intersect(
        &tri(&x, 0),
        &tri(&x, 1)
    ));
    assert!(x[3 * 3 + 2] > 0.0, "the tip stays above: {x:?}");
    // Inelastic: the tip no longer approaches the lower triangle.
    // Relative normal velocity at the contact point (barycentric 0.6, 0.2, 0.2).
    let vn = v[3 * 3 + 2] - (0.6 * v[2] + 0.2 * v[5] + 0.2 * v[8]);
    assert!(vn >= -1e-9, "{vn} {v:?}");
}

/// An edge sweeps through another edge within one step (no vertex passes
/// through a face): caught by the edge-edge test.
#[test]
fn an_edge_edge_crossing_inside_one_step_is_caught() {
    // Lower triangle in z = 0 with the edge 0-1 along x; upper triangle in
    // the plane x = 0.5, its lower edge 3-4 along y at z = 0.05, below the
    // apex, swept down through edge 0-1 and past it.
    let x0 = vec![
        0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.5, -1.0,
        0.0, // lower: edge 0-1 on y = 0, body at y < 0
        0.5, 0.3, 0.05, 0.5, 0.6, 0.05, 0.5, 0.45, 0.8, // upper: edge 3-4 at y in [0.3, 0.6]
    ];
    // Move the upper triangle towards -y and down: edge 3-4 passes under
    // edge 0-1's line at y = 0 while the lower triangle lies at y < 0.
    let mut v = vec![0.0; 18];
    for p in 3..6 {
        v[3 * p + 1] = -90.0; // 45 cm in the step
        v[3 * p + 2] = -20.0; // 10 cm down
    }
    let h = 0.005;
    let moved: Vec<f64> = x0.iter().zip(&v).map(|(x, v)| x + h * v).collect();
    assert!(hookean_testkit::intersect::triangles_intersect(
        &tri(&moved, 0),
        &tri(&moved, 1)
    ));
    let mut m = two_triangles(&x0);
    let (x, _) = step_with(&mut m, &x0, &v, h);
    let s = m.contact_stats();
    assert!(s.impacts >= 1, "{s:?}");
    assert!(!hookean_testkit::intersect::triangles_intersect(
        &tri(&x, 0),
        &tri(&x, 1)
    ));
}
