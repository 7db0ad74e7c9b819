//! The symbolic half of smoothed aggregation (Vaněk, Mandel, Brezina 1996,
//! "Algebraic multigrid by smoothed aggregation for second and fourth order
//! elliptic problems", section 3): strength of connection on blocks,
//! aggregation, and the tentative prolongator from the near-nullspace.

use super::bsr::{Blk, Bsr, Entry, frobenius2, load, zero};
use crate::error::SparseError;

/// Marks a node that belongs to no aggregate (it has no strong neighbour;
/// the smoother alone handles it).
pub(crate) const NO_AGGREGATE: u32 = u32::MAX;

/// Strength of connection on blocks: the off-diagonal block `A_ij` is strong
/// when `|A_ij|_F^2 > theta^2 |A_ii|_F |A_jj|_F` (the block form of the
/// symmetric test `|a_ij| > theta sqrt(|a_ii a_jj|)`; symmetric in `i, j`
/// because `|A_ji|_F = |A_ij^T|_F`). Diagonal slots are marked not strong.
pub(crate) fn strong_connections<const B: usize, S: Entry>(
    a: &Bsr<B, S>,
    diag: &[usize],
    theta: f64,
) -> Vec<bool> {
    let norms: Vec<f64> = diag
        .iter()
        .map(|&d| frobenius2(&load(&a.val[d])).sqrt())
        .collect();
    let mut strong = vec![false; a.nnz_blocks()];
    for i in 0..a.nrows {
        for k in a.row(i) {
            let j = a.col[k] as usize;
            strong[k] =
                j != i && frobenius2(&load(&a.val[k])) > theta * theta * norms[i] * norms[j];
        }
    }
    strong
}

/// Greedy aggregation on the graph of strong connections (the three passes
/// of Vaněk, Mandel, Brezina, as in pyamg's standard aggregation):
/// 1. every node whose strong neighbours are all free seeds an aggregate of
///    itself and those neighbours;
/// 2. every free node joins the aggregate of a strong neighbour seeded in pass 1;
/// 3. every node still free forms an aggregate with its free strong neighbours,
///    or, when that would have fewer than `min_nodes` nodes (too few
///    unknowns for the near-nullspace vectors), joins the aggregate of a
///    strong neighbour.
///
/// Nodes without strong neighbours stay out ([`NO_AGGREGATE`]). Returns the
/// aggregate of every node and the number of aggregates.
pub(crate) fn aggregate<const B: usize, S: Entry>(
    a: &Bsr<B, S>,
    strong: &[bool],
    min_nodes: usize,
) -> (Vec<u32>, usize) {
    let n = a.nrows;
    let mut agg = vec![NO_AGGREGATE; n];
    let mut seeded = vec![false; n];
    let mut count = 0u32;
    let neighbours = |i: usize| a.row(i).filter(|&k| strong[k]).map(|k| a.col[k] as usize);
    for i in 0..n {
        if agg[i] != NO_AGGREGATE {
            continue;
        }
        let mut any = false;
        let mut all_free = true;
        for j in neighbours(i) {
            any = true;
            all_free &= agg[j] == NO_AGGREGATE;
        }
        if any && all_free {
            agg[i] = count;
            seeded[i] = true;
            for j in neighbours(i) {
                agg[j] = count;
                seeded[j] = true;
            }
            count += 1;
        }
    }
    for i in 0..n {
        if agg[i] == NO_AGGREGATE
            && let Some(j) = neighbours(i).find(|&j| seeded[j])
        {
            agg[i] = agg[j];
        }
    }
    for i in 0..n {
        if agg[i] == NO_AGGREGATE && neighbours(i).next().is_some() {
            let free = neighbours(i).filter(|&j| agg[j] == NO_AGGREGATE).count();
            if 1 + free < min_nodes
                && let Some(j) = neighbours(i).find(|&j| agg[j] != NO_AGGREGATE)
            {
                agg[i] = agg[j];
                continue;
            }
            agg[i] = count;
            for j in neighbours(i) {
                if agg[j] == NO_AGGREGATE {
                    agg[j] = count;
                }
            }
            count += 1;
        }
    }
    (agg, count as usize)
}

/// The tentative prolongator `T` (one `B x K` block per aggregated node)
/// and the coarse near-nullspace (one `K x K` block per aggregate): on
/// every aggregate the stacked nullspace blocks `N_a` (its `B m` rows by the
/// `K` vectors) are factored `N_a = Q_a R_a` (thin QR, modified Gram-Schmidt
/// done twice, as pyamg's `fit_candidates`); the rows of `Q_a` become the
/// blocks of `T` in the aggregate's column, `R_a` the coarse nullspace block
/// of the aggregate. So `N = T N_c` and `T^T T = I`, and every coarse node
/// carries `K` unknowns (`K > B` for rigid-body modes: 3 on 2D nodes of 2
/// unknowns, 6 on 3D nodes of 3).
///
/// A vector that is dependent on the previous ones on an aggregate (a
/// rotation about the line through the nodes of a thin aggregate) leaves
/// its column of `Q_a` to the unit vector of the aggregate farthest from
/// the span of the others (`R_a` gets a zero pivot there): `T` keeps `K`
/// orthonormal columns per aggregate, so the coarse operators stay
/// positive definite, and `N = T N_c` holds to the dropped remainder
/// (below `1e-10` of the vector's norm on the aggregate).
///
/// # Errors
/// [`SparseError::InvalidParameter`] if an aggregate has fewer unknowns
/// (`B m`) than vectors (`K`).
pub(crate) fn tentative_prolongator<const B: usize, const K: usize>(
    agg: &[u32],
    n_agg: usize,
    nullspace: &[Blk<B, K>],
) -> Result<(Bsr<B, f64, K>, Vec<Blk<K>>), SparseError> {
    let n = agg.len();
    // Members of every aggregate, by counting sort.
    let mut start = vec![0usize; n_agg + 1];
    for &a in agg.iter().filter(|&&a| a != NO_AGGREGATE) {
        start[a as usize + 1] += 1;
    }
    for a in 0..n_agg {
        start[a + 1] += start[a];
    }
    let mut next = start.clone();
    let mut members = vec![0usize; start[n_agg]];
    for (i, &a) in agg.iter().enumerate() {
        if a != NO_AGGREGATE {
            members[next[a as usize]] = i;
            next[a as usize] += 1;
        }
    }
    let mut row_ptr = Vec::with_capacity(n + 1);
    row_ptr.push(0);
    let mut col = Vec::new();
    let mut slot = vec![usize::MAX; n];
    for (i, &a) in agg.iter().enumerate() {
        if a != NO_AGGREGATE {
            slot[i] = col.len();
            col.push(a);
        }
        row_ptr.push(col.len());
    }
    let mut val: Vec<Blk<B, K>> = vec![zero::<B, K>(); col.len()];
    for (i, &s) in slot.iter().enumerate() {
        if s != usize::MAX {
            val[s] = nullspace[i];
        }
    }
    let mut coarse = vec![zero::<K, K>(); n_agg];
    for a in 0..n_agg {
        let nodes = &members[start[a]..start[a + 1]];
        if B * nodes.len() < K {
            return Err(SparseError::InvalidParameter {
                name: "near_nullspace",
                message: format!(
                    "the aggregate of node {} has {} unknowns, fewer than the {K} near-nullspace vectors",
                    nodes[0],
                    B * nodes.len()
                ),
            });
        }
        let r = &mut coarse[a];
        for c in 0..K {
            let norm0 = column_norm(&val, &slot, nodes, c);
            orthogonalise(&mut val, &slot, nodes, c, |p, d| r[p][c] += d);
            let mut norm = column_norm(&val, &slot, nodes, c);
            if norm > 1e-10 * norm0 && norm > 0.0 {
                r[c][c] = norm;
            } else {
                norm = complete(&mut val, &slot, nodes, c);
            }
            for &i in nodes {
                for row in val[slot[i]].iter_mut() {
                    row[c] /= norm;
                }
            }
        }
    }
    Ok((
        Bsr {
            nrows: n,
            ncols: n_agg,
            row_ptr,
            col,
            val,
        },
        coarse,
    ))
}

/// Column `c` of the aggregate `nodes` minus its projections on columns
/// `0..c` (orthonormal), modified Gram-Schmidt done twice; `project(p, d)`
/// gets every projection `d` on column `p`.
fn orthogonalise<const B: usize, const K: usize>(
    val: &mut [Blk<B, K>],
    slot: &[usize],
    nodes: &[usize],
    c: usize,
    mut project: impl FnMut(usize, f64),
) {
    for _pass in 0..2 {
        for p in 0..c {
            let mut d = 0.0;
            for &i in nodes {
                for row in val[slot[i]].iter() {
                    d += row[p] * row[c];
                }
            }
            for &i in nodes {
                for row in val[slot[i]].iter_mut() {
                    row[c] -= d * row[p];
                }
            }
            project(p, d);
        }
    }
}

/// Fills column `c` of the aggregate `nodes` with the unit vector (of its
/// `B m` unknowns, the first of the largest) whose part orthogonal to
/// columns `0..c` is longest, orthogonalised; returns that part's norm
/// (at least `1 / sqrt(B m)`: the unit vectors span the aggregate's space).
fn complete<const B: usize, const K: usize>(
    val: &mut [Blk<B, K>],
    slot: &[usize],
    nodes: &[usize],
    c: usize,
) -> f64 {
    let mut best = (0, 0, -1.0);
    for &i in nodes {
        for r in 0..B {
            // |(I - Q Q^T) e|^2 = 1 - sum_p Q_{e p}^2.
            let rest = 1.0 - val[slot[i]][r][..c].iter().map(|q| q * q).sum::<f64>();
            if rest > best.2 {
                best = (i, r, rest);
            }
        }
    }
    for &i in nodes {
        for (r, row) in val[slot[i]].iter_mut().enumerate() {
            row[c] = if (i, r) == (best.0, best.1) { 1.0 } else { 0.0 };
        }
    }
    orthogonalise(val, slot, nodes, c, |_, _| {});
    column_norm(val, slot, nodes, c)
}

fn column_norm<const B: usize, const K: usize>(
    val: &[Blk<B, K>],
    slot: &[usize],
    nodes: &[usize],
    c: usize,
) -> f64 {
    nodes
        .iter()
        .flat_map(|&i| val[slot[i]].iter().map(move |row| row[c] * row[c]))
        .sum::<f64>()
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::super::nullspace::rigid_body_modes;
    use super::*;

    /// Two nodes on the x axis: the rotation about x moves neither, so the
    /// six rigid-body modes have rank 5 on their aggregate and the QR
    /// completes the sixth column; one node alone is too few unknowns.
    #[test]
    fn a_dependent_mode_is_completed_and_the_modes_are_reproduced() {
        let modes = rigid_body_modes(&[0.0, 0.0, 0.0, 2.0, 0.0, 0.0], 3).unwrap();
        let blocks: Vec<Blk<3, 6>> = (0..2)
            .map(|i| {
                let mut b = zero::<3, 6>();
                for (r, row) in b.iter_mut().enumerate() {
                    for (c, v) in modes.iter().enumerate() {
                        row[c] = v[3 * i + r];
                    }
                }
                b
            })
            .collect();
        let (t, r) = tentative_prolongator(&[0, 0], 1, &blocks).unwrap();
        // Column c of T: the 6 entries of the two blocks' column c.
        let column = |c: usize| -> Vec<f64> {
            t.val
                .iter()
                .flat_map(|b| b.iter().map(move |row| row[c]))
                .collect()
        };
        for p in 0..6 {
            for q in 0..6 {
                let d: f64 = column(p).iter().zip(column(q)).map(|(x, y)| x * y).sum();
                let e = if p == q { 1.0 } else { 0.0 };
                assert!((d - e).abs() < 1e-14, "T^T T ({p},{q}) = {d}");
            }
        }
        // The rotation about x (mode 3) is zero here: its pivot is zero.
        assert!(r[0][3][3].abs() < 1e-12, "{:?}", r[0][3]);
        // N = T R, entry by entry.
        for (i, b) in blocks.iter().enumerate() {
            for row in 0..3 {
                for c in 0..6 {
                    let tr: f64 = (0..6).map(|k| t.val[i][row][k] * r[0][k][c]).sum();
                    assert!(
                        (tr - b[row][c]).abs() < 1e-14,
                        "node {i}, row {row}, mode {c}"
                    );
                }
            }
        }
        assert!(tentative_prolongator(&[0], 1, &blocks[..1]).is_err());
    }
}
