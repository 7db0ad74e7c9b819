//! Builders' topology, OBJ I/O, Matrix Market export, and typed errors for bad input.

mod common;

use common::*;
use hookean_massspring::{
    BlockParams, ClothParams, ClothPins, Collider, MassSpringError, MassSpringModel, MeshParams,
    ModelOptions, SecondOrderProblem, Spring, SpringMaterial, State, cloth, from_mesh, jelly_block,
    parse_obj, rope, speed_colours, tutorial_example3,
};
use hookean_sparse::{LinearOperator, read_matrix_market};

fn no_gravity() -> ModelOptions {
    ModelOptions {
        gravity: [0.0; 3],
        ..ModelOptions::default()
    }
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0_f64, |a, x| a.max(x.abs()))
}

#[test]
fn cloth_has_the_spring_counts_of_its_grid_and_rests_in_any_plane() {
    let (nu, nv) = (5, 4);
    let (model, s) = cloth(&ClothParams {
        nu,
        nv,
        width: 2.0,
        height: 1.5,
        origin: [1.0, 2.0, 3.0],
        axis_u: [1.0, 0.0, 0.0],
        axis_v: [0.0, 0.3, -1.0], // a tilted, nearly vertical cloth
        pins: ClothPins::Edge,
        options: no_gravity(),
        ..Default::default()
    })
    .unwrap();
    let structural = (nu - 1) * nv + nu * (nv - 1);
    let shear = 2 * (nu - 1) * (nv - 1);
    let bend = (nu - 2) * nv + nu * (nv - 2);
    assert_eq!(model.springs().len(), structural + shear + bend);
    assert_eq!(model.faces().len(), 2 * (nu - 1) * (nv - 1));
    approx::assert_abs_diff_eq!(
        model.particle_masses().iter().sum::<f64>(),
        1.0,
        epsilon = 1e-14
    );
    // Spacing along each axis and the plane: particle (a, b) = origin + a du eu + b dv ev.
    let d = |i: usize, j: usize| dist(&s.x, i, j);
    assert!((d(0, 1) - 0.5).abs() < 1e-14 && (d(0, nu) - 0.5).abs() < 1e-14);
    approx::assert_abs_diff_eq!(d(0, nu + 1), 0.5 * 2f64.sqrt(), epsilon = 1e-14);
    // At rest: zero force without gravity.
    let mut f = vec![0.0; s.x.len()];
    model.force(0.0, &s.x, &s.v, &mut f);
    assert!(max_abs(&f) < 1e-10);
    // The whole edge b = nv - 1 is pinned.
    for a in 0..nu {
        assert_eq!(model.constraint(a + nu * (nv - 1)).unwrap().clone(), {
            let p = a + nu * (nv - 1);
            hookean_massspring::ParticleConstraint::Pinned {
                position: [s.x[3 * p], s.x[3 * p + 1], s.x[3 * p + 2]],
            }
        });
    }
}

#[test]
fn jelly_block_has_edge_face_and_body_diagonal_springs() {
    let [nx, ny, nz] = [4, 3, 2];
    let (model, s) = jelly_block(&BlockParams {
        n: [nx, ny, nz],
        options: no_gravity(),
        ..Default::default()
    })
    .unwrap();
    let (cx, cy, cz) = (nx - 1, ny - 1, nz - 1);
    let edges = cx * ny * nz + nx * cy * nz + nx * ny * cz;
    let faces = 2 * (cx * cy * nz + cx * ny * cz + nx * cy * cz);
    let body = 4 * cx * cy * cz;
    assert_eq!(model.springs().len(), edges + faces + body);
    let h = 0.05;
    let mut count = [0usize; 3];
    for sp in model.springs() {
        let l = sp.rest_length / h;
        let kind = [1.0, 2f64.sqrt(), 3f64.sqrt()]
            .iter()
            .position(|&r| (l - r).abs() < 1e-12)
            .expect("edge, face or body diagonal");
        count[kind] += 1;
    }
    assert_eq!(count, [edges, faces, body]);
    // Boundary triangles: two per boundary cell face.
    assert_eq!(model.faces().len(), 4 * (cx * cy + cx * cz + cy * cz));
    let mut f = vec![0.0; s.x.len()];
    model.force(0.0, &s.x, &s.v, &mut f);
    assert!(max_abs(&f) < 1e-10);
    // The block is a rigid-enough body: positive-definite stiffness apart
    // from rigid motions, so k0 is finite and positive.
    let st = model.stability(&s.x, &Default::default(), None).unwrap();
    assert!(st.k0 > 0.0 && st.dt_max.is_finite());
}

const QUAD_OBJ: &str = "\
# a unit square as one quad and a triangle fan with every index form
mtllib nothing.mtl
o square
v 0 0 0
v 1 0 0
v 1 1 0 0.5 0.5 0.5
v 0 1 0
vt 0 0
vn 0 0 1
s off
f 1/1/1 2/1/1 3//1 4
f -4 -2 -1
";

#[test]
fn obj_parses_polygons_index_forms_and_negative_indices() {
    let mesh = parse_obj(QUAD_OBJ.as_bytes()).unwrap();
    assert_eq!(mesh.positions.len(), 4);
    assert_eq!(mesh.positions[2], [1.0, 1.0, 0.0]);
    // The quad is fan-triangulated; "-4 -2 -1" are vertices 1, 3, 4.
    assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 2, 3]]);
}

#[test]
fn mesh_model_has_one_spring_per_edge_and_bend_springs_across_shared_edges() {
    let mesh = parse_obj("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n".as_bytes()).unwrap();
    let (model, s) = from_mesh(&mesh, &MeshParams::default()).unwrap();
    // Edges 01, 12, 23, 30, 02 and one bend spring 1-3 across the diagonal.
    let mut pairs: Vec<(usize, usize)> = model
        .springs()
        .iter()
        .map(|sp| (sp.i.min(sp.j), sp.i.max(sp.j)))
        .collect();
    pairs.sort();
    assert_eq!(pairs, vec![(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]);
    let bend = model
        .springs()
        .iter()
        .find(|sp| (sp.i.min(sp.j), sp.i.max(sp.j)) == (1, 3))
        .unwrap();
    assert_eq!(bend.stiffness, 1e3);
    approx::assert_abs_diff_eq!(bend.rest_length, 2f64.sqrt(), epsilon = 1e-15);
    assert_eq!(s.x.len(), 12);
    let (no_bend, _) = from_mesh(
        &mesh,
        &MeshParams {
            bend: None,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(no_bend.springs().len(), 5);
}

#[test]
fn obj_export_round_trips_positions_faces_and_carries_colours() {
    let (model, mut s) = cloth(&ClothParams {
        nu: 4,
        nv: 3,
        ..Default::default()
    })
    .unwrap();
    s.v[5] = 2.0;
    let colours = speed_colours(&s.v, 0.0);
    assert_eq!(colours[1], [1.0, 0.0, 0.0]); // the fastest is red
    assert_eq!(colours[0], [0.0, 0.0, 1.0]); // at rest is blue
    let mut out = Vec::new();
    model.write_obj(&mut out, &s.x, Some(&colours)).unwrap();
    let text = String::from_utf8(out).unwrap();
    assert!(
        text.lines()
            .any(|l| l.starts_with("v ") && l.split_whitespace().count() == 7)
    );
    let back = parse_obj(text.as_bytes()).unwrap();
    assert_eq!(back.triangles, model.faces());
    for (p, q) in back.positions.iter().flatten().zip(&s.x) {
        approx::assert_abs_diff_eq!(p, q, epsilon = 1e-9);
    }
    // A rope has no faces: its springs become OBJ lines.
    let (r, rs) = rope(&Default::default()).unwrap();
    let mut out = Vec::new();
    r.write_obj(&mut out, &rs.x, None).unwrap();
    let text = String::from_utf8(out).unwrap();
    assert_eq!(text.lines().filter(|l| l.starts_with("l ")).count(), 9);
}

#[test]
fn implicit_euler_system_export_reads_back_as_the_same_system() {
    let (model, mut s) = cloth(&ClothParams {
        nu: 4,
        nv: 4,
        ..Default::default()
    })
    .unwrap();
    for (k, v) in s.v.iter_mut().enumerate() {
        *v = 0.01 * ((k * 7 % 11) as f64 - 5.0);
    }
    s.x[5] += 0.01;
    let h = 0.01;
    let (mut a_txt, mut b_txt) = (Vec::new(), Vec::new());
    model
        .write_implicit_euler_system(h, &s.x, &s.v, &mut a_txt, &mut b_txt)
        .unwrap();
    let a = read_matrix_market(a_txt.as_slice()).unwrap().into_csr();
    let b = read_matrix_market(b_txt.as_slice())
        .unwrap()
        .into_vector()
        .unwrap();
    // Independently: A = M - h df/dv - h^2 df/dx and b = h (f + h df/dx v).
    let (mut dfdx, mut dfdv) = model.new_jacobians();
    model.force_jacobians(0.0, &s.x, &s.v, &mut dfdx, &mut dfdv);
    let mut f = vec![0.0; model.dim()];
    model.force(0.0, &s.x, &s.v, &mut f);
    let (dx, dv) = (dense(&dfdx), dense(&dfdv));
    let ad = dense_of_csr(&a);
    let n = model.dim();
    for i in 0..n {
        for j in 0..n {
            let m = if i == j { model.mass()[i] } else { 0.0 };
            let expect = m - h * dv[i][j] - h * h * dx[i][j];
            assert!((ad[i][j] - expect).abs() < 1e-12 * (1.0 + expect.abs()));
        }
        let kv: f64 = (0..n).map(|j| dx[i][j] * s.v[j]).sum();
        let expect = h * (f[i] + h * kv);
        assert!((b[i] - expect).abs() < 1e-12 * (1.0 + expect.abs()));
    }
    assert_eq!(a.rows(), n);
    let mut y = vec![0.0; n];
    a.apply(&s.v, &mut y);
    // Also through files.
    let dir = std::env::temp_dir().join(format!("hookean-massspring-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    model
        .export_implicit_euler_system(h, &s.x, &s.v, dir.join("A.mtx"), dir.join("b.mtx"))
        .unwrap();
    let a2 = hookean_sparse::read_matrix_market_file(dir.join("A.mtx"))
        .unwrap()
        .into_csr();
    assert_eq!(a2.nnz(), a.nnz());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_springs_and_masses_are_typed_errors() {
    let ok = |i, j| Spring::new(i, j, 1.0, 10.0, 0.1);
    let opts = ModelOptions::default();
    assert_eq!(
        MassSpringModel::new(vec![1.0; 3], vec![ok(0, 1), ok(1, 3)], opts).unwrap_err(),
        MassSpringError::ParticleOutOfRange {
            spring: 1,
            particle: 3,
            n_particles: 3
        }
    );
    assert_eq!(
        MassSpringModel::new(vec![1.0; 3], vec![ok(2, 2)], opts).unwrap_err(),
        MassSpringError::SelfSpring {
            spring: 0,
            particle: 2
        }
    );
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            MassSpringModel::new(vec![1.0, bad], vec![ok(0, 1)], opts).unwrap_err(),
            MassSpringError::InvalidMass { particle: 1, .. }
        ));
    }
    assert_eq!(
        MassSpringModel::new(vec![1.0; 2], vec![Spring::new(0, 1, 0.0, 1.0, 0.0)], opts)
            .unwrap_err(),
        MassSpringError::ZeroLengthSpring {
            spring: 0,
            i: 0,
            j: 1
        }
    );
    assert!(matches!(
        MassSpringModel::new(vec![1.0; 2], vec![Spring::new(0, 1, 1.0, -5.0, 0.0)], opts)
            .unwrap_err(),
        MassSpringError::InvalidSpring {
            parameter: "stiffness",
            ..
        }
    ));
    assert!(matches!(
        MassSpringModel::new(
            vec![1.0; 2],
            vec![ok(0, 1)],
            ModelOptions {
                air_friction: -1.0,
                ..opts
            }
        )
        .unwrap_err(),
        MassSpringError::InvalidParameter { .. }
    ));
    // A mesh with a degenerate (zero-area) triangle whose edge has zero length.
    let mesh = parse_obj("v 0 0 0\nv 0 0 0\nv 1 0 0\nf 1 2 3\n".as_bytes()).unwrap();
    assert!(matches!(
        from_mesh(&mesh, &MeshParams::default()).unwrap_err(),
        MassSpringError::ZeroLengthSpring { .. }
    ));
    assert!(matches!(
        cloth(&ClothParams {
            pins: ClothPins::Particles(vec![99]),
            nu: 3,
            nv: 3,
            ..Default::default()
        })
        .unwrap_err(),
        MassSpringError::NoSuchParticle { particle: 99, .. }
    ));
    assert!(matches!(
        Collider::sphere([0.0; 3], -1.0, 0.0).unwrap_err(),
        MassSpringError::InvalidParameter { .. }
    ));
    assert!(matches!(
        Collider::plane([0.0; 3], [0.0; 3], 0.0).unwrap_err(),
        MassSpringError::InvalidParameter { .. }
    ));
}

#[test]
fn nan_and_wrong_sizes_in_a_state_are_typed_errors() {
    let (model, s) = tutorial_example3().unwrap();
    let mut x = s.x.clone();
    x[4] = f64::NAN;
    assert_eq!(
        model.check_state(&x, &s.v).unwrap_err(),
        MassSpringError::NonFinite {
            what: "x",
            index: 4
        }
    );
    let mut f = vec![0.0; 6];
    assert!(matches!(
        model.force_checked(&s.x, &[0.0, f64::INFINITY, 0.0, 0.0, 0.0, 0.0], &mut f),
        Err(MassSpringError::NonFinite {
            what: "v",
            index: 1
        })
    ));
    assert!(matches!(
        model.energies(&s.x[..5], &s.v),
        Err(MassSpringError::DimensionMismatch {
            what: "x",
            expected: 6,
            found: 5
        })
    ));
    assert!(matches!(
        model.stability(&x, &Default::default(), None),
        Err(MassSpringError::NonFinite { .. })
    ));
    // Coincident spring endpoints in a state.
    let collapsed = vec![0.0; 6];
    assert_eq!(
        model.check_state(&collapsed, &s.v).unwrap_err(),
        MassSpringError::ZeroLengthSpring {
            spring: 0,
            i: 0,
            j: 1
        }
    );
    let mut sys = model.implicit_system();
    assert!(matches!(
        model.assemble_implicit_euler(-0.1, &s.x, &s.v, &mut sys),
        Err(MassSpringError::InvalidParameter { name: "h", .. })
    ));
    // A model without springs has no stiffness: the power iterate vanishes.
    let lone = MassSpringModel::new(vec![1.0], vec![], ModelOptions::default()).unwrap();
    assert!(matches!(
        lone.stability(&[0.0; 3], &Default::default(), None),
        Err(MassSpringError::Sparse(_))
    ));
}

#[test]
fn malformed_obj_names_the_line() {
    let cases: [(&str, usize); 6] = [
        ("v 0 0 0\nv 1 0\n", 2),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", 4),
        ("v 0 0 0\n# ok\nv 1 x 0\n", 3),
        ("v 0 0 0\nv 1 0 0\nf 1 2\n", 3),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 0 1 2\n", 5),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", 4),
    ];
    for (text, line) in cases {
        match parse_obj(text.as_bytes()) {
            Err(MassSpringError::ObjParse { line: l, message }) => {
                assert_eq!(l, line, "{text:?}: {message}");
                let shown = MassSpringError::ObjParse {
                    line: l,
                    message: message.clone(),
                }
                .to_string();
                assert!(shown.starts_with(&format!("OBJ line {line}:")));
            }
            other => panic!("{text:?}: expected a parse error, got {other:?}"),
        }
    }
    assert!(matches!(
        hookean_massspring::read_obj_file("/nonexistent/mesh.obj"),
        Err(MassSpringError::Io { .. })
    ));
}

#[test]
fn force_and_jacobian_refills_do_not_depend_on_previous_contents() {
    // Refill in place: a second assembly at another state gives the same
    // matrices as a fresh assembly there (nothing accumulates).
    let (model, s) = cloth(&ClothParams {
        nu: 5,
        nv: 5,
        ..Default::default()
    })
    .unwrap();
    let mut s2 = s.clone();
    for (k, x) in s2.x.iter_mut().enumerate() {
        *x += 0.01 * ((k % 5) as f64 - 2.0);
    }
    let (mut a, mut b) = model.new_jacobians();
    model.force_jacobians(0.0, &s.x, &s.v, &mut a, &mut b);
    model.force_jacobians(0.0, &s2.x, &s2.v, &mut a, &mut b);
    let (mut a2, mut b2) = model.new_jacobians();
    model.force_jacobians(0.0, &s2.x, &s2.v, &mut a2, &mut b2);
    assert_eq!(a.values(), a2.values());
    assert_eq!(b.values(), b2.values());
    let _ = State::at_rest(&[[0.0; 3]]);
    let _ = SpringMaterial::new(1.0, 0.0);
}
