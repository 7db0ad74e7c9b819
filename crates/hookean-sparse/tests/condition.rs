//! PCG's condition estimate (the Lanczos matrix of its coefficients)
//! against the exact extreme eigenvalues of `M^-1 A` from a dense
//! eigensolver: with `S = M^-1` formed column by column from the
//! preconditioner and `S = G G^T` (Cholesky), `M^-1 A = G G^T A` is
//! similar to the symmetric `G^T A G`, whose eigenvalues faer computes.
//! This needs `M^-1` symmetric (and positive definite): checked for each
//! preconditioner, the multigrid's V-cycle included.

use faer::{Mat, Side};
use hookean_sparse::{
    AnyPreconditioner, CgParams, CgWorkspace, LinearOperator, PrecondKind, Preconditioner,
    PreconditionerSetup, SymBlockMatrix, pcg, read_matrix_market_file, sprs,
};

/// The 5-point Laplacian of an `m x m` grid plus a small shift (SPD).
fn poisson_2d(m: usize) -> sprs::CsMat<f64> {
    let n = m * m;
    let mut t = sprs::TriMat::new((n, n));
    for y in 0..m {
        for x in 0..m {
            let i = y * m + x;
            t.add_triplet(i, i, 4.0 + 1e-3);
            if x + 1 < m {
                t.add_triplet(i, i + 1, -1.0);
                t.add_triplet(i + 1, i, -1.0);
            }
            if y + 1 < m {
                t.add_triplet(i, i + m, -1.0);
                t.add_triplet(i + m, i, -1.0);
            }
        }
    }
    t.to_csr()
}

/// A deterministic right-hand side with every eigencomponent present.
fn rhs(n: usize) -> Vec<f64> {
    let mut s = 0x9e37_79b9_7f4a_7c15_u64;
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect()
}

/// The dense matrix of a linear map `x -> y`, column by column.
fn dense_of(n: usize, apply: impl Fn(&[f64], &mut [f64])) -> Mat<f64> {
    let mut m = Mat::<f64>::zeros(n, n);
    let (mut e, mut y) = (vec![0.0; n], vec![0.0; n]);
    for j in 0..n {
        e[j] = 1.0;
        apply(&e, &mut y);
        e[j] = 0.0;
        for i in 0..n {
            m[(i, j)] = y[i];
        }
    }
    m
}

/// The exact extreme eigenvalues of `M^-1 A`, after checking that `M^-1`
/// is symmetric.
fn exact_extremes(
    a: &dyn LinearOperator,
    p: &dyn Preconditioner,
    n: usize,
    what: &str,
) -> (f64, f64) {
    let a = dense_of(n, |x, y| a.apply(x, y));
    let mut s = dense_of(n, |r, z| p.apply(r, z));
    let (mut asym, mut size) = (0.0_f64, 0.0_f64);
    for i in 0..n {
        for j in 0..n {
            asym = asym.max((s[(i, j)] - s[(j, i)]).abs());
            size = size.max(s[(i, j)].abs());
        }
    }
    assert!(
        asym <= 1e-10 * size,
        "{what}: M^-1 is not symmetric ({asym:e} of {size:e})"
    );
    for i in 0..n {
        for j in 0..i {
            let v = 0.5 * (s[(i, j)] + s[(j, i)]);
            s[(i, j)] = v;
            s[(j, i)] = v;
        }
    }
    let llt = s
        .llt(Side::Lower)
        .unwrap_or_else(|_| panic!("{what}: M^-1 is not positive definite"));
    let g = llt.L();
    let c = g.transpose() * &a * g;
    let eig = c.self_adjoint_eigenvalues(Side::Lower).unwrap();
    (eig[0], eig[n - 1])
}

fn check(a: &dyn LinearOperator, p: &AnyPreconditioner, n: usize, what: &str) {
    let b = rhs(n);
    let mut x = vec![0.0; n];
    let params = CgParams {
        rtol: 1e-12,
        estimate_condition: true,
        ..Default::default()
    };
    let mut ws = CgWorkspace::new(n);
    let mut info = pcg(a, p, &b, &mut x, &params, &mut ws, None).unwrap();
    assert!(info.converged, "{what}");
    if info.iterations < 30 {
        // A fast preconditioner (the multigrid): 30 iterations regardless,
        // past the tolerance (rtol 0 stops only at the limit).
        let params = CgParams {
            rtol: 0.0,
            max_iter: Some(30),
            ..params
        };
        info = pcg(a, p, &b, &mut x, &params, &mut ws, None).unwrap();
    }
    assert!(
        info.iterations >= 30,
        "{what}: only {} iterations",
        info.iterations
    );
    let est = info.condition.expect("estimate requested");
    let (lo, hi) = exact_extremes(a, p, n, what);
    eprintln!(
        "{what}: n {n}, {} iterations; lambda_min {:.4e} (exact {lo:.4e}), lambda_max {:.4e} (exact {hi:.4e})",
        info.iterations, est.lambda_min, est.lambda_max
    );
    assert!(
        (est.lambda_max - hi).abs() <= 0.05 * hi,
        "{what}: largest {} vs {hi}",
        est.lambda_max
    );
    assert!(
        est.lambda_min >= 0.5 * lo && est.lambda_min <= 2.0 * lo,
        "{what}: smallest {} vs {lo}",
        est.lambda_min
    );
    approx::assert_relative_eq!(est.condition, est.lambda_max / est.lambda_min);
}

const KINDS: [PrecondKind; 3] = [PrecondKind::Jacobi, PrecondKind::Ic0, PrecondKind::Amg];

#[test]
fn the_estimate_matches_the_dense_spectrum_on_a_scalar_poisson_system() {
    let a = poisson_2d(40);
    for kind in KINDS {
        let mut p = AnyPreconditioner::new(kind).unwrap();
        p.setup(&a).unwrap();
        check(&a, &p, a.rows(), &format!("poisson 40x40, {kind}"));
    }
}

#[test]
fn the_estimate_matches_the_dense_spectrum_on_the_shipped_cloth_system() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/cloth16-A.mtx");
    let a = SymBlockMatrix::from_csr(&read_matrix_market_file(path).unwrap().into_csr()).unwrap();
    for kind in KINDS {
        let mut p = AnyPreconditioner::new(kind).unwrap();
        p.setup(&a).unwrap();
        check(&a, &p, a.dim(), &format!("cloth16, {kind}"));
    }
}

#[test]
fn the_estimate_is_absent_unless_asked_for() {
    let a = poisson_2d(6);
    let p = AnyPreconditioner::new(PrecondKind::None).unwrap();
    let b = rhs(36);
    let mut x = vec![0.0; 36];
    let info = pcg(
        &a,
        &p,
        &b,
        &mut x,
        &CgParams::default(),
        &mut CgWorkspace::new(36),
        None,
    )
    .unwrap();
    assert!(info.condition.is_none());
}
