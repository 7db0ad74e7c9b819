//! The implicit-Euler system of the reference drape scene of docs/ARCHITECTURE.md.
//!
//! A square cloth of side 1 m, `n x n` particles, total mass 1 kg lumped
//! uniformly, structural, shear and bend springs; spring force
//! `f_i = k (l - l0) u + d ((v_j - v_i) . u) u`. One backward Euler step in
//! velocity form (Baraff-Witkin) solves
//!
//! `A dv = b`, `A = M - h D - h^2 K`, `b = h (f(x, v) + h K v)`,
//!
//! with `K = df/dx` (definiteness-clamped: `max(0, 1 - l0/l)`) and
//! `D = df/dv`. `A` is symmetric positive definite.
//!
//! This generator stands in until `hookean-massspring` assembles the same
//! system from a real simulation state.

use std::sync::Arc;

use hookean_sparse::{BlockPattern, SymBlockMatrix, block};
use rand::{Rng, SeedableRng, rngs::SmallRng};

/// Parameters of [`cloth_system`]: the reference drape's springs, damping
/// and step (docs/ARCHITECTURE.md; `k`, `d` and `h` default to its values)
/// at `n = 32` with jittered positions. This crate builds the matrix on its
/// own (it cannot use `hookean-massspring`, whose tests use it), so that it
/// is an independent reference for the assembly.
#[derive(Debug, Clone, PartialEq)]
pub struct ClothSystemParams {
    /// Particles per side.
    pub n: usize,
    /// Structural and shear stiffness (N/m); bend springs get `k / 10`.
    pub k: f64,
    /// Spring damping (N s/m).
    pub d: f64,
    /// Time step (s).
    pub h: f64,
    /// Random displacement of each particle, in units of the grid spacing,
    /// so that springs are stretched and compressed. `0` is the rest state.
    pub jitter: f64,
    /// Seed of the displacement.
    pub seed: u64,
}

impl Default for ClothSystemParams {
    fn default() -> Self {
        Self {
            n: 32,
            k: 1e4,
            d: 0.1,
            h: 0.01,
            jitter: 0.1,
            seed: 7,
        }
    }
}

/// A spring of the grid: particles, rest length, stiffness.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridSpring {
    /// First particle.
    pub i: usize,
    /// Second particle.
    pub j: usize,
    /// Rest length (m).
    pub rest: f64,
    /// Stiffness (N/m).
    pub k: f64,
}

/// Structural (grid neighbours), shear (diagonals) and bend (two apart)
/// springs of an `n x n` grid of side 1 m; particle `(x, y)` has index `y n + x`.
pub fn grid_springs(n: usize, k: f64) -> Vec<GridSpring> {
    let s = 1.0 / (n.max(2) - 1) as f64;
    let id = |x: usize, y: usize| y * n + x;
    let mut springs = Vec::new();
    for y in 0..n {
        for x in 0..n {
            if x + 1 < n {
                springs.push(GridSpring {
                    i: id(x, y),
                    j: id(x + 1, y),
                    rest: s,
                    k,
                });
            }
            if y + 1 < n {
                springs.push(GridSpring {
                    i: id(x, y),
                    j: id(x, y + 1),
                    rest: s,
                    k,
                });
            }
            if x + 1 < n && y + 1 < n {
                let rest = s * std::f64::consts::SQRT_2;
                springs.push(GridSpring {
                    i: id(x, y),
                    j: id(x + 1, y + 1),
                    rest,
                    k,
                });
                springs.push(GridSpring {
                    i: id(x + 1, y),
                    j: id(x, y + 1),
                    rest,
                    k,
                });
            }
            if x + 2 < n {
                springs.push(GridSpring {
                    i: id(x, y),
                    j: id(x + 2, y),
                    rest: 2.0 * s,
                    k: k / 10.0,
                });
            }
            if y + 2 < n {
                springs.push(GridSpring {
                    i: id(x, y),
                    j: id(x, y + 2),
                    rest: 2.0 * s,
                    k: k / 10.0,
                });
            }
        }
    }
    springs
}

/// Positions of the cloth in the horizontal plane `z = 0`, displaced by
/// `jitter` grid spacings at random (deterministic in `seed`).
pub fn grid_positions(n: usize, jitter: f64, seed: u64) -> Vec<f64> {
    let s = 1.0 / (n.max(2) - 1) as f64;
    let mut rng = SmallRng::seed_from_u64(seed);
    let mut x = Vec::with_capacity(3 * n * n);
    for y in 0..n {
        for xi in 0..n {
            let mut d = [0.0; 3];
            for c in &mut d {
                *c = jitter * s * (rng.random::<f64>() - 0.5) * 2.0;
            }
            x.push(xi as f64 * s + d[0]);
            x.push(y as f64 * s + d[1]);
            x.push(d[2]);
        }
    }
    x
}

/// The system `A dv = b` of one implicit Euler step from rest (`v = 0`)
/// under gravity, with the clamped stiffness matrix. Returns `(A, b)`.
pub fn cloth_system(p: &ClothSystemParams) -> (SymBlockMatrix, Vec<f64>) {
    let n2 = p.n * p.n;
    let springs = grid_springs(p.n, p.k);
    let x = grid_positions(p.n, p.jitter, p.seed);
    let pattern = Arc::new(
        BlockPattern::new(n2, springs.iter().map(|s| (s.i, s.j)))
            .expect("grid indices are in range"),
    );
    let mut a = SymBlockMatrix::new(pattern);
    let mass = 1.0 / n2 as f64;
    let mut f = vec![0.0; 3 * n2];
    for c in 0..n2 {
        f[3 * c + 2] = -9.81 * mass;
    }
    let (h, d) = (p.h, p.d);
    for s in &springs {
        let xi = &x[3 * s.i..3 * s.i + 3];
        let xj = &x[3 * s.j..3 * s.j + 3];
        let e = [xj[0] - xi[0], xj[1] - xi[1], xj[2] - xi[2]];
        let l = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
        let u = [e[0] / l, e[1] / l, e[2] / l];
        for c in 0..3 {
            let fc = s.k * (l - s.rest) * u[c];
            f[3 * s.i + c] += fc;
            f[3 * s.j + c] -= fc;
        }
        // K_ij = k [max(0, 1 - l0/l)(I - u u^T) + u u^T], D_ij = d u u^T;
        // A_ij = -h D_ij - h^2 K_ij, A_ii += h D_ij + h^2 K_ij.
        let uu = block::outer(&u, &u);
        let t = (1.0 - s.rest / l).max(0.0);
        let mut kij = block::scale(&block::add(&block::IDENTITY, &block::scale(&uu, -1.0)), t);
        kij = block::scale(&block::add(&kij, &uu), s.k);
        let coupling = block::add(&block::scale(&uu, h * d), &block::scale(&kij, h * h));
        a.add_to_block(s.i, s.i, &coupling).expect("in pattern");
        a.add_to_block(s.j, s.j, &coupling).expect("in pattern");
        a.add_to_block(s.i, s.j, &block::scale(&coupling, -1.0))
            .expect("in pattern");
    }
    a.add_to_diagonal(&vec![mass; 3 * n2])
        .expect("length 3 n^2");
    let b: Vec<f64> = f.iter().map(|fi| h * fi).collect();
    (a, b)
}

/// The block pattern of the springs' Jacobians on `n_particles` particles.
pub fn spring_pattern(n_particles: usize, springs: &[GridSpring]) -> Arc<BlockPattern> {
    Arc::new(
        BlockPattern::new(n_particles, springs.iter().map(|s| (s.i, s.j)))
            .expect("spring indices are in range"),
    )
}

/// Adds the spring forces of the spring law of docs/ARCHITECTURE.md to `f` (does not zero it):
/// `f_i += k (l - l0) u + d ((v_j - v_i) . u) u`, `f_j -= ` the same.
pub fn add_spring_forces(springs: &[GridSpring], d: f64, x: &[f64], v: &[f64], f: &mut [f64]) {
    for s in springs {
        let (i, j) = (3 * s.i, 3 * s.j);
        let e = [x[j] - x[i], x[j + 1] - x[i + 1], x[j + 2] - x[i + 2]];
        let l = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
        let u = [e[0] / l, e[1] / l, e[2] / l];
        let dv = [v[j] - v[i], v[j + 1] - v[i + 1], v[j + 2] - v[i + 2]];
        let vr = dv[0] * u[0] + dv[1] * u[1] + dv[2] * u[2];
        let mag = s.k * (l - s.rest) + d * vr;
        for c in 0..3 {
            f[i + c] += mag * u[c];
            f[j + c] -= mag * u[c];
        }
    }
}

/// Adds the spring Jacobians `df/dx` and `df/dv` (the blocks of docs/ARCHITECTURE.md) to
/// `dfdx` and `dfdv` (on [`spring_pattern`]; not zeroed here):
/// `K_ij = k [t (I - u u^T) + u u^T]` with `t = max(0, 1 - l0/l)` when
/// `clamp` (SPD system) or `t = 1 - l0/l` (exact), `D_ij = d u u^T`,
/// `df_i/dx_i = -sum_j K_ij`. The damping force's dependence on `x` is
/// neglected, as usual in cloth simulation.
pub fn add_spring_jacobians(
    springs: &[GridSpring],
    d: f64,
    x: &[f64],
    clamp: bool,
    dfdx: &mut SymBlockMatrix,
    dfdv: &mut SymBlockMatrix,
) {
    for s in springs {
        let (i, j) = (3 * s.i, 3 * s.j);
        let e = [x[j] - x[i], x[j + 1] - x[i + 1], x[j + 2] - x[i + 2]];
        let l = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
        let u = [e[0] / l, e[1] / l, e[2] / l];
        let uu = block::outer(&u, &u);
        let mut t = 1.0 - s.rest / l;
        if clamp {
            t = t.max(0.0);
        }
        let mut kij = block::scale(&block::add(&block::IDENTITY, &block::scale(&uu, -1.0)), t);
        kij = block::scale(&block::add(&kij, &uu), s.k);
        let dij = block::scale(&uu, d);
        add_coupling(dfdx, s.i, s.j, &kij);
        add_coupling(dfdv, s.i, s.j, &dij);
    }
}

/// Adds the tutorial's linearised Jacobians (eq. 50): per spring the
/// isotropic blocks `df_i/dx_j = k I` and `df_i/dv_j = d I` (and minus
/// their sums on the diagonal). Our `k` is in N/m; the paper's
/// `k_ij / l_ij^2` is its per-squared-length constant. They do not depend
/// on the state.
pub fn add_linearized_jacobians(
    springs: &[GridSpring],
    d: f64,
    dfdx: &mut SymBlockMatrix,
    dfdv: &mut SymBlockMatrix,
) {
    for s in springs {
        add_coupling(dfdx, s.i, s.j, &block::scale(&block::IDENTITY, s.k));
        add_coupling(dfdv, s.i, s.j, &block::scale(&block::IDENTITY, d));
    }
}

/// `(i, j) += b`, `(j, i) += b^T`, `(i, i) -= b`, `(j, j) -= b` (b symmetric).
fn add_coupling(m: &mut SymBlockMatrix, i: usize, j: usize, b: &block::Block3) {
    let minus = block::scale(b, -1.0);
    m.add_to_block(i, j, b).expect("spring in pattern");
    m.add_to_block(i, i, &minus).expect("diagonal in pattern");
    m.add_to_block(j, j, &minus).expect("diagonal in pattern");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spring_jacobians_match_finite_differences() {
        let n = 4;
        let springs = grid_springs(n, 1e3);
        let x = grid_positions(n, 0.2, 3);
        let v: Vec<f64> = (0..x.len()).map(|i| (i as f64 * 0.37).sin()).collect();
        let pattern = spring_pattern(n * n, &springs);
        let mut k = SymBlockMatrix::new(pattern.clone());
        let mut dd = SymBlockMatrix::new(pattern);
        add_spring_jacobians(&springs, 0.0, &x, false, &mut k, &mut dd);
        let kd = k.to_csr();
        let eps = 1e-7;
        let mut f0 = vec![0.0; x.len()];
        add_spring_forces(&springs, 0.0, &x, &v, &mut f0);
        for c in [0, 5, 17, 30] {
            let mut xp = x.clone();
            xp[c] += eps;
            let mut f1 = vec![0.0; x.len()];
            add_spring_forces(&springs, 0.0, &xp, &v, &mut f1);
            for r in 0..x.len() {
                let fd = (f1[r] - f0[r]) / eps;
                let an = kd.get(r, c).copied().unwrap_or(0.0);
                assert!(
                    (fd - an).abs() < 1e-3 * (1.0 + an.abs()),
                    "({r},{c}): {fd} vs {an}"
                );
            }
        }
    }

    #[test]
    fn spring_counts_of_the_grid() {
        // n(n-1) per direction structural, 2 (n-1)^2 shear, 2 n (n-2) bend.
        let n = 5;
        let s = grid_springs(n, 1.0);
        assert_eq!(
            s.len(),
            2 * n * (n - 1) + 2 * (n - 1) * (n - 1) + 2 * n * (n - 2)
        );
    }

    #[test]
    fn system_is_symmetric_with_positive_diagonal() {
        let (a, b) = cloth_system(&ClothSystemParams {
            n: 6,
            ..Default::default()
        });
        assert_eq!(b.len(), a.dim());
        let csr = a.to_csr();
        for (&v, (r, c)) in csr.iter() {
            assert_eq!(v, *csr.get(c, r).unwrap());
            if r == c {
                assert!(v > 0.0);
            }
        }
    }
}
