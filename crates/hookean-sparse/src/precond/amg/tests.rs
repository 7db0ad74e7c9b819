//! The multigrid checked against its mathematics.

use super::super::testutil::{dense, rhs, spd_block_matrix};
use super::*;
use crate::vecops::{dot, norm2};
use crate::{CgParams, CgWorkspace, LinearOperator, pcg};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

/// Options that force several levels on small test matrices, with the
/// hierarchy in double precision (so products can be checked to 1e-13).
fn small_coarse(smoother: AmgSmoother) -> AmgOptions {
    AmgOptions {
        coarse_size: 40,
        smoother,
        precision: AmgPrecision::Double,
        ..Default::default()
    }
}

fn hierarchy3(amg: &Amg) -> &hierarchy::Hierarchy<3, 3, f64> {
    match &amg.inner {
        Inner::Block {
            h: Levels::D33(h), ..
        } => h,
        _ => panic!("not a double-precision block hierarchy"),
    }
}

fn hierarchy3_single(amg: &Amg) -> &hierarchy::Hierarchy<3, 3, f32> {
    match &amg.inner {
        Inner::Block {
            h: Levels::S33(h), ..
        } => h,
        _ => panic!("not a single-precision block hierarchy"),
    }
}

/// Row-major dense copy of a block matrix.
fn dense_bsr<const B: usize, S: bsr::Entry>(m: &Bsr<B, S>) -> Vec<Vec<f64>> {
    let mut d = vec![vec![0.0; B * m.ncols]; B * m.nrows];
    for i in 0..m.nrows {
        for k in m.row(i) {
            let j = m.col[k] as usize;
            for r in 0..B {
                for c in 0..B {
                    d[B * i + r][B * j + c] = bsr::Entry::load(m.val[k][r][c]);
                }
            }
        }
    }
    d
}

/// Every coarse operator of `h` equals `P^T A P` of the stored level
/// matrices, entry by entry to `tol` times the product's largest entry.
fn assert_galerkin<S: bsr::Entry>(h: &hierarchy::Hierarchy<3, 3, S>, tol: f64) {
    assert!(h.n_levels() >= 2);
    for l in 0..h.n_levels() - 1 {
        let (al, Some((p, _))) = h.level_matrices(l) else {
            unreachable!()
        };
        let (ac, _) = h.level_matrices(l + 1);
        let (al, p, ac) = (dense_bsr(al), dense_bsr(p), dense_bsr(ac));
        let expected = matmul(&transpose_dense(&p), &matmul(&al, &p));
        let scale = expected
            .iter()
            .flatten()
            .fold(0.0_f64, |m, v| m.max(v.abs()));
        for (r, row) in expected.iter().enumerate() {
            for (c, v) in row.iter().enumerate() {
                assert!((ac[r][c] - v).abs() <= tol * scale, "level {l} ({r},{c})");
            }
        }
    }
}

pub(super) fn transpose_dense(m: &[Vec<f64>]) -> Vec<Vec<f64>> {
    (0..m[0].len())
        .map(|c| m.iter().map(|row| row[c]).collect())
        .collect()
}

pub(super) fn matmul(a: &[Vec<f64>], b: &[Vec<f64>]) -> Vec<Vec<f64>> {
    super::super::testutil::matmul(a, b)
}

/// The Poisson matrix (`2 dim` on the diagonal, `-1` to each grid
/// neighbour) on `n^dim` points, `dim` in 1..=3, Dirichlet boundary, as
/// scalar CSR.
fn poisson(n: usize, dim: usize) -> sprs::CsMat<f64> {
    let size = n.pow(dim as u32);
    let mut t = sprs::TriMat::new((size, size));
    for p in 0..size {
        t.add_triplet(p, p, 2.0 * dim as f64);
        let mut stride = 1;
        for _ in 0..dim {
            let coordinate = (p / stride) % n;
            if coordinate > 0 {
                t.add_triplet(p, p - stride, -1.0);
            }
            if coordinate + 1 < n {
                t.add_triplet(p, p + stride, -1.0);
            }
            stride *= n;
        }
    }
    t.to_csr()
}

#[test]
fn v_cycle_is_symmetric_and_positive() {
    let a = spd_block_matrix(24, 20);
    let n = a.dim();
    let csr = a.to_csr();
    let mut rng = SmallRng::seed_from_u64(15);
    for smoother in [
        AmgSmoother::BlockJacobi,
        AmgSmoother::SymmetricGaussSeidel,
        AmgSmoother::BlockIc0,
    ] {
        for (scalar, precision) in [
            (false, AmgPrecision::Double),
            (true, AmgPrecision::Double),
            (false, AmgPrecision::Single),
            (true, AmgPrecision::Single),
        ] {
            // Single precision rounds the stored matrices, but every level
            // uses the same rounded matrix in its smoothing and residuals:
            // the cycle stays symmetric to f64 round-off.
            let mut amg = Amg::with_options(AmgOptions {
                precision,
                ..small_coarse(smoother)
            })
            .unwrap();
            if scalar {
                amg.setup(&csr).unwrap();
            } else {
                amg.setup(&a).unwrap();
            }
            assert!(amg.stats().levels.len() >= 3, "{:?}", amg.stats());
            let mut bx = vec![0.0; n];
            let mut by = vec![0.0; n];
            for _ in 0..8 {
                let x: Vec<f64> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
                let y: Vec<f64> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
                amg.apply(&x, &mut bx);
                amg.apply(&y, &mut by);
                let (bxy, xby) = (dot(&bx, &y), dot(&x, &by));
                let scale = norm2(&bx) * norm2(&y) + norm2(&x) * norm2(&by);
                assert!(
                    (bxy - xby).abs() <= 1e-13 * scale,
                    "{smoother:?} {precision:?} scalar {scalar}: <Bx,y> = {bxy}, <x,By> = {xby}"
                );
                assert!(dot(&bx, &x) > 0.0);
            }
        }
    }
}

#[test]
fn near_nullspace_lies_in_the_range_of_the_tentative_prolongator() {
    let a = spd_block_matrix(10, 9);
    let nb = a.n_blocks();
    // Translations and, as user vectors, three other smooth fields.
    let user: Vec<Vec<f64>> = (0..3)
        .map(|c| {
            (0..3 * nb)
                .map(|i| {
                    1.0 + ((i / 3) as f64 * 0.1 + c as f64).sin()
                        * if i % 3 == c { 1.0 } else { 0.3 }
                })
                .collect()
        })
        .collect();
    for vectors in [Vec::new(), user] {
        let mut amg = Amg::with_options(AmgOptions {
            near_nullspace: vectors.clone(),
            ..small_coarse(AmgSmoother::BlockJacobi)
        })
        .unwrap();
        amg.setup(&a).unwrap();
        let h = hierarchy3(&amg);
        let (_, Some((_, t))) = h.level_matrices(0) else {
            panic!("one level only")
        };
        let t = dense_bsr(t);
        let tt = transpose_dense(&t);
        // T^T T = I on the aggregated columns.
        let ttt = matmul(&tt, &t);
        for (r, row) in ttt.iter().enumerate() {
            for (c, v) in row.iter().enumerate() {
                let e = if r == c { 1.0 } else { 0.0 };
                assert!((v - e).abs() < 1e-13, "T^T T ({r},{c}) = {v}");
            }
        }
        // N = T (T^T N): the nullspace is reproduced exactly.
        let nvec: Vec<Vec<f64>> = if vectors.is_empty() {
            (0..3)
                .map(|c| {
                    (0..3 * nb)
                        .map(|i| if i % 3 == c { 1.0 } else { 0.0 })
                        .collect()
                })
                .collect()
        } else {
            vectors
        };
        for v in &nvec {
            let coarse: Vec<f64> = tt.iter().map(|row| dot(row, v)).collect();
            let back: Vec<f64> = t.iter().map(|row| dot(row, &coarse)).collect();
            for (x, y) in back.iter().zip(v) {
                approx::assert_abs_diff_eq!(x, y, epsilon = 1e-13 * norm2(v));
            }
        }
    }
}

#[test]
fn coarse_operator_is_the_galerkin_product() {
    let a = spd_block_matrix(9, 8);
    let mut amg = Amg::with_options(small_coarse(AmgSmoother::BlockJacobi)).unwrap();
    amg.setup(&a).unwrap();
    let h = hierarchy3(&amg);
    assert_eq!(dense_bsr(h.level_matrices(0).0), dense(&a));
    assert_galerkin(h, 1e-13);
}

/// The asymptotic convergence factor of the stationary iteration
/// `x += B (b - A x)` on `A x = 0` from a rough start.
fn stationary_rate(a: &sprs::CsMat<f64>, amg: &Amg) -> f64 {
    let n = a.rows();
    let mut x: Vec<f64> = (0..n)
        .map(|i| ((i * 7919) % 1000) as f64 / 1000.0 - 0.5)
        .collect();
    let mut r = vec![0.0; n];
    let mut z = vec![0.0; n];
    let mut norms = Vec::new();
    for _ in 0..12 {
        a.apply(&x, &mut r);
        r.iter_mut().for_each(|v| *v = -*v);
        norms.push(norm2(&r));
        amg.apply(&r, &mut z);
        x.iter_mut().zip(&z).for_each(|(x, z)| *x += z);
    }
    (norms[11] / norms[6]).powf(1.0 / 5.0)
}

#[test]
fn two_grid_and_v_cycle_rates_do_not_grow_with_the_size() {
    for (dim, sizes) in [(1, [64, 256, 1024]), (2, [16, 32, 64])] {
        for max_levels in [2, 10] {
            let rates: Vec<f64> = sizes
                .iter()
                .map(|&n| {
                    let a = poisson(n, dim);
                    let mut amg = Amg::with_options(AmgOptions {
                        max_levels,
                        coarse_size: 20,
                        ..Default::default()
                    })
                    .unwrap();
                    amg.setup(&a).unwrap();
                    let levels = amg.stats().levels.len();
                    assert!((2..=max_levels).contains(&levels), "{levels} levels");
                    stationary_rate(&a, &amg)
                })
                .collect();
            for &rate in &rates {
                assert!(rate < 0.6, "{dim}D, {max_levels} levels: rates {rates:?}");
            }
            assert!(
                rates[2] < rates[0] + 0.1,
                "{dim}D, {max_levels} levels: rate grows with the size: {rates:?}"
            );
        }
    }
}

#[test]
fn small_matrix_is_solved_directly() {
    let a = spd_block_matrix(3, 3);
    // Exactly in double precision; in single precision the factor is of
    // the matrix rounded to f32 (relative error of order 1e-7).
    for (precision, tol) in [(AmgPrecision::Double, 1e-12), (AmgPrecision::Single, 1e-5)] {
        let mut amg = Amg::with_options(AmgOptions {
            precision,
            ..Default::default()
        })
        .unwrap();
        amg.setup(&a).unwrap();
        assert_eq!(amg.stats().levels.len(), 1);
        assert!(amg.stats().coarsest_direct);
        let r = rhs(a.dim());
        let mut z = vec![0.0; r.len()];
        amg.apply(&r, &mut z);
        let mut az = vec![0.0; r.len()];
        a.apply(&z, &mut az);
        let err = super::super::testutil::rel_diff(&az, &r);
        assert!(err < tol, "{precision:?}: {err}");
        if precision == AmgPrecision::Single {
            assert!(
                err > 1e-12,
                "the single-precision factor is of the rounded matrix"
            );
        }
    }
}

/// A mass-dominated system, `A = I + eps L` with `L` the 2D Poisson matrix:
/// every off-diagonal entry is weak (`eps / (1 + 4 eps)` against the
/// strength threshold), so the finest level does not coarsen. Above
/// `coarse_size` it is smoothed, not factored densely at every refill:
/// Gershgorin puts the eigenvalues of `D^-1 A` in `1 -+ 4 eps / (1 + 4 eps)`,
/// a condition number below 1.1, where CG gains about two digits per
/// iteration.
#[test]
fn a_finest_level_that_does_not_coarsen_is_smoothed_not_factored() {
    let eps = 0.01;
    let l = poisson(30, 2);
    let n = l.rows();
    let mut t = sprs::TriMat::new((n, n));
    for (v, (i, j)) in l.iter() {
        t.add_triplet(i, j, eps * v);
    }
    for i in 0..n {
        t.add_triplet(i, i, 1.0);
    }
    let a: sprs::CsMat<f64> = t.to_csr();
    let mut amg = Amg::new();
    amg.setup(&a).unwrap();
    assert!(n > AmgOptions::default().coarse_size);
    assert_eq!(amg.stats().levels.len(), 1, "{:?}", amg.stats());
    assert!(!amg.stats().coarsest_direct);
    let iterations = pcg_iterations(&a, &amg, &rhs(n));
    assert!(iterations <= 8, "{iterations} iterations");
    // One level because the options ask for one (not a stall): solved
    // directly, as a single-level hierarchy always was.
    let mut one_level = Amg::with_options(AmgOptions {
        max_levels: 1,
        ..Default::default()
    })
    .unwrap();
    one_level.setup(&a).unwrap();
    assert!(one_level.stats().coarsest_direct);
    assert!(pcg_iterations(&a, &one_level, &rhs(n)) <= 2);
}

#[test]
fn refill_reuses_the_hierarchy() {
    let a = spd_block_matrix(12, 12);
    // Gershgorin's bounds depend on the values only (no warm start), so a
    // refill must give exactly what a fresh set-up gives.
    let mut amg = Amg::with_options(AmgOptions {
        power_iterations: 0,
        ..small_coarse(AmgSmoother::BlockJacobi)
    })
    .unwrap();
    amg.setup(&a).unwrap();
    let r = rhs(a.dim());
    let mut z1 = vec![0.0; r.len()];
    amg.apply(&r, &mut z1);
    // 2 A: D^-1 A, omega and P are unchanged, every A_l doubles, so the
    // V-cycle halves.
    let mut a2 = a.clone();
    a2.scale(2.0);
    amg.setup(&a2).unwrap();
    assert_eq!((amg.stats().setups, amg.stats().refills), (1, 1));
    let mut z2 = vec![0.0; r.len()];
    amg.apply(&r, &mut z2);
    for (u, v) in z1.iter().zip(&z2) {
        approx::assert_abs_diff_eq!(*u, 2.0 * v, epsilon = 1e-12 * norm2(&z1));
    }
    // A rebuild on the same values gives the same operator.
    amg.rebuild(&a2).unwrap();
    assert_eq!(amg.stats().setups, 2);
    let mut z3 = vec![0.0; r.len()];
    amg.apply(&r, &mut z3);
    for (u, v) in z3.iter().zip(&z2) {
        approx::assert_abs_diff_eq!(u, v, epsilon = 1e-13 * norm2(&z2));
    }
    // With the power method, a refill continues from the last eigenvector
    // estimates for a few steps: its spectral radius estimates are at least
    // a fresh set-up's (more steps of the same iteration), so its weights
    // are at most those, and close (with enough steps that the estimates
    // increase monotonically).
    let power = AmgOptions {
        power_iterations: 10,
        ..small_coarse(AmgSmoother::BlockJacobi)
    };
    let mut warm = Amg::with_options(power.clone()).unwrap();
    warm.setup(&a).unwrap();
    warm.setup(&a2).unwrap();
    let mut fresh = Amg::with_options(power).unwrap();
    fresh.setup(&a2).unwrap();
    for (w, f) in warm.stats().levels.iter().zip(&fresh.stats().levels) {
        for (x, y) in [
            (w.smoother_weight, f.smoother_weight),
            (w.prolongation_weight, f.prolongation_weight),
        ] {
            assert!(x <= y * (1.0 + 1e-9) && x >= 0.85 * y, "{x} vs {y}");
        }
    }
}

#[test]
fn reuse_policy_keeps_refills_or_rebuilds() {
    let a = spd_block_matrix(12, 12);
    let mut a2 = a.clone();
    a2.scale(2.0);
    let r = rhs(a.dim());
    let options = |reuse| AmgOptions {
        power_iterations: 0,
        reuse,
        ..small_coarse(AmgSmoother::BlockJacobi)
    };
    let cycle = |amg: &Amg| {
        let mut z = vec![0.0; r.len()];
        amg.apply(&r, &mut z);
        z
    };
    // Keep for 2 updates: the cycle of A twice, then the refill's of 2 A
    // (half of it, as in `refill_reuses_the_hierarchy`).
    let mut amg = Amg::with_options(options(AmgReuse::Keep { updates: 2 })).unwrap();
    amg.setup(&a).unwrap();
    let z1 = cycle(&amg);
    for kept in 1..=2 {
        amg.setup(&a2).unwrap();
        assert_eq!(cycle(&amg), z1);
        assert_eq!((amg.stats().kept, amg.stats().refills), (kept, 0));
    }
    amg.setup(&a2).unwrap();
    assert_eq!((amg.stats().kept, amg.stats().refills), (2, 1));
    for (u, v) in z1.iter().zip(&cycle(&amg)) {
        approx::assert_abs_diff_eq!(*u, 2.0 * v, epsilon = 1e-12 * norm2(&z1));
    }
    // Keeping again starts counting after the refill.
    amg.setup(&a).unwrap();
    assert_eq!(amg.stats().kept, 3);
    // Rebuild: every set-up is a full one.
    let mut amg = Amg::with_options(options(AmgReuse::Rebuild)).unwrap();
    amg.setup(&a).unwrap();
    amg.setup(&a2).unwrap();
    assert_eq!((amg.stats().setups, amg.stats().refills), (2, 0));
    // A refill without power steps keeps the weights of the last estimates;
    // one with them follows the new values (a diagonal shift lowers rho).
    let mut shifted = a.clone();
    shifted.add_to_diagonal(&vec![5.0; a.dim()]).unwrap();
    let weights = |amg: &Amg| -> Vec<(f64, f64)> {
        amg.stats()
            .levels
            .iter()
            .map(|l| (l.smoother_weight, l.prolongation_weight))
            .collect()
    };
    for (steps, kept) in [(0, true), (3, false)] {
        let mut amg = Amg::with_options(AmgOptions {
            refill_power_iterations: steps,
            ..small_coarse(AmgSmoother::BlockJacobi)
        })
        .unwrap();
        amg.setup(&a).unwrap();
        let before = weights(&amg);
        amg.setup(&shifted).unwrap();
        assert_eq!(amg.stats().refills, 1);
        assert_eq!(weights(&amg) == before, kept, "{steps} steps");
    }
    // A new pattern is a full set-up whatever the policy.
    let mut amg = Amg::with_options(options(AmgReuse::Keep { updates: 5 })).unwrap();
    amg.setup(&a).unwrap();
    amg.setup(&spd_block_matrix(10, 12)).unwrap();
    assert_eq!((amg.stats().setups, amg.stats().kept), (2, 0));
}

#[test]
fn bad_input_gets_typed_errors() {
    let a = spd_block_matrix(4, 4);
    let dim = a.dim();
    let mut amg = Amg::with_options(AmgOptions {
        near_nullspace: vec![vec![1.0; dim]; 3]
            .into_iter()
            .enumerate()
            .map(|(i, v)| if i == 1 { v[..dim - 1].to_vec() } else { v })
            .collect(),
        ..Default::default()
    })
    .unwrap();
    assert_eq!(
        amg.setup(&a),
        Err(SparseError::NullspaceLength {
            vector: 1,
            expected: dim,
            found: dim - 1
        })
    );
    let mut amg = Amg::with_options(AmgOptions {
        near_nullspace: vec![vec![1.0; dim]; 2],
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
    assert!(
        Amg::with_options(AmgOptions {
            jacobi_weight: 2.5,
            ..Default::default()
        })
        .is_err()
    );
    // A singular diagonal block.
    let mut b = a.clone();
    let d = *b.diagonal_block(5);
    b.add_to_block(5, 5, &crate::block::scale(&d, -1.0))
        .unwrap();
    assert!(matches!(
        Amg::new().setup(&b),
        Err(SparseError::SingularBlock { block: 5, .. })
    ));
    // A negative definite diagonal block.
    let mut e = a.clone();
    e.add_to_block(2, 2, &crate::block::scale(&d, -2.0))
        .unwrap();
    assert!(matches!(
        Amg::new().setup(&e),
        Err(SparseError::AmgNotPositiveDefinite {
            level: 0,
            row: 6,
            what: "diagonal block"
        })
    ));
    // SPD diagonal blocks, indefinite matrix: [[1, 2], [2, 1]] per coordinate.
    let pattern = Arc::new(BlockPattern::new(2, [(0, 1)]).unwrap());
    let mut c = SymBlockMatrix::new(pattern);
    c.add_to_diagonal(&[1.0; 6]).unwrap();
    c.add_to_block(0, 1, &crate::block::scale(&crate::block::IDENTITY, 2.0))
        .unwrap();
    assert!(matches!(
        Amg::new().setup(&c),
        Err(SparseError::AmgNotPositiveDefinite {
            level: 0,
            what: "coarsest operator",
            ..
        })
    ));
}

/// PCG iterations to `|r| <= 1e-8 |b|` from zero with `amg`, after checking
/// the true residual.
pub(super) fn pcg_iterations<A: LinearOperator>(a: &A, amg: &Amg, b: &[f64]) -> usize {
    let n = b.len();
    let mut x = vec![0.0; n];
    let info = pcg(
        a,
        amg,
        b,
        &mut x,
        &CgParams::default(),
        &mut CgWorkspace::new(n),
        None,
    )
    .unwrap();
    let mut ax = vec![0.0; n];
    a.apply(&x, &mut ax);
    let res: Vec<f64> = ax.iter().zip(b).map(|(p, q)| p - q).collect();
    assert!(norm2(&res) <= 1.01e-8 * norm2(b));
    info.iterations
}

/// Assembles element matrices `ke` (`dofs` unknowns per node, interleaved)
/// over `elements` (their node lists), with the unknowns for which
/// `clamped` holds replaced by identity rows and columns.
fn assemble<const K: usize>(
    dim: usize,
    dofs: usize,
    ke: &[[f64; K]; K],
    elements: impl Iterator<Item = Vec<usize>>,
    clamped: impl Fn(usize) -> bool,
) -> sprs::CsMat<f64> {
    let mut t = sprs::TriMat::new((dim, dim));
    for nodes in elements {
        for r in 0..K {
            for c in 0..K {
                let (i, j) = (
                    dofs * nodes[r / dofs] + r % dofs,
                    dofs * nodes[c / dofs] + c % dofs,
                );
                if !clamped(i) && !clamped(j) {
                    t.add_triplet(i, j, ke[r][c]);
                }
            }
        }
    }
    for i in (0..dim).filter(|&i| clamped(i)) {
        t.add_triplet(i, i, 1.0);
    }
    t.to_csr()
}

#[test]
fn scalar_amg_pcg_on_3d_poisson_needs_at_most_40_iterations() {
    let a = poisson(40, 3);
    let n = a.rows();
    let b = rhs(n);
    let mut amg = Amg::new();
    amg.setup(&a).unwrap();
    assert!(amg.stats().levels.len() >= 3, "{:?}", amg.stats());
    let iterations = pcg_iterations(&a, &amg, &b);
    assert!(iterations <= 40, "{iterations} iterations");
}

/// 2D linear elasticity (plane stress, E = 1, nu = 0.3) with bilinear (Q1)
/// elements on an `m x m` grid of the unit square, the left edge clamped
/// (its rows and columns replaced by the identity); unknowns interleaved
/// `(u_x, u_y)` per node.
pub(super) fn elasticity_q1(m: usize) -> sprs::CsMat<f64> {
    let (e, nu) = (1.0, 0.3);
    let h = 1.0 / m as f64;
    let d = [
        [e / (1.0 - nu * nu), e * nu / (1.0 - nu * nu), 0.0],
        [e * nu / (1.0 - nu * nu), e / (1.0 - nu * nu), 0.0],
        [0.0, 0.0, e / (2.0 * (1.0 + nu))],
    ];
    let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
    // Element stiffness by 2 x 2 Gauss quadrature: sum B^T D B det J.
    let mut ke = [[0.0; 8]; 8];
    let g = 1.0 / 3.0_f64.sqrt();
    for (xi, eta) in [(-g, -g), (g, -g), (g, g), (-g, g)] {
        let mut bm = [[0.0; 8]; 3];
        for (a, &(xa, ya)) in corners.iter().enumerate() {
            let dx = xa * (1.0 + eta * ya) / 4.0 * 2.0 / h;
            let dy = ya * (1.0 + xi * xa) / 4.0 * 2.0 / h;
            bm[0][2 * a] = dx;
            bm[1][2 * a + 1] = dy;
            bm[2][2 * a] = dy;
            bm[2][2 * a + 1] = dx;
        }
        for r in 0..8 {
            for c in 0..8 {
                let mut v = 0.0;
                for p in 0..3 {
                    for q in 0..3 {
                        v += bm[p][r] * d[p][q] * bm[q][c];
                    }
                }
                ke[r][c] += v * h * h / 4.0;
            }
        }
    }
    let nodes = m + 1;
    let dim = 2 * nodes * nodes;
    let elements = (0..m * m).map(|e| {
        let (ex, ey) = (e % m, e / m);
        vec![
            ey * nodes + ex,
            ey * nodes + ex + 1,
            (ey + 1) * nodes + ex + 1,
            (ey + 1) * nodes + ex,
        ]
    });
    assemble(dim, 2, &ke, elements, |dof| (dof / 2).is_multiple_of(nodes))
}

#[test]
fn two_dof_amg_pcg_on_2d_elasticity_needs_at_most_40_iterations() {
    let a = elasticity_q1(100);
    let n = a.rows();
    let b = rhs(n);
    let mut amg = Amg::with_options(AmgOptions {
        block_size: 2,
        ..Default::default()
    })
    .unwrap();
    amg.setup(&a).unwrap();
    assert!(amg.stats().levels.len() >= 3, "{:?}", amg.stats());
    let iterations = pcg_iterations(&a, &amg, &b);
    assert!(
        iterations <= 40,
        "{iterations} iterations, {:?}",
        amg.stats()
    );
    // A refill on the same pattern keeps the hierarchy.
    amg.setup(&a).unwrap();
    assert_eq!((amg.stats().setups, amg.stats().refills), (1, 1));
}

/// 3D linear elasticity (E = 1, nu = 0.3) with trilinear (Q1) hexahedra on
/// an `m^3` grid of the unit cube, the face x = 0 clamped (identity rows
/// and columns); unknowns interleaved `(u_x, u_y, u_z)` per node.
pub(super) fn elasticity_hex(m: usize) -> sprs::CsMat<f64> {
    let (e, nu) = (1.0, 0.3);
    let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    let mu = e / (2.0 * (1.0 + nu));
    let mut d = [[0.0; 6]; 6];
    for r in 0..3 {
        for c in 0..3 {
            d[r][c] = lambda + if r == c { 2.0 * mu } else { 0.0 };
        }
        d[3 + r][3 + r] = mu;
    }
    let h = 1.0 / m as f64;
    let corners: Vec<[f64; 3]> = (0..8)
        .map(|a| {
            let bit = |k: usize| if a >> k & 1 == 1 { 1.0 } else { -1.0 };
            [bit(0), bit(1), bit(2)]
        })
        .collect();
    let g = 1.0 / 3.0_f64.sqrt();
    let mut ke = [[0.0; 24]; 24];
    for q in &corners {
        let p = [g * q[0], g * q[1], g * q[2]];
        let mut bm = [[0.0; 24]; 6];
        for (a, c) in corners.iter().enumerate() {
            let f = |k: usize| 1.0 + p[k] * c[k];
            let dx = c[0] * f(1) * f(2) / 8.0 * 2.0 / h;
            let dy = c[1] * f(0) * f(2) / 8.0 * 2.0 / h;
            let dz = c[2] * f(0) * f(1) / 8.0 * 2.0 / h;
            let col = 3 * a;
            bm[0][col] = dx;
            bm[1][col + 1] = dy;
            bm[2][col + 2] = dz;
            bm[3][col] = dy;
            bm[3][col + 1] = dx;
            bm[4][col + 1] = dz;
            bm[4][col + 2] = dy;
            bm[5][col] = dz;
            bm[5][col + 2] = dx;
        }
        for r in 0..24 {
            for c in 0..24 {
                let mut v = 0.0;
                for s in 0..6 {
                    for t in 0..6 {
                        v += bm[s][r] * d[s][t] * bm[t][c];
                    }
                }
                ke[r][c] += v * h * h * h / 8.0;
            }
        }
    }
    let nodes = m + 1;
    let dim = 3 * nodes * nodes * nodes;
    let elements = (0..m * m * m).map(|e| {
        let (ex, ey, ez) = (e % m, (e / m) % m, e / (m * m));
        (0..8)
            .map(|a| {
                let (x, y, z) = (ex + (a & 1), ey + (a >> 1 & 1), ez + (a >> 2 & 1));
                (z * nodes + y) * nodes + x
            })
            .collect()
    });
    assemble(dim, 3, &ke, elements, |dof| (dof / 3).is_multiple_of(nodes))
}

#[test]
fn three_dof_amg_pcg_on_3d_elasticity_needs_at_most_40_iterations() {
    let a = elasticity_hex(14);
    let n = a.rows();
    let b = rhs(n);
    // The same matrix as 3x3 blocks from CSR and as a SymBlockMatrix: the
    // same hierarchy, the same iterations.
    let mut counts = Vec::new();
    for csr in [true, false] {
        let mut amg = Amg::with_options(AmgOptions {
            block_size: 3,
            ..Default::default()
        })
        .unwrap();
        if csr {
            amg.setup(&a).unwrap();
        } else {
            amg.setup(&SymBlockMatrix::from_csr(&a).unwrap()).unwrap();
        }
        assert!(amg.stats().levels.len() >= 2, "{:?}", amg.stats());
        let iterations = pcg_iterations(&a, &amg, &b);
        counts.push(iterations);
    }
    assert!(counts[0] <= 40, "{counts:?}");
    assert_eq!(counts[0], counts[1]);
}

#[test]
fn a_refill_that_keeps_the_prolongators_recomputes_the_galerkin_operators() {
    let a = spd_block_matrix(16, 14);
    let mut amg = Amg::with_options(AmgOptions {
        keep_prolongators: true,
        ..small_coarse(AmgSmoother::BlockJacobi)
    })
    .unwrap();
    amg.setup(&a).unwrap();
    let p_before = dense_bsr(hierarchy3(&amg).level_matrices(0).1.unwrap().0);
    // New values on the same pattern: more mass on the diagonal.
    let mut a2 = a.clone();
    a2.add_to_diagonal(&vec![0.7; a.dim()]).unwrap();
    amg.setup(&a2).unwrap();
    assert_eq!(amg.stats().refills, 1);
    let h = hierarchy3(&amg);
    let (al, Some((p, _))) = h.level_matrices(0) else {
        unreachable!()
    };
    let p = dense_bsr(p);
    assert_eq!(p, p_before);
    // The coarse operator is P^T A2 P with the kept P.
    let expected = matmul(&transpose_dense(&p), &matmul(&dense_bsr(al), &p));
    assert_eq!(dense_bsr(al), dense(&a2));
    let ac = dense_bsr(h.level_matrices(1).0);
    let scale = expected
        .iter()
        .flatten()
        .fold(0.0_f64, |m, v| m.max(v.abs()));
    for (r, row) in expected.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            approx::assert_abs_diff_eq!(ac[r][c], v, epsilon = 1e-13 * scale);
        }
    }
    // The default refill smooths P again with the new values: it differs.
    let mut fresh = Amg::with_options(small_coarse(AmgSmoother::BlockJacobi)).unwrap();
    fresh.setup(&a).unwrap();
    fresh.setup(&a2).unwrap();
    assert_ne!(
        dense_bsr(hierarchy3(&fresh).level_matrices(0).1.unwrap().0),
        p_before
    );
}

#[test]
fn fused_cg_passes_equal_the_cycle_and_its_sums() {
    // CG's `r -= alpha q`, `z = M^-1 r`, `(r . r, r . z)` fused into the
    // finest passes give the V-cycle and the sums computed separately.
    let a = spd_block_matrix(48, 44);
    let n = a.dim();
    let mut rng = SmallRng::seed_from_u64(25);
    for precision in [AmgPrecision::Double, AmgPrecision::Single] {
        let mut amg = Amg::with_options(AmgOptions {
            precision,
            ..small_coarse(AmgSmoother::BlockJacobi)
        })
        .unwrap();
        amg.setup(&a).unwrap();
        let r0: Vec<f64> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
        let q: Vec<f64> = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
        let alpha = 0.37;
        let mut r = r0.clone();
        let mut z = vec![0.0; n];
        let (rr, rz) = amg.update_and_apply(alpha, &q, &mut r, &mut z);
        let expected_r: Vec<f64> = r0.iter().zip(&q).map(|(r, q)| r - alpha * q).collect();
        let mut expected_z = vec![0.0; n];
        amg.apply(&expected_r, &mut expected_z);
        assert!(super::super::testutil::rel_diff(&r, &expected_r) < 1e-15);
        assert!(super::super::testutil::rel_diff(&z, &expected_z) < 1e-13);
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-12 * y.abs();
        assert!(close(rr, dot(&expected_r, &expected_r)), "{precision:?}");
        assert!(close(rz, dot(&expected_r, &expected_z)), "{precision:?}");
        let mut z2 = vec![0.0; n];
        let rz2 = amg.apply_dot(&expected_r, &mut z2);
        assert!(super::super::testutil::rel_diff(&z2, &expected_z) < 1e-13);
        assert!(close(rz2, rz), "{precision:?}");
    }
}

#[test]
fn single_precision_levels_are_the_galerkin_products_of_the_rounded_matrices() {
    // A_{l+1} = R (A P) with every factor stored in f32: equal to
    // P^T A P of the stored matrices to f32 rounding (relative 1e-6 of the
    // largest entry), and the PCG iteration counts of the double-precision
    // hierarchy within one.
    let a = spd_block_matrix(16, 14);
    let mut single = Amg::with_options(AmgOptions {
        precision: AmgPrecision::Single,
        ..small_coarse(AmgSmoother::BlockJacobi)
    })
    .unwrap();
    single.setup(&a).unwrap();
    assert_galerkin(hierarchy3_single(&single), 1e-6);
    let mut double = Amg::with_options(small_coarse(AmgSmoother::BlockJacobi)).unwrap();
    double.setup(&a).unwrap();
    let b = rhs(a.dim());
    let (its_single, its_double) = (
        pcg_iterations(&a, &single, &b),
        pcg_iterations(&a, &double, &b),
    );
    assert!(
        its_single.abs_diff(its_double) <= 1,
        "{its_single} vs {its_double}"
    );
}

#[test]
fn a_refill_that_keeps_omega_reproduces_the_set_up_in_one_pass() {
    // The default refill (refill_power_iterations = 0) keeps every omega and
    // computes D^-1, D_F^-1 and P in one pass over A's rows: on the values of
    // the set-up it must give the set-up's hierarchy bit for bit (the two-pass
    // path computed each number with the same operations), in both
    // precisions; on 3 A, P stays (D_F^-1 A_F is unchanged) and every
    // operator triples, still the Galerkin products.
    let a = spd_block_matrix(16, 14);
    for precision in [AmgPrecision::Double, AmgPrecision::Single] {
        let options = AmgOptions {
            precision,
            ..small_coarse(AmgSmoother::BlockJacobi)
        };
        assert_eq!(options.refill_power_iterations, 0);
        let mut amg = Amg::with_options(options).unwrap();
        amg.setup(&a).unwrap();
        let before = match precision {
            AmgPrecision::Double => hierarchy3(&amg).dense_levels(),
            AmgPrecision::Single => hierarchy3_single(&amg).dense_levels(),
        };
        assert!(before.len() >= 3, "{} levels", before.len());
        amg.setup(&a).unwrap();
        assert_eq!(amg.stats().refills, 1);
        let after = match precision {
            AmgPrecision::Double => hierarchy3(&amg).dense_levels(),
            AmgPrecision::Single => hierarchy3_single(&amg).dense_levels(),
        };
        assert!(
            before == after,
            "{precision:?}: the refill changed the hierarchy"
        );
    }
    let mut amg = Amg::with_options(small_coarse(AmgSmoother::BlockJacobi)).unwrap();
    amg.setup(&a).unwrap();
    let p_before: Vec<_> = hierarchy3(&amg)
        .dense_levels()
        .into_iter()
        .map(|(_, pt)| pt)
        .collect();
    let mut a3 = a.clone();
    a3.scale(3.0);
    amg.setup(&a3).unwrap();
    let h = hierarchy3(&amg);
    assert_galerkin(h, 1e-13);
    for (p, (_, pt)) in p_before.iter().zip(h.dense_levels()) {
        let (Some((p0, _)), Some((p1, _))) = (p, pt) else {
            continue;
        };
        for (r0, r1) in p0.iter().zip(&p1) {
            for (x, y) in r0.iter().zip(r1) {
                approx::assert_abs_diff_eq!(x, y, epsilon = 1e-12 * (1.0 + x.abs()));
            }
        }
    }
}

#[test]
fn without_weak_blocks_the_prolongator_takes_the_smoothers_spectral_radius() {
    // 3D Poisson: every off-diagonal entry of the finest level is strong
    // (A_F = A, D_F = D), so rho(D_F^-1 A_F) is the smoother's rho(D^-1 A),
    // estimated once: with equal weights (4/3) the two omegas are equal.
    // On a matrix with weak blocks (the jittered block matrix) they are two
    // estimates of two operators and differ.
    let a = poisson(16, 3);
    let mut amg = Amg::with_options(AmgOptions {
        coarse_size: 40,
        ..Default::default()
    })
    .unwrap();
    amg.setup(&a).unwrap();
    // The finest level (the 7-point Laplacian: every neighbour strong; the
    // coarser Galerkin operators have weak blocks).
    let l0 = &amg.stats().levels[0];
    assert_eq!(l0.smoother_weight, l0.prolongation_weight);
    // rho(D^-1 A) of the Laplacian is below 2: omega above 2/3.
    assert!(
        l0.smoother_weight > 4.0 / 3.0 / 2.0,
        "{}",
        l0.smoother_weight
    );
    let b = spd_block_matrix(16, 14);
    let mut amg = Amg::with_options(small_coarse(AmgSmoother::BlockJacobi)).unwrap();
    amg.setup(&b).unwrap();
    let l0 = &amg.stats().levels[0];
    assert_ne!(l0.smoother_weight, l0.prolongation_weight);
}
