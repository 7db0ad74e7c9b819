use super::*;

/// Row ranges and bandwidth against the input pairs: row `r` holds its
/// diagonal plus the distinct `j > r` paired with it, and the bandwidth
/// is the largest `|i - j|` of a pair.
#[test]
fn row_ranges_and_bandwidth_match_the_pairs() {
    let pairs = [(0, 3), (1, 2), (4, 1), (2, 2), (3, 0), (5, 4)];
    let n = 6;
    let p = BlockPattern::new(n, pairs).unwrap();
    let mut end = 0;
    for r in 0..n {
        let mut upper: Vec<usize> = pairs
            .iter()
            .filter(|&&(i, j)| i.min(j) == r && i != j)
            .map(|&(i, j)| i.max(j))
            .collect();
        upper.sort_unstable();
        upper.dedup();
        let range = p.rows_value_range(r..r + 1);
        assert_eq!(
            range.start,
            end,
            "row {r} starts where row {} ends",
            r.max(1) - 1
        );
        assert_eq!(range.len(), 1 + upper.len(), "row {r}");
        for j in std::iter::once(r).chain(upper) {
            assert!(range.contains(&p.find(r, j).unwrap().index()), "({r}, {j})");
        }
        end = range.end;
    }
    assert_eq!(p.rows_value_range(0..n), 0..p.stored_blocks());
    assert_eq!(p.rows_value_range(2..5), p.row_ptr()[2]..p.row_ptr()[5]);
    let widest = pairs.iter().map(|&(i, j)| i.abs_diff(j)).max().unwrap();
    assert_eq!(p.bandwidth(), widest);
    assert_eq!(BlockPattern::new(4, []).unwrap().bandwidth(), 0);
    assert_eq!(BlockPattern::new(0, []).unwrap().bandwidth(), 0);
}

fn chain(n: usize) -> SymBlockMatrix {
    let pattern = Arc::new(BlockPattern::new(n, (1..n).map(|i| (i - 1, i))).unwrap());
    let mut a = SymBlockMatrix::new(pattern);
    for i in 0..n {
        let d = [
            [4.0 + i as f64, 0.5, 0.0],
            [0.5, 5.0, 0.25],
            [0.0, 0.25, 6.0],
        ];
        a.add_to_block(i, i, &d).unwrap();
        if i > 0 {
            let b = [[-1.0, 0.2, 0.0], [0.1, -1.0, 0.3], [0.0, 0.0, -0.5]];
            a.add_to_block(i, i - 1, &b).unwrap();
        }
    }
    a
}

fn dense(a: &SymBlockMatrix) -> Vec<Vec<f64>> {
    let n = a.n_blocks();
    let mut d = vec![vec![0.0; 3 * n]; 3 * n];
    for i in 0..n {
        for j in 0..n {
            let b = a.block(i, j).unwrap();
            for r in 0..3 {
                for c in 0..3 {
                    d[3 * i + r][3 * j + c] = b[r][c];
                }
            }
        }
    }
    d
}

#[test]
fn pattern_dedups_and_orients_pairs() {
    let p = BlockPattern::new(4, [(2, 1), (1, 2), (0, 3), (3, 3)]).unwrap();
    assert_eq!(p.row_ptr(), &[0, 2, 4, 5, 6]);
    assert_eq!(p.col_idx(), &[0, 3, 1, 2, 2, 3]);
    assert_eq!(p.full_nnz(), 9 * (2 * 6 - 4));
    assert!(p.find(1, 3).is_none());
    assert!(p.find(2, 1).unwrap().transposed);
}

#[test]
fn out_of_range_pair_is_an_error() {
    assert_eq!(
        BlockPattern::new(3, [(0, 3)]),
        Err(SparseError::BlockIndexOutOfRange {
            row: 0,
            col: 3,
            n: 3
        })
    );
}

#[test]
fn writing_outside_the_pattern_is_an_error() {
    let mut a = chain(3);
    assert_eq!(
        a.add_to_block(0, 2, &block::IDENTITY),
        Err(SparseError::NotInPattern { row: 0, col: 2 })
    );
}

#[test]
fn lower_block_is_stored_transposed() {
    let a = chain(3);
    let upper = a.block(0, 1).unwrap();
    let lower = a.block(1, 0).unwrap();
    assert_eq!(
        lower,
        [[-1.0, 0.2, 0.0], [0.1, -1.0, 0.3], [0.0, 0.0, -0.5]]
    );
    assert_eq!(upper, block::transpose(&lower));
}

#[test]
fn spmv_matches_dense_product() {
    let a = chain(5);
    let d = dense(&a);
    let x: Vec<f64> = (0..15).map(|i| (i as f64 * 0.7).sin()).collect();
    let mut y = vec![0.0; 15];
    a.mul_vec(&x, &mut y).unwrap();
    for r in 0..15 {
        let expected: f64 = (0..15).map(|c| d[r][c] * x[c]).sum();
        approx::assert_abs_diff_eq!(y[r], expected, epsilon = 1e-13);
    }
}

/// A banded matrix big enough for the threaded kernels: block `i`
/// coupled to `i + 1` and `i + w` (a cloth-like bandwidth `w`).
fn banded(n: usize, w: usize) -> SymBlockMatrix {
    let pairs = (0..n)
        .flat_map(|i| [(i, i + 1), (i, i + w)])
        .filter(|&(_, j)| j < n);
    let pattern = Arc::new(BlockPattern::new(n, pairs).unwrap());
    let mut a = SymBlockMatrix::new(pattern.clone());
    for (k, b) in a.values_mut().iter_mut().enumerate() {
        for r in 0..3 {
            for c in 0..3 {
                b[r][c] = ((k * 31 + r * 7 + c * 3) % 17) as f64 / 17.0 - 0.5;
            }
        }
    }
    for i in 0..n {
        let d = &mut a.values_mut()[pattern.row_ptr()[i]];
        *d = block::add(d, &block::transpose(d));
        for c in 0..3 {
            d[c][c] += 8.0;
        }
    }
    a
}

#[test]
fn threaded_spmv_gives_the_serial_bits() {
    // The parts gather the contributions of earlier rows in the serial
    // order, so y is bitwise the serial product for every split; the
    // dot product differs by its summation order only.
    let n = 3 * crate::par::MIN_PARALLEL_BLOCKS + 11;
    let a = banded(n, 67);
    let x: Vec<f64> = (0..3 * n).map(|i| (i as f64 * 0.37).sin()).collect();
    let mut y1 = vec![f64::NAN; 3 * n];
    let d1 = crate::par::in_pool(1, || a.spmv_dot(&x, &mut y1));
    let mut expected = vec![0.0; 3 * n];
    a.spmv_dot_serial(&x, &mut expected);
    assert_eq!(y1, expected);
    for threads in [2, 3, 4] {
        let mut y = vec![f64::NAN; 3 * n];
        let d = crate::par::in_pool(threads, || a.spmv_dot(&x, &mut y));
        assert_eq!(y, expected, "{threads} threads");
        approx::assert_relative_eq!(d, d1, max_relative = 1e-12);
        let mut again = vec![0.0; 3 * n];
        assert_eq!(
            crate::par::in_pool(threads, || a.spmv_dot(&x, &mut again)).to_bits(),
            d.to_bits()
        );
    }
    // The fused CG update on two threads: the serial bits for x, p, q.
    let z: Vec<f64> = (0..3 * n).map(|i| (i as f64 * 0.11).cos()).collect();
    let run = |threads: usize| {
        let (mut xs, mut p, mut q) = (x.clone(), z.clone(), vec![0.0; 3 * n]);
        p.reverse();
        crate::par::in_pool(threads, || {
            a.update_spmv_dot(&z, 0.3, 0.7, &mut xs, &mut p, &mut q)
        });
        (xs, p, q)
    };
    assert_eq!(run(1), run(2));
}

#[test]
fn fused_direction_update_and_product_match_the_separate_steps() {
    let a = chain(6);
    let z: Vec<f64> = (0..18).map(|i| (i as f64 * 0.3).cos()).collect();
    let p0: Vec<f64> = (0..18).map(|i| (i as f64 * 0.9).sin()).collect();
    let beta = 0.37;
    let mut p = p0.clone();
    let mut q = vec![f64::NAN; 18];
    let x0: Vec<f64> = (0..18).map(|i| i as f64 * 0.1).collect();
    let mut x = x0.clone();
    let alpha = 0.8;
    let pq = a.update_spmv_dot(&z, beta, alpha, &mut x, &mut p, &mut q);
    for i in 0..18 {
        assert_eq!(x[i], x0[i] + alpha * p0[i]);
    }
    let expected_p: Vec<f64> = z.iter().zip(&p0).map(|(z, p)| z + beta * p).collect();
    let mut expected_q = vec![0.0; 18];
    a.mul_vec(&expected_p, &mut expected_q).unwrap();
    assert_eq!(p, expected_p);
    for (u, v) in q.iter().zip(&expected_q) {
        approx::assert_abs_diff_eq!(u, v, epsilon = 1e-14);
    }
    let expected_pq: f64 = expected_p.iter().zip(&expected_q).map(|(u, v)| u * v).sum();
    approx::assert_relative_eq!(pq, expected_pq, max_relative = 1e-13);
}

#[test]
fn diagonal_plus_combination_is_the_dense_formula() {
    // A = diag(d) + a X + b Y entry by entry, with X a chain and Y = 2 X + I.
    let x = chain(4);
    let mut y = SymBlockMatrix::new(x.pattern().clone());
    y.add_scaled(2.0, &x).unwrap();
    y.add_to_diagonal(&[1.0; 12]).unwrap();
    let d: Vec<f64> = (0..12).map(|k| 0.5 + k as f64).collect();
    let (a, b) = (-1e-4, -1e-2);
    let mut m = SymBlockMatrix::new(x.pattern().clone());
    m.assign_diagonal_plus_combination(&d, a, &x, b, &y)
        .unwrap();
    let (dm, dx, dy) = (dense(&m), dense(&x), dense(&y));
    for r in 0..12 {
        for c in 0..12 {
            let diag = if r == c { d[r] } else { 0.0 };
            let expected = diag + a * dx[r][c] + b * dy[r][c];
            assert!((dm[r][c] - expected).abs() <= 1e-15 * (1.0 + expected.abs()));
        }
    }
    let other = chain(3);
    assert!(
        m.assign_diagonal_plus_combination(&d, a, &other, b, &y)
            .is_err()
    );
    assert!(
        m.assign_diagonal_plus_combination(&d[..3], a, &x, b, &y)
            .is_err()
    );
}

#[test]
fn threaded_diagonal_plus_combination_gives_the_serial_bits() {
    // Large enough to split (and with a last chunk shorter than the others).
    let n = 3 * crate::par::MIN_PARALLEL_BLOCKS + 11;
    let x = banded(n, 67);
    let mut y = SymBlockMatrix::new(x.pattern().clone());
    y.add_scaled(-0.3, &x).unwrap();
    for (k, b) in y.values.iter_mut().enumerate() {
        b[0][1] += (k as f64 * 0.7).sin();
    }
    let d: Vec<f64> = (0..3 * n).map(|k| 1.0 + (k as f64).cos()).collect();
    let run = |threads: usize| {
        let mut m = SymBlockMatrix::new(x.pattern().clone());
        m.values.fill([[f64::NAN; 3]; 3]);
        crate::par::in_pool(threads, || {
            m.assign_diagonal_plus_combination(&d, -1e-4, &x, -1e-2, &y)
                .unwrap()
        });
        m.values
    };
    let serial = run(1);
    assert!(serial.iter().flatten().flatten().all(|v| v.is_finite()));
    assert_eq!(run(2), serial);
    assert_eq!(run(3), serial);
}

#[test]
fn csr_round_trip_and_faer_agree() {
    let a = chain(4);
    let csr = a.to_csr();
    let d = dense(&a);
    for (&v, (r, c)) in csr.iter() {
        assert_eq!(v, d[r][c]);
    }
    let back = SymBlockMatrix::from_csr(&csr).unwrap();
    assert_eq!(dense(&back), d);
    #[cfg(feature = "faer")]
    assert_eq!(a.to_faer().compute_nnz(), csr.nnz());
}

#[test]
fn from_csr_rejects_bad_shapes_and_asymmetry() {
    let mut t = sprs::TriMat::new((4, 4));
    t.add_triplet(0, 0, 1.0);
    assert_eq!(
        SymBlockMatrix::from_csr(&t.to_csr()),
        Err(SparseError::NotBlockAligned { dim: 4 })
    );
    let mut t = sprs::TriMat::new((3, 3));
    t.add_triplet(0, 1, 1.0);
    t.add_triplet(1, 0, 2.0);
    assert!(matches!(
        SymBlockMatrix::from_csr(&t.to_csr()),
        Err(SparseError::NotSymmetric { .. })
    ));
    let mut t = sprs::TriMat::new((3, 6));
    t.add_triplet(0, 1, 1.0);
    assert_eq!(
        SymBlockMatrix::from_csr(&t.to_csr()),
        Err(SparseError::NotSquare { rows: 3, cols: 6 })
    );
}

#[test]
fn wrong_vector_length_is_an_error() {
    let a = chain(2);
    let mut y = vec![0.0; 6];
    assert_eq!(
        a.mul_vec(&[1.0; 5], &mut y),
        Err(SparseError::DimensionMismatch {
            what: "x",
            expected: 6,
            found: 5
        })
    );
}

/// `from_blocks` against a dense assembly written out here: each triplet
/// lands at `(i, j)` and, off the diagonal, transposed at `(j, i)`;
/// duplicates and both orientations sum.
#[test]
fn from_blocks_sums_triplets_like_a_dense_assembly() {
    let n = 4;
    let blk = |s: f64| -> Block3 {
        let mut b = [[0.0; 3]; 3];
        for (r, row) in b.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v = s * (1.0 + r as f64) + 0.1 * c as f64;
            }
        }
        b
    };
    let sym = |s: f64| -> Block3 { block::add(&blk(s), &block::transpose(&blk(s))) };
    let triplets = vec![
        (0, 0, sym(1.0)),
        (1, 1, sym(2.0)),
        (2, 2, sym(3.0)),
        (3, 3, sym(4.0)),
        (0, 1, blk(0.5)),
        (2, 1, blk(-0.25)),
        (0, 1, blk(1.5)), // duplicate of (0, 1)
        (3, 0, blk(0.75)),
        (2, 2, sym(1.0)), // duplicate diagonal
    ];
    let a = SymBlockMatrix::from_blocks(n, triplets.clone()).unwrap();
    let mut dense = vec![vec![0.0; 3 * n]; 3 * n];
    for (i, j, m) in &triplets {
        for r in 0..3 {
            for c in 0..3 {
                dense[3 * i + r][3 * j + c] += m[r][c];
                if i != j {
                    dense[3 * j + c][3 * i + r] += m[r][c];
                }
            }
        }
    }
    let csr = a.to_csr();
    for (r, row) in dense.iter().enumerate() {
        for (c, &v) in row.iter().enumerate() {
            let got = csr.get(r, c).copied().unwrap_or(0.0);
            assert!((got - v).abs() < 1e-14, "({r}, {c}): {got} vs {v}");
        }
    }
    assert_eq!(a.pattern().stored_blocks(), n + 3);

    let mut asym = [[0.0; 3]; 3];
    asym[0][1] = 1.0;
    assert_eq!(
        SymBlockMatrix::from_blocks(2, [(1, 1, asym)]).unwrap_err(),
        SparseError::NotSymmetric { row: 3, col: 4 }
    );
    assert!(matches!(
        SymBlockMatrix::from_blocks(2, [(0, 2, blk(1.0))]),
        Err(SparseError::BlockIndexOutOfRange {
            row: 0,
            col: 2,
            n: 2
        })
    ));
    let mut nan = blk(1.0);
    nan[2][2] = f64::NAN;
    assert!(matches!(
        SymBlockMatrix::from_blocks(2, [(0, 0, sym(1.0)), (0, 1, nan)]),
        Err(SparseError::NonFinite { index: Some(1), .. })
    ));
}

/// The scalar pattern of `nodes` nodes of `dofs` unknowns each, every
/// unknown of node `i` coupled to every unknown of node `j` for each
/// `(i, j)` in `edges` and to its own node (values arbitrary, non-zero).
fn node_pattern(nodes: usize, dofs: usize, edges: &[(usize, usize)]) -> sprs::CsMat<f64> {
    let n = nodes * dofs;
    let mut t = sprs::TriMat::new((n, n));
    let mut couple = |i: usize, j: usize| {
        for p in 0..dofs {
            for q in 0..dofs {
                t.add_triplet(dofs * i + p, dofs * j + q, 1.0 + (p + 2 * q) as f64);
            }
        }
    };
    for i in 0..nodes {
        couple(i, i);
    }
    for &(i, j) in edges {
        couple(i, j);
        couple(j, i);
    }
    t.to_csr()
}

/// The edges of an `m x m` grid of nodes: right and down neighbours, and
/// both diagonals of every cell when `diagonals` (cloth's shear springs).
fn grid_edges(m: usize, diagonals: bool) -> Vec<(usize, usize)> {
    let id = |x: usize, y: usize| y * m + x;
    let mut e = Vec::new();
    for y in 0..m {
        for x in 0..m {
            if x + 1 < m {
                e.push((id(x, y), id(x + 1, y)));
            }
            if y + 1 < m {
                e.push((id(x, y), id(x, y + 1)));
            }
            if diagonals && x + 1 < m && y + 1 < m {
                e.push((id(x, y), id(x + 1, y + 1)));
                e.push((id(x + 1, y), id(x, y + 1)));
            }
        }
    }
    e
}

/// 2D elasticity (2 unknowns per node) on a 3 x 3 grid: 18 unknowns,
/// divisible by 2, 3 and 6, yet only the 2-blocking fits; stored as CSC
/// it reads the same.
#[test]
fn a_two_dof_pattern_is_detected_as_2() {
    let a = node_pattern(9, 2, &grid_edges(3, false));
    assert_eq!(a.rows(), 18);
    assert!(is_block_pattern(&a, 2));
    assert!(!is_block_pattern(&a, 3));
    assert_eq!(detect_block_size(&a), 2);
    assert_eq!(detect_block_size(&a.to_csc()), 2);
}

/// Cloth (3 unknowns per node, structural and shear springs) on a 4 x 4
/// grid: 48 unknowns, divisible by 2 and 6, detected as 3.
#[test]
fn a_three_dof_cloth_pattern_is_detected_as_3() {
    let a = node_pattern(16, 3, &grid_edges(4, true));
    assert_eq!(a.rows(), 48);
    assert!(!is_block_pattern(&a, 2));
    assert_eq!(detect_block_size(&a), 3);
}

/// The scalar 5-point Poisson pattern on a 6 x 6 grid (36 unknowns) has
/// no node blocks.
#[test]
fn a_scalar_poisson_pattern_is_detected_as_1() {
    let a = node_pattern(36, 1, &grid_edges(6, false));
    assert!(is_block_pattern(&a, 1));
    assert!(!is_block_pattern(&a, 2) && !is_block_pattern(&a, 3));
    assert_eq!(detect_block_size(&a), 1);
}

/// Zeros dropped inside the node blocks (a node's x-y coupling, as in
/// bilinear elasticity) keep the structure; one entry coupling a row to a
/// node its node's other rows do not touch breaks it: the answer falls
/// back to 1.
#[test]
fn a_pattern_broken_in_one_entry_falls_back_to_1() {
    let without = |a: &sprs::CsMat<f64>, drop: &[(usize, usize)], add: Option<(usize, usize)>| {
        let mut t = sprs::TriMat::new(a.shape());
        for (&v, (i, j)) in a.iter() {
            if !drop.contains(&(i, j)) {
                t.add_triplet(i, j, v);
            }
        }
        if let Some((i, j)) = add {
            t.add_triplet(i, j, 1.0);
        }
        t.to_csr::<usize>()
    };
    for (dofs, nodes, edges, extra) in [
        (2, 9, grid_edges(3, false), (0, 2 * 8)),
        (3, 16, grid_edges(4, true), (4, 3 * 15 + 2)),
        (3, 16, grid_edges(4, true), (47, 0)),
    ] {
        let full = node_pattern(nodes, dofs, &edges);
        assert_eq!(detect_block_size(&full), dofs);
        // Node 1 has neighbours of its own in both grids.
        let thinned = without(&full, &[(dofs, dofs + 1), (dofs + 1, dofs)], None);
        assert_eq!(thinned.nnz() + 2, full.nnz());
        assert_eq!(detect_block_size(&thinned), dofs);
        let broken = without(&full, &[], Some(extra));
        assert_eq!(broken.nnz(), full.nnz() + 1, "{extra:?} is a new entry");
        assert!(!is_block_pattern(&broken, dofs), "dofs {dofs}, {extra:?}");
        assert_eq!(detect_block_size(&broken), 1);
    }
}

/// A pattern of dense 6x6 blocks (two on the diagonal, or a dense 12 x 12
/// matrix) or a diagonal one is both 2- and 3-blocked: ambiguous, so 1. An
/// odd dimension is never 2-blocked, a non-square matrix never blocked.
#[test]
fn an_ambiguous_pattern_gives_1() {
    for a in [
        node_pattern(2, 6, &[]),
        node_pattern(2, 6, &[(0, 1)]),
        node_pattern(12, 1, &[]),
    ] {
        assert!(is_block_pattern(&a, 2) && is_block_pattern(&a, 3));
        assert_eq!(detect_block_size(&a), 1);
    }
    let odd = node_pattern(3, 3, &[(0, 1)]);
    assert!(is_block_pattern(&odd, 3) && !is_block_pattern(&odd, 2));
    assert_eq!(detect_block_size(&odd), 3);
    let wide: sprs::CsMat<f64> = sprs::CsMat::zero((6, 12));
    assert!(!is_block_pattern(&wide, 3));
    assert_eq!(detect_block_size(&wide), 1);
}

proptest::proptest! {
    /// The one-pass mirror check against the definition, entry by entry
    /// with a search for each mirror: random square patterns whose entries
    /// are symmetric, perturbed above or below the tolerance, or without a
    /// mirror (small or large), dense and sparse.
    #[test]
    fn symmetry_check_agrees_with_the_definition(
        n in 1usize..12,
        entries in proptest::collection::vec((0usize..12, 0usize..12, -4i32..5, 0u8..6), 0..60),
    ) {
        let mut t = sprs::TriMat::new((n, n));
        let mut seen = std::collections::HashSet::new();
        for &(i, j, v, kind) in &entries {
            let (i, j) = (i % n, j % n);
            if !seen.insert((i.min(j), i.max(j))) {
                continue;
            }
            let v = f64::from(v);
            match kind {
                // Symmetric pair (or a diagonal entry).
                0 | 1 => {
                    t.add_triplet(i, j, v);
                    if i != j { t.add_triplet(j, i, v); }
                }
                // Mirror off by far more, or far less, than 1e-12 of the largest.
                2 | 3 if i != j => {
                    let d = if kind == 2 { 1e-6 } else { 1e-15 };
                    t.add_triplet(i, j, v);
                    t.add_triplet(j, i, v + d);
                }
                // No mirror stored: symmetric only when the entry is (near) zero.
                4 => t.add_triplet(i, j, v * 1e-14),
                _ => t.add_triplet(i, j, v),
            }
        }
        let a: sprs::CsMat<f64> = t.to_csr();
        let max = a.data().iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        let first_bad = a.iter().find(|&(&v, (r, c))| {
            (v - a.get(c, r).copied().unwrap_or(0.0)).abs() > 1e-12 * max
        });
        let expected = match first_bad {
            Some((_, (row, col))) => Err(SparseError::NotSymmetric { row, col }),
            None => Ok(()),
        };
        proptest::prop_assert_eq!(check_csr_symmetric(&a), expected.clone());
        // CSC storage takes the general path and must agree.
        let csc = a.to_csc();
        proptest::prop_assert_eq!(check_csr_symmetric(&csc).is_ok(), expected.is_ok());
    }
}

proptest::proptest! {
    /// `from_csr` keeps every entry: its dense form equals the scalar
    /// matrix's, on random symmetric patterns that fill 3x3 blocks partly
    /// (writers drop exact zeros), with empty block rows and CSC input, on
    /// the pattern of exactly the blocks that hold an entry.
    #[test]
    fn from_csr_keeps_every_entry(
        nodes in 1usize..6,
        entries in proptest::collection::vec((0usize..18, 0usize..18, 1i32..9), 0..40),
    ) {
        let dim = 3 * nodes;
        let mut seen = std::collections::HashSet::new();
        let mut t = sprs::TriMat::new((dim, dim));
        let mut want = vec![vec![0.0; dim]; dim];
        for &(i, j, v) in &entries {
            let (i, j) = (i % dim, j % dim);
            if !seen.insert((i.min(j), i.max(j))) {
                continue;
            }
            let v = f64::from(v);
            t.add_triplet(i, j, v);
            want[i][j] = v;
            if i != j {
                t.add_triplet(j, i, v);
                want[j][i] = v;
            }
        }
        let csr: sprs::CsMat<f64> = t.to_csr();
        // The pattern is exactly the blocks holding an entry: the one
        // `BlockPattern::new` makes from the pairs (a sort of all of them).
        let pairs = seen.iter().map(|&(i, j)| (i / 3, j / 3));
        let expected = BlockPattern::new(nodes, pairs).unwrap();
        let got = BlockPattern::of_scalar_upper(nodes, &csr).unwrap();
        proptest::prop_assert_eq!((got.row_ptr(), got.col_idx()), (expected.row_ptr(), expected.col_idx()));
        proptest::prop_assert_eq!(dense(&SymBlockMatrix::from_csr(&csr).unwrap()), want.clone());
        proptest::prop_assert_eq!(dense(&SymBlockMatrix::from_csr(&csr.to_csc()).unwrap()), want);
    }
}
