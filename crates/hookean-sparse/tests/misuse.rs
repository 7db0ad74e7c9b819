//! API misuse of hookean-sparse (issue 28): what a user can get wrong
//! through the public API returns a typed error, never a panic. Empty
//! systems, wrong lengths, a preconditioner used before its set-up or on
//! another size, non-finite numbers, absurd options and badly scaled
//! right-hand sides.

use std::sync::Arc;

use hookean_sparse::*;

/// A 0 x 0 block matrix and the same as CSR.
fn empty() -> (SymBlockMatrix, sprs::CsMat<f64>) {
    let pattern = Arc::new(BlockPattern::new(0, std::iter::empty()).unwrap());
    let a = SymBlockMatrix::new(pattern);
    let csr = a.to_csr();
    (a, csr)
}

/// A 2-particle SPD block matrix (6 x 6).
fn small() -> SymBlockMatrix {
    let pattern = Arc::new(BlockPattern::new(2, [(0, 1)]).unwrap());
    let mut a = SymBlockMatrix::new(pattern);
    a.add_to_diagonal(&[4.0; 6]).unwrap();
    a.add_to_block(0, 1, &block::scale(&block::IDENTITY, -1.0))
        .unwrap();
    a
}

fn kinds() -> Vec<PrecondKind> {
    let mut k = PrecondKind::all(1.0).to_vec();
    k.push(PrecondKind::Mic0 { omega: 0.99 });
    k
}

/// (`none` has nothing to set up: the solvers refuse the empty system.)
#[test]
fn every_preconditioner_refuses_an_empty_system() {
    let (a, csr) = empty();
    for kind in kinds().into_iter().filter(|k| *k != PrecondKind::None) {
        let mut p = AnyPreconditioner::new(kind).unwrap();
        let r = p.setup(&a);
        assert!(
            matches!(r, Err(SparseError::Empty { .. })),
            "{kind} on 0 x 0 blocks: {r:?}"
        );
        if kind.name() != "mic0" {
            let mut p = AnyPreconditioner::new(kind).unwrap();
            let r = p.setup(&csr);
            assert!(
                matches!(r, Err(SparseError::Empty { .. })),
                "{kind} on 0 x 0 CSR: {r:?}"
            );
        }
    }
}

#[test]
fn pcg_refuses_an_empty_system() {
    let (a, _) = empty();
    let r = pcg(
        &a,
        &Identity,
        &[],
        &mut [],
        &CgParams::default(),
        &mut CgWorkspace::new(0),
        None,
    );
    assert!(matches!(r, Err(SparseError::Empty { .. })), "{r:?}");
}

#[test]
fn wrong_lengths_and_a_preconditioner_of_another_size_are_errors() {
    let a = small();
    let mut p = AnyPreconditioner::new(PrecondKind::Ic0).unwrap();
    // Used before its set-up.
    let mut x = [0.0; 6];
    let r = pcg(
        &a,
        &p,
        &[1.0; 6],
        &mut x,
        &CgParams::default(),
        &mut CgWorkspace::new(6),
        None,
    );
    assert!(r.is_err(), "{r:?}");
    p.setup(&a).unwrap();
    for (b, xl) in [(5, 6), (6, 5), (0, 0)] {
        let b = vec![1.0; b];
        let mut x = vec![0.0; xl];
        let r = pcg(
            &a,
            &p,
            &b,
            &mut x,
            &CgParams::default(),
            &mut CgWorkspace::new(6),
            None,
        );
        assert!(
            matches!(r, Err(SparseError::DimensionMismatch { .. })),
            "{r:?}"
        );
    }
}

#[test]
fn non_finite_inputs_and_options_are_errors() {
    let a = small();
    let mut x = [0.0; 6];
    let mut b = [1.0; 6];
    b[3] = f64::NAN;
    let r = pcg(
        &a,
        &Identity,
        &b,
        &mut x,
        &CgParams::default(),
        &mut CgWorkspace::new(6),
        None,
    );
    assert!(matches!(r, Err(SparseError::NonFinite { .. })), "{r:?}");
    for rtol in [f64::NAN, -1.0, f64::INFINITY] {
        let params = CgParams {
            rtol,
            ..Default::default()
        };
        let r = pcg(
            &a,
            &Identity,
            &[1.0; 6],
            &mut x,
            &params,
            &mut CgWorkspace::new(6),
            None,
        );
        assert!(r.is_err(), "rtol {rtol}: {r:?}");
    }
    let mut bad = small();
    bad.add_to_block(0, 0, &block::scale(&block::IDENTITY, f64::NAN))
        .unwrap();
    for kind in kinds() {
        let mut p = AnyPreconditioner::new(kind).unwrap();
        // Either refused at set-up or the solve refuses the NaN: never a panic.
        if p.setup(&bad).is_ok() {
            let r = pcg(
                &bad,
                &p,
                &[1.0; 6],
                &mut x,
                &CgParams::default(),
                &mut CgWorkspace::new(6),
                None,
            );
            assert!(r.is_err() || !r.unwrap().converged, "{kind}");
        }
    }
    for omega in [0.0, 2.0, f64::NAN] {
        assert!(AnyPreconditioner::new(PrecondKind::Ssor { omega }).is_err());
    }
    for omega in [-0.1, 1.1, f64::NAN] {
        assert!(AnyPreconditioner::new(PrecondKind::Mic0 { omega }).is_err());
    }
}

/// A right-hand side whose squares underflow would read as zero and report
/// convergence at x = 0; one whose squares overflow would stop with NaN.
#[test]
fn a_badly_scaled_right_hand_side_is_refused_not_converged_at_zero() {
    let a = small();
    for scale in [1e-308, 1e-200, 1e200, 1e300] {
        let mut x = [0.0; 6];
        let r = pcg(
            &a,
            &Identity,
            &[scale; 6],
            &mut x,
            &CgParams::default(),
            &mut CgWorkspace::new(6),
            None,
        );
        assert!(
            matches!(r, Err(SparseError::BadlyScaled { .. })),
            "b = {scale:e}: {r:?}"
        );
    }
    // The edges of the accepted scale solve.
    for scale in [1e-150, 1e150] {
        let mut x = [0.0; 6];
        let info = pcg(
            &a,
            &Identity,
            &[scale; 6],
            &mut x,
            &CgParams::default(),
            &mut CgWorkspace::new(6),
            None,
        )
        .unwrap();
        assert!(info.converged && x[0] > 0.0, "b = {scale:e}");
    }
}

#[test]
fn block_construction_refuses_out_of_range_pairs_and_blocks() {
    assert!(BlockPattern::new(2, [(0, 2)]).is_err());
    assert!(BlockPattern::new(2, [(usize::MAX, 0)]).is_err());
    let mut a = small();
    assert!(a.add_to_block(0, 5, &block::IDENTITY).is_err());
    assert!(a.add_to_diagonal(&[1.0; 5]).is_err());
}

/// The counts a user sets have upper ends (a billion sweeps or power steps
/// would never end, a huge coarse level is a dense factor of its square):
/// each is refused by name at the end past the library's range, and the
/// range's own end is accepted.
#[test]
fn amg_counts_past_their_ranges_are_refused_by_name() {
    use hookean_sparse::{AMG_MAX_COARSE_SIZE, AMG_MAX_LEVELS, AMG_MAX_SWEEPS, SparseError};
    type WithCount = fn(usize) -> AmgOptions;
    let cases: [(&str, WithCount, usize); 5] = [
        (
            "sweeps",
            |v| AmgOptions {
                sweeps: v,
                ..Default::default()
            },
            AMG_MAX_SWEEPS,
        ),
        (
            "coarse_size",
            |v| AmgOptions {
                coarse_size: v,
                ..Default::default()
            },
            AMG_MAX_COARSE_SIZE,
        ),
        (
            "max_levels",
            |v| AmgOptions {
                max_levels: v,
                ..Default::default()
            },
            AMG_MAX_LEVELS,
        ),
        (
            "power_iterations",
            |v| AmgOptions {
                power_iterations: v,
                ..Default::default()
            },
            AMG_MAX_SWEEPS,
        ),
        (
            "refill_power_iterations",
            |v| AmgOptions {
                refill_power_iterations: v,
                ..Default::default()
            },
            AMG_MAX_SWEEPS,
        ),
    ];
    for (name, options, max) in cases {
        assert!(Amg::with_options(options(max)).is_ok(), "{name} = {max}");
        match Amg::with_options(options(max + 1)) {
            Err(SparseError::InvalidParameter { name: n, .. }) => assert_eq!(n, name),
            other => panic!("{name} = {}: {other:?}", max + 1),
        }
    }
}

#[test]
fn amg_options_out_of_range_are_errors() {
    let a = small();
    for opts in [
        AmgOptions {
            block_size: 0,
            ..Default::default()
        },
        AmgOptions {
            block_size: 4,
            ..Default::default()
        },
        AmgOptions {
            sweeps: 0,
            ..Default::default()
        },
        AmgOptions {
            strength_threshold: f64::NAN,
            ..Default::default()
        },
    ] {
        let mut p = match Amg::with_options(opts.clone()) {
            Ok(p) => p,
            Err(_) => continue,
        };
        assert!(p.setup(&a).is_err(), "accepted {opts:?} (or a panic above)");
    }
}

/// A symmetric matrix handed over as its upper (or lower) half: the
/// symmetric preconditioners refuse it naming the stored triangle, where
/// before IC(0) factored only the diagonal and SSOR smoothed a triangular
/// matrix. Jacobi reads the diagonal only and accepts it; both triangles
/// pass everywhere.
#[test]
fn symmetric_preconditioners_refuse_a_matrix_stored_as_one_triangle() {
    let full = small().to_csr();
    let upper = {
        let mut t = sprs::TriMat::new((6, 6));
        for (&v, (r, c)) in full.iter() {
            if c >= r {
                t.add_triplet(r, c, v);
            }
        }
        t.to_csr::<usize>()
    };
    let lower = upper.transpose_view().to_csr();
    for kind in [
        PrecondKind::Ssor { omega: 1.0 },
        PrecondKind::Ic0,
        PrecondKind::Amg,
    ] {
        for (m, stored) in [(&upper, "upper"), (&lower, "lower")] {
            let mut p = AnyPreconditioner::new(kind).unwrap();
            match p.setup(m) {
                Err(SparseError::OneTriangle {
                    stored: s,
                    preconditioner,
                }) => {
                    assert_eq!(s, stored, "{kind}");
                    let msg = SparseError::OneTriangle {
                        stored: s,
                        preconditioner,
                    }
                    .to_string();
                    assert!(
                        msg.contains(stored) && msg.contains("both triangles"),
                        "{msg}"
                    );
                }
                other => panic!("{kind} on the {stored} triangle: {other:?}"),
            }
        }
        let mut p = AnyPreconditioner::new(kind).unwrap();
        p.setup(&full)
            .unwrap_or_else(|e| panic!("{kind} on both triangles: {e}"));
    }
    let mut jacobi = Jacobi::new();
    jacobi.setup(&upper).unwrap();
}

/// The machine's memory and swap in bytes (Linux; `None` elsewhere).
fn memory_bytes() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let kib = |key: &str| -> Option<u64> {
        let line = info.lines().find(|l| l.starts_with(key))?;
        line.split_whitespace().nth(1)?.parse().ok()
    };
    Some((kib("MemTotal:")? + kib("SwapTotal:").unwrap_or(0)) * 1024)
}

#[test]
fn constructors_refuse_sizes_that_cannot_be_allocated_with_a_typed_error() {
    let too_large = |r: Result<(), SparseError>, what: &str| match r {
        Err(SparseError::TooLarge { .. }) => {}
        other => panic!("{what}: expected TooLarge, got {other:?}"),
    };
    // Sizes whose byte counts overflow usize: "capacity overflow" before.
    too_large(
        CgWorkspace::try_new(usize::MAX / 8).map(drop),
        "CgWorkspace",
    );
    too_large(
        GmresWorkspace::try_new(usize::MAX / 2, 10).map(drop),
        "GmresWorkspace",
    );
    too_large(
        GmresWorkspace::try_new(10, usize::MAX / 4).map(drop),
        "GmresWorkspace (Krylov dimension)",
    );
    too_large(
        Constraints::try_new(usize::MAX / 4).map(drop),
        "Constraints",
    );
    // And solvers handed such a size through a workspace: no panic.
    let e = CgWorkspace::try_new(usize::MAX / 8).unwrap_err();
    assert!(e.to_string().starts_with("CG workspace of "), "{e}");
    // The largest pattern the documented check lets through, u32::MAX
    // block rows: 34 GB of row pointers, which the allocator refuses on a
    // machine with less memory (on a larger one it would succeed, and
    // this test would fill 50 GB: it then checks nothing).
    match memory_bytes() {
        Some(m) if m < 40 << 30 => too_large(
            BlockPattern::new(u32::MAX as usize, std::iter::empty()).map(drop),
            "BlockPattern",
        ),
        m => eprintln!("skipped BlockPattern::new(u32::MAX): {m:?} bytes of memory"),
    }
}
