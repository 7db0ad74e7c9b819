//! Near-nullspaces of more vectors than unknowns per node (rigid-body
//! modes), checked against their mathematics.

use super::super::testutil::rhs;
use super::tests::{elasticity_hex, elasticity_q1, matmul, pcg_iterations, transpose_dense};
use super::*;
use crate::vecops::{dot, norm2};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

/// The coordinates of the nodes of the `m^dim` grid of the unit square or
/// cube, node `(x, y, z)` numbered `(z (m+1) + y) (m+1) + x` (the numbering
/// of [`elasticity_q1`] and [`elasticity_hex`]).
fn grid(m: usize, dim: usize) -> Vec<f64> {
    let nodes = (m + 1).pow(dim as u32);
    (0..nodes)
        .flat_map(|i| {
            (0..dim).map(move |c| (i / (m + 1).pow(c as u32) % (m + 1)) as f64 / m as f64)
        })
        .collect()
}

#[test]
fn the_tentative_prolongator_reproduces_more_modes_than_unknowns_per_node() {
    for (a, dim, m) in [(elasticity_q1(12), 2, 12), (elasticity_hex(5), 3, 5)] {
        let modes = rigid_body_modes(&grid(m, dim), dim).unwrap();
        let k = modes.len();
        assert_eq!(k, if dim == 2 { 3 } else { 6 });
        let mut amg = Amg::with_options(AmgOptions {
            block_size: dim,
            near_nullspace: modes.clone(),
            coarse_size: 40,
            precision: AmgPrecision::Double,
            ..Default::default()
        })
        .unwrap();
        amg.setup(&a).unwrap();
        let Inner::Csr(c) = &amg.inner else {
            panic!("a CSR hierarchy")
        };
        let levels = c.h.dense_levels();
        assert!(levels.len() >= 2, "{:?}", amg.stats());
        let (_, Some((_, t))) = &levels[0] else {
            panic!("one level only")
        };
        // k unknowns per coarse node: the next operator has T's columns.
        assert_eq!(t[0].len() % k, 0);
        assert_eq!(levels[1].0.len(), t[0].len());
        let tt = transpose_dense(t);
        for (r, row) in matmul(&tt, t).iter().enumerate() {
            for (c, v) in row.iter().enumerate() {
                let e = if r == c { 1.0 } else { 0.0 };
                assert!((v - e).abs() < 1e-12, "T^T T ({r},{c}) = {v}");
            }
        }
        // N = T R with R = T^T N: every mode is reproduced on the aggregated
        // nodes, all but the clamped ones (a grid line or face of the
        // m + 1: no strong neighbour, no row of T).
        let aggregated: Vec<usize> = (0..t.len())
            .filter(|&i| t[i].iter().any(|&x| x != 0.0))
            .collect();
        assert_eq!(aggregated.len(), t.len() * m / (m + 1));
        for v in &modes {
            let coarse: Vec<f64> = tt.iter().map(|row| dot(row, v)).collect();
            for &i in &aggregated {
                let back = dot(&t[i], &coarse);
                approx::assert_abs_diff_eq!(back, v[i], epsilon = 1e-12 * norm2(v));
            }
        }
        // Every coarse operator is symmetric positive definite on its
        // diagonal blocks (the completed columns keep it so): PCG converges.
        let b = rhs(a.rows());
        assert!(pcg_iterations(&a, &amg, &b) < 40);
    }
}

/// The stiffness matrix (dense) of linear elasticity (Lamé `lambda`,
/// `mu`) with linear (P1) simplices `elements` over nodes at `x`
/// (`dim` coordinates each), no boundary conditions:
/// `K_ab[i][j] = V (lambda d_i phi_a d_j phi_b + mu d_j phi_a d_i phi_b
/// + mu delta_ij grad phi_a . grad phi_b)`.
fn p1_stiffness(x: &[f64], dim: usize, elements: &[Vec<usize>]) -> Vec<Vec<f64>> {
    let (lambda, mu) = (0.6, 0.4);
    let n = x.len();
    let mut k = vec![vec![0.0; n]; n];
    for e in elements {
        // J = [x_1 - x_0, ..., x_d - x_0]; grad phi_a = J^-T e_a (a >= 1).
        let mut j = [[0.0; 3]; 3];
        for c in 0..dim {
            for r in 0..dim {
                j[r][c] = x[dim * e[c + 1] + r] - x[dim * e[0] + r];
            }
        }
        let (inv, det) = invert(&j, dim);
        let mut grad = vec![[0.0; 3]; dim + 1];
        for a in 1..=dim {
            for r in 0..dim {
                // (J^-T)_{r, a-1} = (J^-1)_{a-1, r}.
                grad[a][r] = inv[a - 1][r];
                grad[0][r] -= inv[a - 1][r];
            }
        }
        let volume = det.abs() / if dim == 2 { 2.0 } else { 6.0 };
        for (a, ga) in grad.iter().enumerate() {
            for (b, gb) in grad.iter().enumerate() {
                let gg: f64 = (0..dim).map(|r| ga[r] * gb[r]).sum();
                for i in 0..dim {
                    for jj in 0..dim {
                        let v = lambda * ga[i] * gb[jj]
                            + mu * ga[jj] * gb[i]
                            + if i == jj { mu * gg } else { 0.0 };
                        k[dim * e[a] + i][dim * e[b] + jj] += volume * v;
                    }
                }
            }
        }
    }
    k
}

/// The inverse and determinant of the leading `dim x dim` block of `j`.
fn invert(j: &[[f64; 3]; 3], dim: usize) -> ([[f64; 3]; 3], f64) {
    let mut inv = [[0.0; 3]; 3];
    if dim == 2 {
        let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        inv[0] = [j[1][1] / det, -j[0][1] / det, 0.0];
        inv[1] = [-j[1][0] / det, j[0][0] / det, 0.0];
        return (inv, det);
    }
    let det = j[0][0] * (j[1][1] * j[2][2] - j[1][2] * j[2][1])
        - j[0][1] * (j[1][0] * j[2][2] - j[1][2] * j[2][0])
        + j[0][2] * (j[1][0] * j[2][1] - j[1][1] * j[2][0]);
    for r in 0..3 {
        for c in 0..3 {
            // Cofactor of (c, r) over det: the adjugate's entry (r, c).
            let (r1, r2) = ((c + 1) % 3, (c + 2) % 3);
            let (c1, c2) = ((r + 1) % 3, (r + 2) % 3);
            inv[r][c] = (j[r1][c1] * j[r2][c2] - j[r1][c2] * j[r2][c1]) / det;
        }
    }
    (inv, det)
}

#[test]
fn rigid_body_modes_lie_in_the_kernel_of_unconstrained_elasticity() {
    let mut rng = SmallRng::seed_from_u64(29);
    for dim in [2, 3] {
        // A perturbed grid of 3^dim nodes and random simplices on it.
        let mut x = grid(2, dim);
        for v in x.iter_mut() {
            *v = 3.0 * *v + 0.2 * rng.random_range(-1.0..1.0) + 5.0;
        }
        let nodes = x.len() / dim;
        let elements: Vec<Vec<usize>> = (0..4 * nodes)
            .map(|_| {
                let mut e: Vec<usize> = Vec::new();
                while e.len() <= dim {
                    let v = rng.random_range(0..nodes);
                    if !e.contains(&v) {
                        e.push(v);
                    }
                }
                e
            })
            .collect();
        let k = p1_stiffness(&x, dim, &elements);
        let scale = k.iter().flatten().fold(0.0_f64, |m, v| m.max(v.abs()));
        let times =
            |v: &[f64]| -> f64 { norm2(&k.iter().map(|row| dot(row, v)).collect::<Vec<_>>()) };
        let modes = rigid_body_modes(&x, dim).unwrap();
        assert_eq!(modes.len(), if dim == 2 { 3 } else { 6 });
        for (i, v) in modes.iter().enumerate() {
            let kv = times(v);
            assert!(
                kv <= 1e-12 * scale * norm2(v),
                "dim {dim}, mode {i}: |K v| = {kv:e}"
            );
        }
        // A stretch along x is no rigid motion: K sees it.
        let stretch: Vec<f64> = (0..x.len())
            .map(|i| if i % dim == 0 { x[i] - 5.0 } else { 0.0 })
            .collect();
        let ks = times(&stretch);
        assert!(ks > 1e-6 * scale * norm2(&stretch), "|K u| = {ks:e}");
        // The modes are independent: their Gram matrix is diagonal
        // (translations orthogonal to rotations about the centroid) in 2D.
        if dim == 2 {
            for p in 0..3 {
                for q in 0..p {
                    assert!(dot(&modes[p], &modes[q]).abs() < 1e-9, "{p} {q}");
                }
            }
        }
    }
    assert!(rigid_body_modes(&[0.0; 5], 2).is_err());
    assert!(rigid_body_modes(&[0.0; 4], 4).is_err());
    assert!(rigid_body_modes(&[0.0, f64::NAN], 2).is_err());
}

#[test]
fn rigid_body_modes_cut_the_iterations_on_2d_and_3d_elasticity() {
    // 2D: nodes of 2 unknowns, 3 modes; 3D: of 3 unknowns, 6 modes, from CSR
    // and from 3x3 block storage (the same hierarchy, the same iterations).
    for (a, dim, m) in [(elasticity_q1(60), 2, 60), (elasticity_hex(12), 3, 12)] {
        let b = rhs(a.rows());
        let iterations = |near_nullspace: Vec<Vec<f64>>| {
            let mut amg = Amg::with_options(AmgOptions {
                block_size: dim,
                near_nullspace,
                ..Default::default()
            })
            .unwrap();
            amg.setup(&a).unwrap();
            pcg_iterations(&a, &amg, &b)
        };
        let modes = rigid_body_modes(&grid(m, dim), dim).unwrap();
        let (without, with) = (iterations(Vec::new()), iterations(modes.clone()));
        assert!(
            (with as f64) < 0.8 * without as f64,
            "dim {dim}: {with} iterations with the modes, {without} without"
        );
        if dim == 3 {
            let mut amg = Amg::with_options(AmgOptions {
                near_nullspace: modes,
                ..Default::default()
            })
            .unwrap();
            amg.setup(&SymBlockMatrix::from_csr(&a).unwrap()).unwrap();
            assert_eq!(pcg_iterations(&a, &amg, &b), with);
        }
    }
}

#[test]
fn unsupported_or_dependent_near_nullspaces_are_typed_errors() {
    let a = elasticity_q1(6);
    let modes = rigid_body_modes(&grid(6, 2), 2).unwrap();
    // 3 vectors on scalar nodes: not a supported pair.
    let mut amg = Amg::with_options(AmgOptions {
        near_nullspace: modes.clone(),
        ..Default::default()
    })
    .unwrap();
    assert!(matches!(
        amg.setup(&a),
        Err(SparseError::InvalidParameter {
            name: "near_nullspace",
            ..
        })
    ));
    // The rotation given twice: dependent.
    let mut amg = Amg::with_options(AmgOptions {
        block_size: 2,
        near_nullspace: vec![modes[0].clone(), modes[2].clone(), modes[2].clone()],
        ..Default::default()
    })
    .unwrap();
    assert!(matches!(
        amg.setup(&a),
        Err(SparseError::InvalidParameter {
            name: "near_nullspace",
            ..
        })
    ));
}
