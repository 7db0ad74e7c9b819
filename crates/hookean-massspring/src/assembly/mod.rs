//! Forces and Jacobians: the hot loops, and the
//! [`SecondOrderProblem`](hookean_problem::SecondOrderProblem) implementation.
//!
//! Spring `(i, j, l0, k, d)`, `u = (x_j - x_i) / l`, `l = |x_j - x_i|`,
//! `dv = v_j - v_i` (docs/ARCHITECTURE.md):
//!
//! - force on `i`: `f_i = k (l - l0) u + d (dv . u) u` (projected damping)
//!   or `+ d dv` (incorrect damping); `f_j = -f_i`;
//! - stiffness block `K_ij = df_i/dx_j = k [ a (I - u u^T) + u u^T ]`,
//!   `a = 1 - l0/l` (exact) or `max(0, 1 - l0/l)` (clamped),
//!   `df_i/dx_i = -sum_j K_ij`;
//! - damping blocks `df_i/dv_j = d u u^T` (projected) or `d I` (incorrect);
//! - projected damping's position derivative
//!   `G = d/l [ (u . dv)(I - u u^T) + u w^T ]`, `w = (I - u u^T) dv`, which
//!   enters `df_i/dx_j` and `df_j/dx_i` alike (not transposed): see
//!   [`DampingInDfdx`] and [`MassSpringModel::dfdx_exact`].
//!
//! One file per idea: [`plan`] holds the layout ([`AssemblyPlan`]), [`sweep`]
//! the hot kernel and its SIMD/rayon dispatch, [`energy`] the springs'
//! energy in the sweep's chunked form, [`linearized`] the eq. 50
//! linearisations, [`exact`] the exact `dfdx` as `sprs`, and [`problem`] the
//! checked entry points and the `SecondOrderProblem` implementation. This
//! file holds the per-spring block formulas above, shared by all of them.

mod energy;
mod exact;
mod linearized;
mod plan;
mod problem;
mod sweep;

pub(crate) use plan::*;
pub(crate) use sweep::*;

use hookean_sparse::block::{self, Block3};
use nalgebra::Vector3;

/// `k [ a I + (1 - a) u u^T ]` = `k [ a (I - u u^T) + u u^T ]`.
#[inline(always)]
fn stiffness_block(k: f64, a: f64, u: &Vector3<f64>) -> Block3 {
    let b = k * (1.0 - a);
    let c = k * a;
    let mut m = [[0.0; 3]; 3];
    for r in 0..3 {
        for s in 0..3 {
            m[r][s] = b * u[r] * u[s];
        }
        m[r][r] += c;
    }
    m
}

/// `G = d/l [ (u . dv)(I - u u^T) + u w^T ]`, `w = dv - (u . dv) u`.
#[inline(always)]
fn damping_position_block(d: f64, l: f64, u: &Vector3<f64>, dv: &Vector3<f64>) -> Block3 {
    let s = d / l;
    let ud = u.dot(dv);
    let w = dv - u * ud;
    let mut m = [[0.0; 3]; 3];
    for r in 0..3 {
        for c in 0..3 {
            let delta = if r == c { 1.0 } else { 0.0 };
            m[r][c] = s * (ud * (delta - u[r] * u[c]) + u[r] * w[c]);
        }
    }
    m
}

#[inline(always)]
fn neg(a: &Block3) -> Block3 {
    block::scale(a, -1.0)
}

/// The 6 unique entries of a symmetric block.
#[inline(always)]
fn sym6(b: &Block3) -> [f64; 6] {
    [b[0][0], b[0][1], b[0][2], b[1][1], b[1][2], b[2][2]]
}

/// The symmetric block of 6 unique entries.
#[inline(always)]
fn unsym6(a: &[f64]) -> Block3 {
    [[a[0], a[1], a[2]], [a[1], a[3], a[4]], [a[2], a[4], a[5]]]
}

/// Writes a spring's symmetric block `b` (`df_i/dx_j`, before projection,
/// given by its 6 unique entries `b6`):
/// the off-diagonal block is assigned (first spring of its pair) or added,
/// and `-b` (projected: `-P_i b P_i`, `-P_j b P_j`) is accumulated into the
/// diagonal accumulators at offset `at` (0: `df/dx`, 6: `df/dv`): `loc` of
/// the row's particle `min(i, j)`, `acc_c` of the other one.
#[inline(always)]
fn scatter_sym(
    vals: &mut [Block3],
    base: usize,
    loc: &mut [f64; 12],
    acc_c: &mut [f64; 12],
    at: usize,
    h: &HotSpring,
    constrained: bool,
    proj: &[Block3],
    b6: &[f64; 6],
) {
    let (i, j) = (h.i as usize, h.j as usize);
    let (off, di, dj) = if constrained {
        let b = &unsym6(b6);
        let (pi, pj) = (&proj[i], &proj[j]);
        let pb = block::mul(pi, b);
        let off = block::mul(&pb, pj);
        (
            off,
            sym6(&block::mul(&pb, pi)),
            sym6(&block::mul(&block::mul(pj, b), pj)),
        )
    } else {
        (unsym6(b6), *b6, *b6)
    };
    if h.first {
        vals[h.upper as usize - base] = off;
    } else {
        let t = &mut vals[h.upper as usize - base];
        for r in 0..3 {
            for c in 0..3 {
                t[r][c] += off[r][c];
            }
        }
    }
    // The row's own particle is i < j.
    let (dr, dc) = (di, dj);
    for t in 0..6 {
        loc[at + t] -= dr[t];
        acc_c[at + t] -= dc[t];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hookean_problem::SecondOrderProblem;
    use hookean_sparse::SymBlockMatrix;

    use crate::model::{DampingInDfdx, MassSpringModel, SpringDamping, point};
    use crate::{ClothParams, ModelOptions, Spring, cloth};
    use rand::rngs::SmallRng;
    use rand::{Rng, SeedableRng};

    /// A 7 x 6 cloth, its bottom-left corner pinned, its top-right corner
    /// sliding along a line, particle 12 in the plane `z = const`, one
    /// spring duplicated (with other material), compressed by 10% and
    /// shaken, with random velocities.
    fn scene(options: ModelOptions) -> (MassSpringModel, Vec<f64>, Vec<f64>) {
        scene_sized(options, 7, 6)
    }

    /// [`scene`] on an `nu x nv` cloth.
    fn scene_sized(
        options: ModelOptions,
        nu: usize,
        nv: usize,
    ) -> (MassSpringModel, Vec<f64>, Vec<f64>) {
        let (base, state) = cloth(&ClothParams {
            nu,
            nv,
            ..Default::default()
        })
        .unwrap();
        let mut springs = base.springs().to_vec();
        let s0 = springs[5];
        springs.push(Spring::new(s0.j, s0.i, 0.8 * s0.rest_length, 3e3, 0.3));
        let mut model =
            MassSpringModel::new(base.particle_masses().to_vec(), springs, options).unwrap();
        let n = model.n_particles();
        let mut rng = SmallRng::seed_from_u64(0x2545_F491_4F6C_DD1D);
        let x: Vec<f64> = (state.x.iter())
            .map(|&c| 0.9 * c + 0.02 * rng.random_range(-0.5..0.5))
            .collect();
        let v: Vec<f64> = (0..3 * n).map(|_| rng.random_range(-0.5..0.5)).collect();
        model.pin(0, [x[0], x[1], x[2]]).unwrap();
        let p = n - 1;
        let at = [x[3 * p], x[3 * p + 1], x[3 * p + 2]];
        model.constrain_direction(p, [1.0, 0.0, 0.0], at).unwrap();
        model.constrain_direction(p, [0.0, 1.0, 1.0], at).unwrap();
        model
            .constrain_direction(12, [0.0, 0.0, 1.0], [x[36], x[37], x[38]])
            .unwrap();
        (model, x, v)
    }

    /// Assembles `(f, df/dx, df/dv)` into garbage-filled outputs.
    fn run(
        model: &MassSpringModel,
        x: &[f64],
        v: &[f64],
        mode: AssemblyMode,
        fast: bool,
    ) -> (Vec<f64>, SymBlockMatrix, SymBlockMatrix) {
        let (mut dx, mut dv) = model.new_jacobians();
        let mut f = vec![f64::NAN; x.len()];
        // Start from garbage: every block must be overwritten.
        dx.values_mut().fill([[7.0; 3]; 3]);
        dv.values_mut().fill([[7.0; 3]; 3]);
        model.assemble_paths(x, v, Some(&mut f), &mut dx, Some(&mut dv), mode, fast, None);
        (f, dx, dv)
    }

    /// The row flags are consistent with the constraints: skipping the
    /// constrained look-ups on fast rows changes nothing (against every row
    /// checked, on a fresh copy of the model); a repeated call on the same
    /// scratch gives the same bits (the scratch is left zeroed).
    fn assert_paths_agree(model: &MassSpringModel, x: &[f64], v: &[f64], mode: AssemblyMode) {
        let first = run(model, x, v, mode, true);
        let (fa, xa, va) = run(model, x, v, mode, true);
        assert_eq!(first.0, fa);
        assert_eq!(first.1.values(), xa.values());
        assert_eq!(first.2.values(), va.values());
        let checked = run(&model.clone(), x, v, mode, false);
        assert_round_off(&(fa, xa, va), &checked, &format!("{mode:?}"));
    }

    /// Two assemblies `(f, df/dx, df/dv)` agree to round-off: `1e-12`
    /// relative for `f`, `1e-12` of the largest `df/dx` entry for the blocks.
    fn assert_round_off(
        a: &(Vec<f64>, SymBlockMatrix, SymBlockMatrix),
        b: &(Vec<f64>, SymBlockMatrix, SymBlockMatrix),
        what: &str,
    ) {
        let scale = (b.1.values().iter().flatten().flatten()).fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(scale > 1e3);
        for (u, w) in a.0.iter().zip(&b.0) {
            assert!(
                (u - w).abs() <= 1e-12 * (1.0 + w.abs()),
                "{what}: f {u} vs {w}"
            );
        }
        for (ma, mb) in [(&a.1, &b.1), (&a.2, &b.2)] {
            let pairs = (ma.values().iter().flatten().flatten())
                .zip(mb.values().iter().flatten().flatten());
            for (u, w) in pairs {
                assert!((u - w).abs() <= 1e-12 * scale, "{what}: {u} vs {w}");
            }
        }
    }

    /// The threaded sweep (row parts, halos added afterwards in part order)
    /// sums the same terms as the serial one in another order: equal to
    /// round-off, and bitwise repeatable for a given thread count.
    #[test]
    fn threaded_assembly_agrees_with_the_serial_sweep_and_repeats_its_bits() {
        let (model, x, v) = scene_sized(ModelOptions::default(), 50, 48);
        assert!(model.n_particles() >= hookean_sparse::par::MIN_PARALLEL_BLOCKS);
        let pool = |t: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .unwrap()
        };
        for mode in [
            AssemblyMode {
                clamp: true,
                damping_in_dfdx: DampingInDfdx::Drop,
            },
            AssemblyMode {
                clamp: false,
                damping_in_dfdx: DampingInDfdx::Symmetrize,
            },
        ] {
            let serial = pool(1).install(|| run(&model, &x, &v, mode, true));
            for threads in [2, 3] {
                let p = pool(threads);
                let (fa, xa, va) = p.install(|| run(&model, &x, &v, mode, true));
                let again = p.install(|| run(&model, &x, &v, mode, true));
                assert_eq!(
                    (&fa, xa.values(), va.values()),
                    (&again.0, again.1.values(), again.2.values())
                );
                assert_round_off(&(fa, xa, va), &serial, &format!("{threads} threads"));
            }
        }
    }

    /// The one-sweep Newton matrix is `M + a df/dx + b df/dv` formed from
    /// the separately assembled Jacobians, to round-off, for every damping
    /// law, damping-in-`df/dx` choice, clamp, thread count, with
    /// constraints (pins, directions) and air friction; and a second call
    /// gives the same bits (the scratch is left zeroed).
    #[test]
    fn one_sweep_step_matrix_is_the_combination_of_the_jacobians() {
        let (gh_a, gh_b) = (-1e-4, -1e-2);
        for damping in [
            SpringDamping::Projected,
            SpringDamping::Incorrect,
            SpringDamping::None,
        ] {
            for damping_in_dfdx in [DampingInDfdx::Drop, DampingInDfdx::Symmetrize] {
                if damping_in_dfdx == DampingInDfdx::Symmetrize
                    && damping != SpringDamping::Projected
                {
                    continue;
                }
                for clamp in [true, false] {
                    let options = ModelOptions {
                        damping,
                        air_friction: 0.3,
                        ..ModelOptions::default()
                    };
                    let (model, x, v) = scene_sized(options, 50, 48);
                    let mode = AssemblyMode {
                        clamp,
                        damping_in_dfdx,
                    };
                    for threads in [1, 2] {
                        let pool = rayon::ThreadPoolBuilder::new()
                            .num_threads(threads)
                            .build()
                            .unwrap();
                        pool.install(|| {
                            let (_, dx, dv) = run(&model, &x, &v, mode, true);
                            let mut expected = SymBlockMatrix::new(dx.pattern().clone());
                            expected
                                .assign_diagonal_plus_combination(&model.mass, gh_a, &dx, gh_b, &dv)
                                .unwrap();
                            let mut fused = SymBlockMatrix::new(dx.pattern().clone());
                            fused.values_mut().fill([[7.0; 3]; 3]);
                            model.assemble_step_matrix(&x, &v, gh_a, gh_b, &mut fused, mode);
                            let scale = expected
                                .values()
                                .iter()
                                .flatten()
                                .flatten()
                                .fold(0.0f64, |m, w| m.max(w.abs()));
                            let pairs = (fused.values().iter().flatten().flatten())
                                .zip(expected.values().iter().flatten().flatten());
                            for (u, w) in pairs {
                                assert!(
                                    (u - w).abs() <= 1e-13 * scale,
                                    "{damping:?} {damping_in_dfdx:?} clamp {clamp}, {threads} threads: {u} vs {w}"
                                );
                            }
                            let mut again = SymBlockMatrix::new(dx.pattern().clone());
                            model.assemble_step_matrix(&x, &v, gh_a, gh_b, &mut again, mode);
                            assert_eq!(again.values(), fused.values());
                        });
                    }
                }
            }
        }
    }

    /// The force-only evaluation is the fused sweep without its Jacobian
    /// half: for every damping law and thread count (1: serial; 2, 3: row
    /// parts and halos) its `f` has the fused sweep's bits, and a coincident
    /// pair of particles gives no force and no NaN.
    #[test]
    fn force_only_sweep_has_the_fused_sweeps_bits_for_every_thread_count() {
        for damping in [
            SpringDamping::Projected,
            SpringDamping::Incorrect,
            SpringDamping::None,
        ] {
            let options = ModelOptions {
                damping,
                ..ModelOptions::default()
            };
            let (model, mut x, v) = scene_sized(options, 50, 48);
            // Particles 1 and 2 at the same place.
            let (a, b) = x.split_at_mut(6);
            b[..3].copy_from_slice(&a[3..6]);
            let mode = AssemblyMode {
                clamp: true,
                damping_in_dfdx: DampingInDfdx::Drop,
            };
            for threads in [1, 2, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let (fused, only) = pool.install(|| {
                    let (fused, _, _) = run(&model, &x, &v, mode, true);
                    let mut only = vec![f64::NAN; x.len()];
                    model.eval_force(&x, &v, &mut only);
                    (fused, only)
                });
                assert!(only.iter().all(|f| f.is_finite()), "{damping:?}, {threads}");
                assert_eq!(fused, only, "{damping:?}, {threads} threads");
            }
        }
    }

    #[test]
    fn fast_rows_equal_checked_rows_with_constraints_duplicates_and_compression() {
        for damping in [
            SpringDamping::Projected,
            SpringDamping::Incorrect,
            SpringDamping::None,
        ] {
            for damping_in_dfdx in [DampingInDfdx::Drop, DampingInDfdx::Symmetrize] {
                for clamp in [true, false] {
                    let options = ModelOptions {
                        damping,
                        damping_in_dfdx,
                        clamp_stiffness: clamp,
                        air_friction: 0.3,
                        ..Default::default()
                    };
                    let (model, x, v) = scene(options);
                    let rows = model.plan.row_fast.iter().filter(|&&b| b).count();
                    assert!(rows > 10 && rows < model.n_particles());
                    // Compressed springs: the clamp is active somewhere.
                    let compressed = model
                        .springs()
                        .iter()
                        .filter(|s| (point(&x, s.j) - point(&x, s.i)).norm() < s.rest_length)
                        .count();
                    assert!(compressed > 10);
                    let mode = AssemblyMode {
                        clamp,
                        damping_in_dfdx,
                    };
                    assert_paths_agree(&model, &x, &v, mode);
                }
            }
        }
    }

    #[test]
    fn row_flags_follow_pins_releases_and_contacts() {
        let (mut model, mut x, mut v) = scene(ModelOptions::default());
        let mode = AssemblyMode {
            clamp: true,
            damping_in_dfdx: DampingInDfdx::Drop,
        };
        let slow = |m: &MassSpringModel| m.plan.row_fast.iter().filter(|&&b| !b).count();
        let before = slow(&model);
        // Releasing the sliding particle 12 frees its rows.
        model.release(12).unwrap();
        assert!(model.plan.row_fast[12] && model.plan.row_fast[11]);
        assert!(slow(&model) < before);
        assert_paths_agree(&model, &x, &v, mode);
        // Pinning an interior particle flags its row and the rows of its
        // lower neighbours.
        assert!(model.plan.row_fast[20] && model.plan.row_fast[19] && model.plan.row_fast[13]);
        model.pin(20, [x[60], x[61], x[62]]).unwrap();
        assert!(!model.plan.row_fast[20] && !model.plan.row_fast[19] && !model.plan.row_fast[13]);
        assert_paths_agree(&model, &x, &v, mode);
        // A collider: contacts of begin_step flag rows, the next step with
        // no contact unflags them.
        let z = (0..model.n_particles())
            .map(|p| x[3 * p + 2])
            .fold(f64::INFINITY, f64::min);
        model.add_collider(
            crate::Collider::plane([0.0, 0.0, z + 0.01], [0.0, 0.0, 1.0], 0.0).unwrap(),
        );
        let mut c = hookean_sparse::Constraints::new(model.n_particles());
        model.begin_step(0.0, &mut x, &mut v, &mut c);
        assert!(model.contact_count() > 0);
        assert_paths_agree(&model, &x, &v, mode);
    }
}
