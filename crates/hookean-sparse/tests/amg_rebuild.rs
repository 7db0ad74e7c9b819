//! A checkpointed run restores its multigrid by rebuilding it from the
//! matrix of its last full set-up ([`Amg::built_from`]): with the default
//! refill, the aggregates, tentative prolongators and spectral estimates
//! are functions of that matrix alone, so rebuild-then-refill gives the
//! same V-cycle, bit for bit, as the hierarchy that was refilled all along;
//! and a hierarchy built from the later matrix instead gives another one
//! (the refill really reuses the build, so the rebuild is needed). With
//! `reuse = "keep"` [`Amg::restore`] from the build matrix, the last
//! refill's ([`Amg::refilled_from`]) and the count of kept set-ups
//! ([`Amg::kept_in_a_row`]) continues the same sequence of kept and
//! refilled hierarchies.

use std::sync::Arc;

use hookean_sparse::{
    Amg, AmgOptions, AmgReuse, BlockPattern, Preconditioner, PreconditionerSetup, SymBlockMatrix,
    block,
};

/// A 60 x 60 grid of particles joined to their right and upper neighbours
/// by springs of stiffness `k(i)` along the spring's direction, plus mass
/// `m` on the diagonal: an SPD block matrix whose values depend on `phase`.
fn grid(pattern: &Arc<BlockPattern>, side: usize, phase: f64) -> SymBlockMatrix {
    let mut a = SymBlockMatrix::new(pattern.clone());
    let idx = |i: usize, j: usize| i * side + j;
    let mut spring = |p: usize, q: usize, dir: [f64; 3], k: f64| {
        let mut b = [[0.0; 3]; 3];
        for r in 0..3 {
            for c in 0..3 {
                b[r][c] = k * dir[r] * dir[c] + 0.1 * k * f64::from(u8::from(r == c));
            }
        }
        a.add_to_block(p, p, &b).unwrap();
        a.add_to_block(q, q, &b).unwrap();
        a.add_to_block(p.min(q), p.max(q), &block::scale(&b, -1.0))
            .unwrap();
    };
    for i in 0..side {
        for j in 0..side {
            let k = 1.0 + 0.5 * ((i * 7 + j * 3) as f64 + phase).sin();
            if j + 1 < side {
                spring(idx(i, j), idx(i, j + 1), [1.0, 0.0, 0.0], k);
            }
            if i + 1 < side {
                let s = 0.6 + 0.3 * phase.cos();
                spring(idx(i, j), idx(i + 1, j), [0.0, s, (1.0 - s * s).sqrt()], k);
            }
        }
    }
    a.add_to_diagonal(&vec![1e-3; 3 * side * side]).unwrap();
    a
}

/// The pattern of the 60 x 60 grid of [`grid`].
fn grid_pattern(side: usize) -> Arc<BlockPattern> {
    let mut edges = Vec::new();
    for i in 0..side {
        for j in 0..side {
            if j + 1 < side {
                edges.push((i * side + j, i * side + j + 1));
            }
            if i + 1 < side {
                edges.push((i * side + j, (i + 1) * side + j));
            }
        }
    }
    Arc::new(BlockPattern::new(side * side, edges).unwrap())
}

/// One V-cycle of `amg` on a fixed right-hand side of `n` unknowns.
fn cycle(amg: &Amg, n: usize) -> Vec<f64> {
    let r: Vec<f64> = (0..n)
        .map(|i| ((i * 37 % 101) as f64 - 50.0) / 50.0)
        .collect();
    let mut z = vec![0.0; n];
    amg.apply(&r, &mut z);
    z
}

#[test]
fn a_kept_hierarchy_restored_from_its_build_and_refill_matrices_continues_alike() {
    let side = 60;
    let pattern = grid_pattern(side);
    let a: Vec<SymBlockMatrix> = (0..8)
        .map(|k| grid(&pattern, side, 0.7 * k as f64))
        .collect();
    let options = AmgOptions {
        reuse: AmgReuse::Keep { updates: 2 },
        ..AmgOptions::default()
    };
    let n = 3 * side * side;
    // The run: built from a0, a1 and a2 kept, refilled with a3, a4 kept.
    let mut run = Amg::with_options(options.clone()).unwrap();
    for m in &a[..5] {
        run.setup(m).unwrap();
    }
    assert_eq!((run.stats().setups, run.stats().refills), (1, 1));
    assert_eq!(run.kept_in_a_row(), 1);
    assert!(run.last_setup_refilled());
    let built = run.built_from().unwrap().clone();
    let refilled = run.refilled_from().unwrap().clone();
    assert_eq!(built.values(), a[0].values());
    assert_eq!(refilled.values(), a[3].values());

    let mut resumed = Amg::with_options(options.clone()).unwrap();
    resumed.restore(&built, Some(&refilled), 1).unwrap();
    assert!(
        cycle(&run, n) == cycle(&resumed, n),
        "the restored hierarchy"
    );
    // A forgotten count keeps a5 and a6 instead of refilling with a6.
    let mut miscounted = Amg::with_options(options).unwrap();
    miscounted.restore(&built, Some(&refilled), 0).unwrap();
    // a5 kept (the count reaches 2), a6 refilled, a7 kept.
    for m in &a[5..] {
        run.setup(m).unwrap();
        resumed.setup(m).unwrap();
        miscounted.setup(m).unwrap();
        assert!(cycle(&run, n) == cycle(&resumed, n), "bit for bit");
    }
    assert_eq!(run.stats().refills, 2);
    assert!(cycle(&run, n) != cycle(&miscounted, n), "the count matters");
}

#[test]
fn rebuilding_from_the_build_matrix_then_refilling_gives_the_same_v_cycle() {
    let side = 60;
    let n = side * side;
    let mut edges = Vec::new();
    for i in 0..side {
        for j in 0..side {
            if j + 1 < side {
                edges.push((i * side + j, i * side + j + 1));
            }
            if i + 1 < side {
                edges.push((i * side + j, (i + 1) * side + j));
            }
        }
    }
    let pattern = Arc::new(BlockPattern::new(n, edges).unwrap());
    let (a0, a1, a2) = (
        grid(&pattern, side, 0.0),
        grid(&pattern, side, 1.3),
        grid(&pattern, side, 2.1),
    );
    let r: Vec<f64> = (0..3 * n)
        .map(|i| ((i * 37 % 101) as f64 - 50.0) / 50.0)
        .collect();
    let cycle = |amg: &Amg| {
        let mut z = vec![0.0; 3 * n];
        amg.apply(&r, &mut z);
        z
    };

    // The run: built from a0, refilled with a1 and then a2.
    let mut run = Amg::new();
    run.setup(&a0).unwrap();
    assert!(run.stats().levels.len() > 2, "a real hierarchy");
    run.setup(&a1).unwrap();
    let saved = run.built_from().expect("the build matrix is kept").clone();
    assert_eq!(saved.values(), a0.values());
    run.setup(&a2).unwrap();

    // The resumed run: rebuilt from the saved matrix, then refilled with a2.
    let mut resumed = Amg::new();
    resumed.rebuild(&saved).unwrap();
    resumed.setup(&a2).unwrap();
    assert_eq!(run.stats().refills, 2);
    assert!(cycle(&run) == cycle(&resumed), "bit for bit");

    // Built from a2 instead, the V-cycle differs: the refill kept a0's parts.
    let mut fresh = Amg::new();
    fresh.setup(&a2).unwrap();
    assert!(cycle(&fresh) != cycle(&run));
}
