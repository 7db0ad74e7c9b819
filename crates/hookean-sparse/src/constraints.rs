//! Per-particle constraints for the filtered CG of Baraff and Witkin
//! (the tutorial's section 4.2, eqs. 55-57).

use crate::block::{self, Block3};
use crate::error::SparseError;
use crate::matrix::{BlockPattern, SymBlockMatrix};

const NONE: usize = usize::MAX;

/// Constraints on the unknown `x` (3 entries per particle): for a
/// constrained particle `p`, up to three orthonormal directions `d_k` with
/// prescribed values `d_k . x_p = c_k`.
///
/// The filter `P = I - sum_k d_k d_k^T` ([`project`](Self::project)) removes
/// the constrained components; filtered CG solves `P A P x = P b` with
/// `(I - P) x` fixed to the prescribed values.
///
/// Re-filled every step as collisions come and go: [`clear`](Self::clear)
/// keeps the storage, so refilling allocates nothing once warmed up.
///
/// ```
/// use hookean_sparse::Constraints;
/// let mut c = Constraints::new(3);
/// c.pin(0, [0.0, 0.0, 0.0])?;                 // particle 0 does not move
/// c.constrain(2, [0.0, 0.0, 2.0], 0.0)?;      // particle 2 slides in the z = const plane
/// let mut v = vec![1.0; 9];
/// c.project(&mut v);
/// assert_eq!(v, [0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0]);
/// # Ok::<(), hookean_sparse::SparseError>(())
/// ```
#[derive(Debug, Default)]
pub struct Constraints {
    slot: Vec<usize>,
    entries: Vec<Entry>,
    /// The filter `P_p` of every entry (same index), formed as the entry
    /// changes: [`filter_matrix`](Self::filter_matrix) reads it for every
    /// stored block of a constrained row or column.
    projectors: Vec<Block3>,
}

impl Clone for Constraints {
    fn clone(&self) -> Self {
        Self {
            slot: self.slot.clone(),
            entries: self.entries.clone(),
            projectors: self.projectors.clone(),
        }
    }

    /// Copies into the storage at hand (the linear solver's copy of a
    /// step's constraints): no allocation once it has grown.
    fn clone_from(&mut self, source: &Self) {
        self.slot.clone_from(&source.slot);
        self.entries.clone_from(&source.entries);
        self.projectors.clone_from(&source.projectors);
    }
}

#[derive(Debug, Clone, Copy)]
struct Entry {
    particle: usize,
    count: usize,
    dirs: [[f64; 3]; 3],
    values: [f64; 3],
}

impl Entry {
    /// The filter `P = I - sum_k d_k d_k^T` of this particle.
    fn projector(&self) -> Block3 {
        let mut p = [[0.0; 3]; 3];
        for (r, row) in p.iter_mut().enumerate() {
            row[r] = 1.0;
        }
        for d in &self.dirs[..self.count] {
            for (r, row) in p.iter_mut().enumerate() {
                for (c, v) in row.iter_mut().enumerate() {
                    *v -= d[r] * d[c];
                }
            }
        }
        p
    }
}

impl Constraints {
    /// No constraints on `n_particles` particles.
    ///
    /// # Panics
    /// If the allocator cannot give `8 n_particles` bytes (as `Vec` does);
    /// [`try_new`](Self::try_new) returns an error instead.
    pub fn new(n_particles: usize) -> Self {
        Self {
            slot: vec![NONE; n_particles],
            entries: Vec::new(),
            projectors: Vec::new(),
        }
    }

    /// No constraints on `n_particles` particles, or an error where
    /// [`new`](Self::new) panics.
    ///
    /// # Errors
    /// [`SparseError::TooLarge`] if the per-particle index cannot be allocated.
    pub fn try_new(n_particles: usize) -> Result<Self, SparseError> {
        Ok(Self {
            slot: crate::error::try_filled("constraints", n_particles, NONE)?,
            entries: Vec::new(),
            projectors: Vec::new(),
        })
    }

    /// Number of particles (the unknown has `3 * n_particles` entries).
    pub fn n_particles(&self) -> usize {
        self.slot.len()
    }

    /// Number of constrained particles.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True when no particle is constrained.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Removes every constraint, keeping the storage.
    pub fn clear(&mut self) {
        for e in &self.entries {
            self.slot[e.particle] = NONE;
        }
        self.entries.clear();
        self.projectors.clear();
    }

    /// The constrained particles and their numbers of constrained
    /// directions (1 to 3), in the order they were constrained.
    pub fn counts(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.entries.iter().map(|e| (e.particle, e.count))
    }

    /// Every constrained direction as `(particle, d_k, c_k)`, particle by
    /// particle in the order they were constrained: [`constrain`](Self::constrain)
    /// called with these in this order rebuilds the constraints (exactly for
    /// pins and other axis directions; up to rounding for others, which it
    /// normalises again). How a recorded system carries its constraints.
    pub fn directions(&self) -> impl Iterator<Item = (usize, [f64; 3], f64)> + '_ {
        self.entries
            .iter()
            .flat_map(|e| (0..e.count).map(move |k| (e.particle, e.dirs[k], e.values[k])))
    }

    /// Number of constrained directions of `particle` (0 to 3).
    pub fn count(&self, particle: usize) -> usize {
        match self.slot.get(particle) {
            Some(&s) if s != NONE => self.entries[s].count,
            _ => 0,
        }
    }

    /// Adds the constraint `direction . x_particle = value`. The direction
    /// need not be unit length nor orthogonal to the particle's earlier
    /// directions: it is orthonormalised against them (Gram-Schmidt) and the
    /// value transformed to match.
    ///
    /// # Errors
    /// [`SparseError::BlockIndexOutOfRange`] for a particle out of range,
    /// [`SparseError::NonFinite`] for NaN input, and
    /// [`SparseError::DegenerateConstraint`] for a zero direction, one in the
    /// span of earlier ones, or a fourth direction.
    pub fn constrain(
        &mut self,
        particle: usize,
        direction: [f64; 3],
        value: f64,
    ) -> Result<(), SparseError> {
        let n = self.slot.len();
        if particle >= n {
            return Err(SparseError::BlockIndexOutOfRange {
                row: particle,
                col: particle,
                n,
            });
        }
        if direction.iter().any(|v| !v.is_finite()) || !value.is_finite() {
            return Err(SparseError::NonFinite {
                what: "constraint",
                index: Some(particle),
            });
        }
        let s = self.slot[particle];
        let mut entry = if s == NONE {
            Entry {
                particle,
                count: 0,
                dirs: [[0.0; 3]; 3],
                values: [0.0; 3],
            }
        } else {
            self.entries[s]
        };
        if entry.count == 3 {
            return Err(SparseError::DegenerateConstraint { particle });
        }
        let scale = norm3(&direction);
        let mut d = direction;
        let mut v = value;
        for k in 0..entry.count {
            let proj = dot3(&d, &entry.dirs[k]);
            for c in 0..3 {
                d[c] -= proj * entry.dirs[k][c];
            }
            v -= proj * entry.values[k];
        }
        let len = norm3(&d);
        if !(len > 1e-10 * scale) || scale == 0.0 {
            return Err(SparseError::DegenerateConstraint { particle });
        }
        entry.dirs[entry.count] = [d[0] / len, d[1] / len, d[2] / len];
        entry.values[entry.count] = v / len;
        entry.count += 1;
        if s == NONE {
            self.slot[particle] = self.entries.len();
            self.entries.push(entry);
            self.projectors.push(entry.projector());
        } else {
            self.entries[s] = entry;
            self.projectors[s] = entry.projector();
        }
        Ok(())
    }

    /// Pins `particle`: all three components are prescribed, `x_particle = value`.
    ///
    /// # Errors
    /// As [`constrain`](Self::constrain); a particle that already has
    /// constraints is re-pinned from scratch.
    pub fn pin(&mut self, particle: usize, value: [f64; 3]) -> Result<(), SparseError> {
        if let Some(&s) = self.slot.get(particle)
            && s != NONE
        {
            self.entries[s].count = 0;
        }
        for (c, &v) in value.iter().enumerate() {
            let mut e = [0.0; 3];
            e[c] = 1.0;
            self.constrain(particle, e, v)?;
        }
        Ok(())
    }

    /// Applies the filter `v <- P v`, removing constrained components.
    #[inline]
    pub fn project(&self, v: &mut [f64]) {
        for e in &self.entries {
            let vp = &mut v[3 * e.particle..3 * e.particle + 3];
            for d in &e.dirs[..e.count] {
                let s = d[0] * vp[0] + d[1] * vp[1] + d[2] * vp[2];
                vp[0] -= s * d[0];
                vp[1] -= s * d[1];
                vp[2] -= s * d[2];
            }
        }
    }

    /// Sets the constrained components of `x` to their prescribed values:
    /// `x <- P x + sum_k c_k d_k`.
    pub fn impose(&self, x: &mut [f64]) {
        self.project(x);
        for e in &self.entries {
            for k in 0..e.count {
                for c in 0..3 {
                    x[3 * e.particle + c] += e.values[k] * e.dirs[k][c];
                }
            }
        }
    }

    /// The filter `P_p = I - sum_k d_k d_k^T` of `particle` as a 3x3 block
    /// (`None` for an unconstrained particle).
    pub fn projector(&self, particle: usize) -> Option<Block3> {
        let s = *self.slot.get(particle)?;
        (s != NONE).then(|| self.projectors[s])
    }

    /// Replaces `A` by the filtered matrix `P A P + (I - P) s (I - P)` that
    /// filtered CG solves with (`s` per constrained particle: the mean of
    /// its diagonal block's diagonal, so the constrained directions keep
    /// their scale). On `range(P)` both act alike, so filtered CG's iterates
    /// do not change in exact arithmetic; a preconditioner set up from the
    /// filtered matrix sees the constrained particles as the Dirichlet
    /// boundary they are for the step (Baraff and Witkin's filter), instead
    /// of couplings through them that the solve never uses. One pass over
    /// the stored blocks, threaded by row parts (every block is its own
    /// function of the input: the same bits for every thread count); no
    /// allocation.
    pub fn filter_matrix(&self, a: &mut SymBlockMatrix) {
        if self.entries.is_empty() {
            return;
        }
        let pattern = std::sync::Arc::clone(a.pattern());
        let parts = crate::par::parts_for(pattern.n_blocks());
        let rows = |t| pattern.part_start(t, parts);
        crate::par::join_parts(
            a.values_mut(),
            parts,
            &|t| pattern.row_ptr()[rows(t)],
            &|t, vals| self.filter_rows(&pattern, vals, rows(t), rows(t + 1)),
            &|(), ()| (),
        );
    }

    /// Rows `r0..r1` of [`filter_matrix`](Self::filter_matrix); `vals`
    /// holds their stored blocks.
    fn filter_rows(&self, pattern: &BlockPattern, vals: &mut [Block3], r0: usize, r1: usize) {
        let (row_ptr, col_idx) = (pattern.row_ptr(), pattern.col_idx());
        let base = row_ptr[r0];
        for i in r0..r1 {
            let pi = self.projector(i);
            for k in row_ptr[i]..row_ptr[i + 1] {
                let j = col_idx[k] as usize;
                let pj = if j == i { pi } else { self.projector(j) };
                if pi.is_none() && pj.is_none() {
                    continue;
                }
                let k = k - base;
                let mut b = vals[k];
                if let Some(pi) = &pi {
                    b = block::mul(pi, &b);
                }
                if let Some(pj) = &pj {
                    b = block::mul(&b, pj);
                }
                if j == i
                    && let Some(pi) = &pi
                {
                    let s = (vals[k][0][0] + vals[k][1][1] + vals[k][2][2]) / 3.0;
                    for r in 0..3 {
                        for c in 0..3 {
                            let id = if r == c { 1.0 } else { 0.0 };
                            b[r][c] += s * (id - pi[r][c]);
                        }
                    }
                }
                vals[k] = b;
            }
        }
    }

    /// The largest violation `max |d_k . x_p - c_k|` over all constraints.
    pub fn violation(&self, x: &[f64]) -> f64 {
        let mut worst = 0.0_f64;
        for e in &self.entries {
            let xp = &x[3 * e.particle..3 * e.particle + 3];
            for k in 0..e.count {
                let d = &e.dirs[k];
                worst = worst.max((d[0] * xp[0] + d[1] * xp[1] + d[2] * xp[2] - e.values[k]).abs());
            }
        }
        worst
    }
}

fn dot3(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn norm3(a: &[f64; 3]) -> f64 {
    dot3(a, a).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `P A P` checked entry by entry on dense matrices (the filter's
    /// definition), and the complement decoupled and positive definite.
    #[test]
    fn the_filtered_matrix_acts_as_p_a_p_on_the_free_directions() {
        let a =
            SymBlockMatrix::from_csr(&hookean_testkit::random::random_spd(12, 4, 1.2, 7)).unwrap();
        let mut c = Constraints::new(4);
        c.pin(1, [0.5, 0.0, 0.0]).unwrap();
        c.constrain(3, [1.0, 2.0, 2.0], 0.3).unwrap();
        let mut f = a.clone();
        c.filter_matrix(&mut f);
        let dense = |m: &SymBlockMatrix| {
            let mut d = vec![[0.0; 12]; 12];
            for (k, row) in d.iter_mut().enumerate() {
                let mut e = vec![0.0; 12];
                e[k] = 1.0;
                let mut y = vec![0.0; 12];
                m.mul_vec(&e, &mut y).unwrap();
                row.copy_from_slice(&y); // column k (the matrix is symmetric)
            }
            d
        };
        let (da, df) = (dense(&a), dense(&f));
        // The filter P as a dense matrix: I except the constrained blocks.
        let mut p = [[0.0; 12]; 12];
        for (i, row) in p.iter_mut().enumerate() {
            row[i] = 1.0;
        }
        let n3 = [1.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0];
        for r in 0..3 {
            for q in 0..3 {
                p[3 + r][3 + q] = 0.0;
                p[9 + r][9 + q] -= n3[r] * n3[q];
            }
        }
        let mul = |x: &[[f64; 12]; 12], y: &[[f64; 12]; 12]| {
            let mut z = [[0.0; 12]; 12];
            for i in 0..12 {
                for j in 0..12 {
                    z[i][j] = (0..12).map(|k| x[i][k] * y[k][j]).sum();
                }
            }
            z
        };
        let mut dfa = [[0.0; 12]; 12];
        for i in 0..12 {
            dfa[i].copy_from_slice(&da[i]);
        }
        let pap = mul(&mul(&p, &dfa), &p);
        let mut dff = [[0.0; 12]; 12];
        for i in 0..12 {
            dff[i].copy_from_slice(&df[i]);
        }
        let pfp = mul(&mul(&p, &dff), &p);
        let mut q = [[0.0; 12]; 12];
        for i in 0..12 {
            for j in 0..12 {
                q[i][j] = if i == j { 1.0 } else { 0.0 } - p[i][j];
            }
        }
        // P F (I - P) = 0: the constrained directions are decoupled.
        let pfq = mul(&mul(&p, &dff), &q);
        for i in 0..12 {
            for j in 0..12 {
                approx::assert_abs_diff_eq!(pfp[i][j], pap[i][j], epsilon = 1e-12);
                approx::assert_abs_diff_eq!(pfq[i][j], 0.0, epsilon = 1e-12);
            }
        }
        // The pinned particle's block: the mean of its diagonal times I.
        let s = (da[3][3] + da[4][4] + da[5][5]) / 3.0;
        for r in 0..3 {
            for q in 0..12 {
                let want = if q == 3 + r { s } else { 0.0 };
                approx::assert_abs_diff_eq!(df[3 + r][q], want, epsilon = 1e-12);
            }
        }
        // Unconstrained blocks between free particles are untouched.
        assert_eq!(df[0][6], da[0][6]);
        assert_eq!(df[6][7], da[6][7]);
    }

    /// On a matrix large enough to be split into row parts, every
    /// stored block of the filtered matrix is `P_i B P_j` plus, on the
    /// diagonal of a constrained particle, `s (I - P_i)` (`P` formed here
    /// from the unit directions given), and the bits are the same for 1 to
    /// 4 threads.
    #[test]
    fn the_threaded_filter_is_the_blockwise_formula_for_every_thread_count() {
        let a =
            SymBlockMatrix::from_csr(&hookean_testkit::random::random_spd(3 * 3600, 8, 1.2, 11))
                .unwrap();
        let n = a.n_blocks();
        assert!(n >= 3 * crate::par::MIN_PARALLEL_BLOCKS / 2);
        let s2 = std::f64::consts::FRAC_1_SQRT_2;
        let mut c = Constraints::new(n);
        let mut dirs: Vec<Vec<[f64; 3]>> = vec![Vec::new(); n];
        for p in (0..n).filter(|p| p % 5 == 1 || p % 7 == 3) {
            let d: &[[f64; 3]] = match p % 3 {
                0 => &[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
                1 => &[[0.0, s2, s2]],
                _ => &[[s2, -s2, 0.0], [0.0, 0.0, 1.0]],
            };
            for e in d {
                c.constrain(p, *e, 0.0).unwrap();
            }
            dirs[p] = d.to_vec();
        }
        let filtered = |threads: usize| {
            let mut f = a.clone();
            crate::par::in_pool(threads, || c.filter_matrix(&mut f));
            f
        };
        let one = filtered(1);
        for threads in [2, 3, 4] {
            assert_eq!(
                filtered(threads).values(),
                one.values(),
                "{threads} threads"
            );
        }
        let proj = |p: usize| {
            let mut m = block::IDENTITY;
            for d in &dirs[p] {
                m = block::add(&m, &block::scale(&block::outer(d, d), -1.0));
            }
            m
        };
        let (row_ptr, col_idx) = (a.pattern().row_ptr(), a.pattern().col_idx());
        for i in 0..n {
            for k in row_ptr[i]..row_ptr[i + 1] {
                let j = col_idx[k] as usize;
                let b = a.values()[k];
                let mut want = block::mul(&block::mul(&proj(i), &b), &proj(j));
                if i == j && !dirs[i].is_empty() {
                    let s = (b[0][0] + b[1][1] + b[2][2]) / 3.0;
                    let q = block::add(&block::IDENTITY, &block::scale(&proj(i), -1.0));
                    want = block::add(&want, &block::scale(&q, s));
                }
                let scale = b.iter().flatten().fold(0.0_f64, |m, v| m.max(v.abs()));
                for r in 0..3 {
                    for q in 0..3 {
                        approx::assert_abs_diff_eq!(
                            one.values()[k][r][q],
                            want[r][q],
                            epsilon = 1e-14 * scale
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn oblique_directions_are_orthonormalised_with_their_values() {
        let mut c = Constraints::new(1);
        c.constrain(0, [1.0, 0.0, 0.0], 2.0).unwrap();
        c.constrain(0, [1.0, 1.0, 0.0], 5.0).unwrap(); // x + y = 5 with x = 2: y = 3
        let mut x = vec![7.0, -1.0, 4.0];
        c.impose(&mut x);
        approx::assert_abs_diff_eq!(x[0], 2.0, epsilon = 1e-15);
        approx::assert_abs_diff_eq!(x[1], 3.0, epsilon = 1e-15);
        assert_eq!(x[2], 4.0);
        assert!(c.violation(&x) < 1e-15);
    }

    #[test]
    fn dependent_zero_and_fourth_directions_are_errors() {
        let mut c = Constraints::new(2);
        assert_eq!(
            c.constrain(0, [0.0; 3], 1.0),
            Err(SparseError::DegenerateConstraint { particle: 0 })
        );
        c.constrain(0, [1.0, 0.0, 0.0], 0.0).unwrap();
        assert_eq!(
            c.constrain(0, [2.0, 0.0, 0.0], 0.0),
            Err(SparseError::DegenerateConstraint { particle: 0 })
        );
        c.pin(1, [0.0; 3]).unwrap();
        assert_eq!(
            c.constrain(1, [0.0, 0.0, 1.0], 0.0),
            Err(SparseError::DegenerateConstraint { particle: 1 })
        );
        assert!(matches!(
            c.constrain(5, [1.0, 0.0, 0.0], 0.0),
            Err(SparseError::BlockIndexOutOfRange { .. })
        ));
        assert!(matches!(
            c.constrain(0, [0.0, f64::NAN, 0.0], 0.0),
            Err(SparseError::NonFinite { .. })
        ));
    }

    #[test]
    fn clear_forgets_everything() {
        let mut c = Constraints::new(2);
        c.pin(1, [1.0, 2.0, 3.0]).unwrap();
        assert_eq!(c.count(1), 3);
        c.clear();
        assert!(c.is_empty());
        assert_eq!(c.count(1), 0);
        let mut v = vec![1.0; 6];
        c.project(&mut v);
        assert_eq!(v, vec![1.0; 6]);
    }
}
