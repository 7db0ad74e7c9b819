//! One level of nested dissection for the block IC(0)/MIC(0) factor: the
//! order `A, B reversed, S` in which two threads share the triangular solves.
//!
//! A banded pattern (a cloth grid in its natural order, a rope, any matrix
//! whose rows couple only to nearby rows) splits at a row `m`: the rows
//! `0..m` (domain `A`) couple only to rows below `m + w`, so the `w` rows
//! `m..m + w` (the separator `S`) cut `A` from the rows `m + w..n` (domain
//! `B`), and no block couples `A` with `B`. With the separator numbered last
//! (George's nested dissection, one level: George 1973, "Nested dissection
//! of a regular finite element mesh"), the incomplete factor `U` of
//! `P A P^T ~ U^T D U` has no block between `A` and `B` either, because
//! IC(0) keeps only the pattern of `P A P^T`. Each sweep of `M^-1 r` is
//! then two independent sweeps over `A` and `B` and a short one over `S`
//! (forward: `A | B`, then `S`; backward: `S`, then `A | B`).
//!
//! `B` is numbered backwards, from row `n - 1` towards the separator, so
//! that both domains are eliminated towards `S` (a twisted factorisation,
//! "burn at both ends"). The order matters: on the 64² cloth system of the
//! peers' gallery (`cloth64-k1e4.mtx`), PCG with MIC(0) takes 64
//! iterations in the natural order and in this one, but 94 with `B` in its
//! natural order and 95 with `S` first (`hookean solve` on the symmetrically
//! permuted matrices).
//!
//! The split is a fixed function of the pattern, never of the number of
//! threads, so the preconditioner and every result have the same bits on
//! one thread and on many.

use std::sync::Arc;

use crate::block::{self, Block3};
use crate::matrix::{BlockPattern, Slot};
use crate::par::MIN_PARALLEL_BLOCKS;

/// The separator may hold at most this fraction (`1 / MAX_SEPARATOR_SHARE`)
/// of the rows: its sweep is serial.
const MAX_SEPARATOR_SHARE: usize = 8;

/// The split of a pattern into `A = 0..m`, `S = m..m + w`, `B = m + w..n`
/// (the matrix's numbering) and the factor's numbering `A, B reversed, S`:
/// old row `i < m` is new row `i`, `B`'s old row `i` is `m + n - 1 - i`,
/// `S`'s old row `i` is `i + (n - m - w)`.
#[derive(Debug, Clone)]
pub(crate) struct TwoDomains {
    n: usize,
    m: usize,
    w: usize,
    /// The pattern of `P A P^T`.
    pattern: Arc<BlockPattern>,
    /// For each slot of `pattern`, the slot of the matrix's pattern holding
    /// that block (transposed when the order of its two rows flipped).
    source: Vec<Slot>,
}

impl TwoDomains {
    /// The split of `pattern` whose two domains are closest in size, if the
    /// pattern is large enough to thread ([`MIN_PARALLEL_BLOCKS`] block rows)
    /// and the separator holds at most an eighth of the rows and each
    /// domain at least a quarter; `None` otherwise (the factor keeps the
    /// matrix's order).
    pub fn of(pattern: &BlockPattern) -> Option<Self> {
        let n = pattern.n_blocks();
        if n < MIN_PARALLEL_BLOCKS {
            return None;
        }
        let (row_ptr, cols) = (pattern.row_ptr(), pattern.col_idx());
        // reach = 1 + the farthest column of rows 0..m: with A = 0..m,
        // S = m..reach and B = reach..n, no row of A couples to B.
        let mut reach = 0;
        let mut best: Option<(usize, usize)> = None;
        for m in 1..n {
            reach = reach.max(cols[row_ptr[m] - 1] as usize + 1).max(m);
            let b = n - reach;
            if best.is_none_or(|(bm, bb)| m.abs_diff(b) < bm.abs_diff(bb)) {
                best = Some((m, b));
            }
        }
        let (m, b) = best?;
        let w = n - m - b;
        if w * MAX_SEPARATOR_SHARE > n || 4 * m < n || 4 * b < n {
            return None;
        }
        let split = |old: usize| -> usize {
            if old < m {
                old
            } else if old < m + w {
                old + b
            } else {
                m + n - 1 - old
            }
        };
        let pairs = (0..n).flat_map(|i| {
            cols[row_ptr[i] + 1..row_ptr[i + 1]]
                .iter()
                .map(move |&j| (split(i), split(j as usize)))
        });
        let permuted = BlockPattern::new(n, pairs).ok()?;
        let mut this = Self {
            n,
            m,
            w,
            pattern: Arc::new(permuted),
            source: Vec::new(),
        };
        let (prow, pcols) = (this.pattern.row_ptr(), this.pattern.col_idx());
        let mut source = Vec::with_capacity(pcols.len());
        for r in 0..n {
            for &c in &pcols[prow[r]..prow[r + 1]] {
                // Every block of P A P^T is a block of A.
                source.push(pattern.find(this.old_row(r), this.old_row(c as usize))?);
            }
        }
        this.source = source;
        Some(this)
    }

    /// The pattern of `P A P^T` (the factor's).
    pub fn pattern(&self) -> &Arc<BlockPattern> {
        &self.pattern
    }

    /// Rows of `A` (the first domain): `0..m` in both numberings.
    pub fn m(&self) -> usize {
        self.m
    }

    /// Rows of the separator `S`.
    pub fn w(&self) -> usize {
        self.w
    }

    /// Rows of `B` (the second domain).
    pub fn b(&self) -> usize {
        self.n - self.m - self.w
    }

    /// The matrix's row of the factor's row `new`.
    pub fn old_row(&self, new: usize) -> usize {
        let (m, b) = (self.m, self.b());
        if new < m {
            new
        } else if new < m + b {
            m + self.n - 1 - new
        } else {
            new - b
        }
    }

    /// `dst = P A P^T`'s values from `A`'s values `src`.
    pub fn gather(&self, src: &[Block3], dst: &mut Vec<Block3>) {
        dst.clear();
        dst.extend(self.source.iter().map(|s| {
            let v = &src[s.index()];
            if s.is_transposed() {
                block::transpose(v)
            } else {
                *v
            }
        }));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 5-point-plus-bending pattern of an `n x n` grid, natural order.
    fn grid(n: usize) -> BlockPattern {
        let id = |r: usize, c: usize| r * n + c;
        let mut pairs = Vec::new();
        for r in 0..n {
            for c in 0..n {
                for (dr, dc) in [(0, 1), (1, 0), (1, 1), (0, 2), (2, 0)] {
                    if r + dr < n && c + dc < n {
                        pairs.push((id(r, c), id(r + dr, c + dc)));
                    }
                }
                if r + 1 < n && c >= 1 {
                    pairs.push((id(r, c), id(r + 1, c - 1)));
                }
            }
        }
        BlockPattern::new(n * n, pairs).unwrap()
    }

    #[test]
    fn a_grid_splits_at_two_lines_and_a_b_never_meet() {
        let p = grid(64);
        let s = TwoDomains::of(&p).expect("a 64 x 64 grid splits");
        // Bending reaches two grid lines ahead: the separator is two lines
        // (128 rows, less one row of the first: row m - 1's farthest
        // neighbour is m - 1 + 128).
        assert!((120..=130).contains(&s.w()), "w = {}", s.w());
        assert!(s.m().abs_diff(s.b()) <= 1, "m = {}, b = {}", s.m(), s.b());
        // No stored block joins A and B, in either numbering.
        let (m, w) = (s.m(), s.w());
        for i in 0..m {
            for &j in &p.col_idx()[p.row_ptr()[i]..p.row_ptr()[i + 1]] {
                assert!((j as usize) < m + w, "A row {i} couples to B row {j}");
            }
        }
        let q = s.pattern();
        for i in 0..m {
            for &j in &q.col_idx()[q.row_ptr()[i]..q.row_ptr()[i + 1]] {
                let j = j as usize;
                assert!(
                    j < m || j >= m + s.b(),
                    "new A row {i} couples to B row {j}"
                );
            }
        }
        // The permutation is a bijection and P A P^T has A's block count.
        let mut seen = vec![false; p.n_blocks()];
        for new in 0..p.n_blocks() {
            let old = s.old_row(new);
            assert!(!seen[old]);
            seen[old] = true;
        }
        assert_eq!(q.stored_blocks(), p.stored_blocks());
    }

    #[test]
    fn gather_is_the_symmetric_permutation() {
        let p = grid(48);
        let s = TwoDomains::of(&p).expect("a 48 x 48 grid splits");
        // Distinct, nonsymmetric blocks so that a missed transpose shows.
        let values: Vec<Block3> = (0..p.stored_blocks())
            .map(|k| {
                let f = k as f64;
                [
                    [f, f + 0.1, f + 0.2],
                    [f + 0.3, f + 0.4, f + 0.5],
                    [f + 0.6, f + 0.7, f + 0.8],
                ]
            })
            .collect();
        let mut permuted = Vec::new();
        s.gather(&values, &mut permuted);
        let q = s.pattern();
        let block_of = |i: usize, j: usize| -> Block3 {
            let slot = p.find(i, j).unwrap();
            let v = values[slot.index()];
            if slot.is_transposed() {
                block::transpose(&v)
            } else {
                v
            }
        };
        for r in 0..q.n_blocks() {
            for k in q.row_ptr()[r]..q.row_ptr()[r + 1] {
                let c = q.col_idx()[k] as usize;
                assert_eq!(
                    permuted[k],
                    block_of(s.old_row(r), s.old_row(c)),
                    "block ({r}, {c})"
                );
            }
        }
    }

    #[test]
    fn small_or_wide_patterns_keep_their_order() {
        assert!(TwoDomains::of(&grid(32)).is_none(), "1024 rows stay serial");
        // Every row coupled to the last one: no separator narrower than n - 1.
        let n = 4096;
        let star = BlockPattern::new(n, (0..n - 1).map(|i| (i, n - 1))).unwrap();
        assert!(TwoDomains::of(&star).is_none());
    }
}
