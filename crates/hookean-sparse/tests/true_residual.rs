//! "Converged" means the true residual: on an ill-conditioned
//! jump-coefficient diffusion system (coefficients 1 and 1e4), where CG's
//! recursively updated residual drifts from `b - A x`, no solve with any
//! preconditioner reports convergence with a true relative residual above
//! its tolerance (checked here by an independent product in CSR storage).

use hookean_sparse::{
    AnyPreconditioner, CgParams, CgWorkspace, Constraints, GmresParams, GmresWorkspace,
    LinearOperator, PrecondKind, PreconditionerSetup, SymBlockMatrix, filtered_pcg, gmres, pcg,
    vecops::norm2,
};
use hookean_testkit::diffusion::jump_diffusion;

/// `|b - A x| / |b|` by a plain loop over the CSR rows (not the solver's kernels).
fn true_relative_residual(a: &sprs::CsMat<f64>, x: &[f64], b: &[f64]) -> f64 {
    let r: Vec<f64> = a
        .outer_iterator()
        .zip(b)
        .map(|(row, bi)| bi - row.iter().map(|(j, v)| v * x[j]).sum::<f64>())
        .collect();
    norm2(&r) / norm2(b)
}

/// The preconditioners of the issue: Jacobi, block Jacobi, SSOR, IC(0),
/// MIC(0) (it takes block storage) and the multigrid.
fn kinds() -> Vec<PrecondKind> {
    let mut k = PrecondKind::all(1.2)[1..].to_vec();
    k.push(PrecondKind::Mic0 {
        omega: PrecondKind::MIC_OMEGA,
    });
    k
}

/// 72 x 72 nodes: 5184 unknowns (a multiple of 3, for the block storage),
/// condition number about 1e4 * 72^2 / 10 = 5e6. Its attainable accuracy
/// (about `eps |A| |x| / |b|`) lies near 1e-9: at the tolerances below,
/// CG's recursive residual falls below the tolerance while the true one
/// is up to 15 times above it.
const N: usize = 72;

/// The tolerances tried: from above the attainable accuracy (where every
/// solve must converge) to below it (where none can).
const RTOLS: [f64; 6] = [1e-8, 5e-9, 2e-9, 1e-9, 5e-10, 1e-10];

/// The two products (the solver's block kernel and the CSR loop above)
/// round differently by about `eps |A| |x|`: at these residuals, up to 8%
/// of the residual. The solver's own true residual must meet the
/// tolerance exactly; the independent one within this margin.
const PRODUCT_MARGIN: f64 = 1.1;

#[test]
fn no_pcg_solve_reports_converged_above_its_tolerance_on_a_jump_coefficient_system() {
    let (a, b) = jump_diffusion(N, 1e4);
    let block = SymBlockMatrix::from_csr(&a).unwrap();
    let mut ws = CgWorkspace::new(b.len());
    let mut restarted = 0;
    for kind in kinds() {
        for rtol in RTOLS {
            let mut p = AnyPreconditioner::new(kind).unwrap();
            p.setup(&block).unwrap();
            let mut x = vec![0.0; b.len()];
            let params = CgParams {
                rtol,
                max_iter: Some(b.len()),
                ..Default::default()
            };
            let info = pcg(&block, &p, &b, &mut x, &params, &mut ws, None).unwrap();
            let truth = true_relative_residual(&a, &x, &b);
            // The reported true residual is the true one (to the rounding
            // of the product itself).
            assert!(
                (info.true_relative_residual - truth).abs() <= (PRODUCT_MARGIN - 1.0) * truth,
                "{kind} rtol {rtol:e}: reported {:e}, true {truth:e}",
                info.true_relative_residual
            );
            if info.converged {
                assert!(
                    info.true_relative_residual <= rtol && truth <= PRODUCT_MARGIN * rtol,
                    "{kind} rtol {rtol:e}: converged with |b - A x| / |b| = {truth:e} \
                     (recursive {:e})",
                    info.relative_residual
                );
            }
            // Above the attainable accuracy every solve converges; far
            // below it none does (and none runs to the iteration limit:
            // a restart that gains nothing ends the solve).
            if rtol >= 2e-9 {
                assert!(info.converged, "{kind} rtol {rtol:e}: {truth:e}");
            }
            if rtol <= 1e-10 {
                assert!(!info.converged && info.iterations < b.len() / 10, "{kind}");
            }
            restarted += usize::from(info.restarts > 0);
        }
    }
    // A test of something: the recursive residual did drift.
    assert!(
        restarted >= kinds().len(),
        "only {restarted} solves drifted"
    );
}

#[test]
fn filtered_pcg_checks_the_true_filtered_residual() {
    let (a, b) = jump_diffusion(N, 1e4);
    let block = SymBlockMatrix::from_csr(&a).unwrap();
    // Pin a few "particles" (blocks of three unknowns) to zero: the
    // filtered system is the free part of A.
    let mut c = Constraints::new(b.len() / 3);
    for p in (0..b.len() / 3).step_by(17) {
        c.pin(p, [0.0; 3]).unwrap();
    }
    let mut ws = CgWorkspace::new(b.len());
    for kind in kinds() {
        for rtol in RTOLS {
            let mut p = AnyPreconditioner::new(kind).unwrap();
            p.setup(&block).unwrap();
            let mut x = vec![0.0; b.len()];
            let params = CgParams {
                rtol,
                max_iter: Some(b.len()),
                ..Default::default()
            };
            let info = filtered_pcg(&block, &p, &b, &mut x, &c, &params, &mut ws, None).unwrap();
            // P (b - A x) and P b, with P zeroing the pinned blocks.
            let mut ax = vec![0.0; b.len()];
            block.apply(&x, &mut ax);
            let mut r: Vec<f64> = ax.iter().zip(&b).map(|(p, q)| q - p).collect();
            let mut pb = b.clone();
            c.project(&mut r);
            c.project(&mut pb);
            let truth = norm2(&r) / norm2(&pb);
            if info.converged {
                assert!(
                    info.true_relative_residual <= rtol && truth <= PRODUCT_MARGIN * rtol,
                    "{kind} rtol {rtol:e}: {truth:e}"
                );
            }
        }
    }
}

#[test]
fn no_gmres_solve_reports_converged_above_its_tolerance() {
    // Half the grid (GMRES(30) is slower), attainable accuracy near 3e-10.
    let (a, b) = jump_diffusion(N / 2, 1e4);
    let mut converged = 0;
    for kind in PrecondKind::all(1.2)[1..].iter().copied() {
        let mut p = AnyPreconditioner::new(kind).unwrap();
        p.setup(&a).unwrap();
        for rtol in [1e-8, 1e-9, 3e-10, 1e-10] {
            let params = GmresParams {
                krylov_dim: 30,
                restarts: 200,
                rtol,
                ..Default::default()
            };
            let mut x = vec![0.0; b.len()];
            let mut ws = GmresWorkspace::new(b.len(), 30);
            let info = gmres(&a, &p, &b, &mut x, &params, &mut ws).unwrap();
            let truth = true_relative_residual(&a, &x, &b);
            assert!(
                (info.relative_residual - truth).abs() <= (PRODUCT_MARGIN - 1.0) * truth,
                "{kind} rtol {rtol:e}: reported {:e}, true {truth:e}",
                info.relative_residual
            );
            if info.converged {
                converged += 1;
                assert!(
                    truth <= PRODUCT_MARGIN * rtol,
                    "{kind} rtol {rtol:e}: {truth:e}"
                );
            }
        }
    }
    assert!(converged > 0);
}
