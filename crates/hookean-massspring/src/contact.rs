//! What contact is, per step, for the integrator: the one owner of the
//! contact handling of [`MassSpringModel`] (docs/CONTACT.md).
//!
//! - **Before the step** (`begin_step`, the tutorial's section 4.2 and
//!   Baraff and Witkin's filter): a particle within a collider's band is
//!   pushed out (to the surface for planes and spheres, to the thickness for
//!   meshes), its inward normal velocity relative to the surface is removed,
//!   and, unless it separates, its normal is constrained for the step. With
//!   Coulomb friction the impact first takes up to `mu_k |dv_n|` of the
//!   tangential velocity (Bridson et al. 2002, eq. 9); then the tangential
//!   momentum the particle would have after the step without friction,
//!   `q = m v_t + h f_t` (`h` the last step's size), decides: within the
//!   static cone, `|q| <= h mu_s N`, the particle sticks (all three
//!   directions constrained, moving with the surface); outside it, it slides
//!   (the normal force `N = -f . n` at the step's start). Cloth
//!   self-collision finds its proximity pairs here.
//! - **Inside the step**: kinetic friction is the tangential damping force
//!   `-c v_t` with `c = mu_k N / |v_t^pred|`, `|v_t^pred| = (|q| - h mu_k
//!   N) / m` the tangential speed Coulomb friction leaves at the step's end:
//!   it has the Coulomb magnitude `mu_k N` exactly when the other forces are
//!   constant over the step, is linear in the unknown velocity (Newton needs
//!   no extra iteration for it) and can only brake, never reverse or push, a
//!   particle whose load changes within the step. It and the repulsion of
//!   self-contact pairs are forces of the model
//!   ([`MassSpringModel::add_contact_forces`]) with diagonal Jacobian blocks
//!   ([`MassSpringModel::add_contact_jacobians`]).
//! - **After the step** (`end_step`): the continuous passes, mesh colliders
//!   (a particle whose straight path entered a mesh is put back at the
//!   thickness) and cloth self-collision (`self_contact.rs`).

use hookean_sparse::SymBlockMatrix;
use hookean_sparse::block::{self, Block3};
use nalgebra::Vector3;
use rayon::prelude::*;

use crate::collide::{Collider, Touch, touch};
use crate::model::{Dirs, MassSpringModel, point};
use crate::self_contact::SelfContact;

/// Tangential speed (m/s) below which a particle whose tangential force
/// lies in the static cone sticks when no step size is known yet (the first
/// step of a run); afterwards the static cone of the momentum decides.
pub const STICK_SPEED: f64 = 1e-3;

/// The relative normal speed below which a particle counts as moving
/// with a surface, as a fraction of the surface's speed (0 on a static
/// collider): the round-off of `v_s`.
const SEPARATION_ROUND_OFF: f64 = 1e-12;

/// A sliding contact of the current step: the kinetic friction force
/// `-c P_t (v_p - v_s)` on particle `p` (`P_t = I - n n^T`, `v_s` the
/// surface's velocity), a damping in the tangent plane.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Sliding {
    p: usize,
    /// `c = mu_k N / |v_t^pred|` (N s/m).
    c: f64,
    normal: Vector3<f64>,
    surface_velocity: Vector3<f64>,
}

/// What the contact handling did in the last step (counters).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ContactStats {
    /// Particle-collider contacts constrained by the last `begin_step`.
    pub contacts: usize,
    /// Of those, particles sticking (static friction).
    pub sticking: usize,
    /// Of those, particles sliding against kinetic friction.
    pub sliding: usize,
    /// Particles the last mesh pass put back out of a mesh.
    pub mesh_corrections: usize,
    /// Self-contact proximity pairs repelled in the last step.
    pub proximity_pairs: usize,
    /// Impacts found by the last continuous self-collision pass (all rounds).
    pub impacts: usize,
    /// Impact zones made rigid in the last step.
    pub impact_zones: usize,
    /// Self-collision rounds of the last step that needed the fallbacks
    /// beyond rigid zones (translation or rest): normally 0.
    pub fallbacks: usize,
    /// Traversals of the self-collision tree in the last step (rebuilds of
    /// the candidate list, and detections of fast motion): most steps need
    /// none.
    pub traversals: usize,
}

/// The contact state of a model between `begin_step` and `end_step`.
#[derive(Debug, Clone, Default)]
pub(crate) struct ContactState {
    pub(crate) sliding: Vec<Sliding>,
    /// The contacts `begin_step` found, `n_colliders` per particle in
    /// collider order (`None`: outside that collider's band); kept so that
    /// its storage is reused.
    found: Vec<Option<(Touch, f64, f64)>>,
    /// The size of the last accepted step (0 before the first).
    pub(crate) h_last: f64,
    pub(crate) self_contact: Option<Box<SelfContact>>,
    pub(crate) stats: ContactStats,
}

/// A particle at `xp` within a collider's band but closer than `target`
/// (0 for planes and spheres, the thickness for meshes), moved along the
/// contact normal to `target`.
fn pushed_out(xp: &Vector3<f64>, touch: &Touch, target: f64) -> Vector3<f64> {
    let (phi, normal) = (touch.phi, touch.normal);
    if target == 0.0 {
        xp - normal * phi
    } else {
        xp + normal * (target - phi)
    }
}

/// Two unit vectors completing `n` to an orthonormal basis.
fn tangents(n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let trial = if n.x.abs() < 0.6 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let t1 = n.cross(&trial).normalize();
    (t1, n.cross(&t1))
}

impl MassSpringModel {
    /// Steps 1 and 2 of `begin_step`: permanent constraints, then
    /// self-contact pairs, then collider contacts. No allocation once the
    /// lists have grown to their size.
    pub(crate) fn apply_constraints_and_contacts(&mut self, t: f64, x: &mut [f64], v: &mut [f64]) {
        self.pose_colliders(t);
        self.refresh_permanent();
        let n = self.n_particles();
        for p in 0..n {
            let d = self.fixes[p];
            for k in 0..d.count {
                let e = d.dirs[k];
                let xe: f64 = (0..3).map(|r| e[r] * x[3 * p + r]).sum();
                let ve: f64 = (0..3).map(|r| e[r] * v[3 * p + r]).sum();
                for r in 0..3 {
                    x[3 * p + r] -= (xe - d.values[k]) * e[r];
                    v[3 * p + r] -= ve * e[r];
                }
            }
        }
        self.contact.sliding.clear();
        self.contact.stats = ContactStats::default();
        if let Some(sc) = self.contact.self_contact.as_mut() {
            self.contact.stats.proximity_pairs = sc.find_proximity(x);
        }
        if self.colliders.is_empty() {
            return;
        }
        let n_colliders = self.colliders.len();
        let mut found = std::mem::take(&mut self.contact.found);
        if !self.find_contacts(t, x, &mut found) {
            // No particle within a band: nothing below would change.
            self.contact.found = found;
            return;
        }
        // The force with permanent constraints only, to release contacts
        // that the force pulls away from the surface.
        let mut f = std::mem::take(&mut self.scratch);
        self.eval_force(x, v, &mut f);
        for p in 0..n {
            for c in 0..n_colliders {
                let Some((touch, target, _)) = found[p * n_colliders + c] else {
                    continue;
                };
                let (phi, normal) = (touch.phi, touch.normal);
                if phi < target {
                    let y = pushed_out(&point(x, p), &touch, target);
                    x[3 * p..3 * p + 3].copy_from_slice(y.as_slice());
                }
                let vp = point(v, p);
                let vn = (vp - touch.velocity).dot(&normal);
                if vn < 0.0 {
                    let w = vp - normal * vn;
                    v[3 * p..3 * p + 3].copy_from_slice(w.as_slice());
                }
                // Separating: no constraint this step. On a moving surface
                // the relative velocity carries the round-off of the
                // surface's velocity (a few ulps of |v_s|): a particle
                // moving with the surface is not separating.
                let round_off = SEPARATION_ROUND_OFF * touch.velocity.norm();
                if vn > round_off || point(&f, p).dot(&normal) > 0.0 {
                    continue;
                }
                let friction = self.colliders[c].friction();
                let mut dirs: Dirs = self.active_set.dirs[p];
                let moving = [touch.velocity.x, touch.velocity.y, touch.velocity.z];
                if friction.is_none() {
                    if dirs.push([normal.x, normal.y, normal.z], 0.0) {
                        self.active_set.vel[p] = moving;
                        self.activate(p, dirs);
                        self.active_set.contact_count += 1;
                    }
                    continue;
                }
                // Coulomb friction: the normal force N at the step's start,
                // the impulse of the removed normal velocity, the static cone.
                let fp = point(&f, p);
                let f_n = fp.dot(&normal);
                let big_n = (-f_n).max(0.0);
                let mut vrel = point(v, p) - touch.velocity;
                let mut vt = vrel - normal * vrel.dot(&normal);
                let dvn = (-vn).max(0.0);
                let speed = vt.norm();
                if dvn > 0.0 && friction.mu_k > 0.0 && speed > 0.0 {
                    // Bridson et al. 2002, eq. (9): the tangential velocity
                    // loses up to mu |dv_n| in the impact.
                    let k = (friction.mu_k * dvn / speed).min(1.0);
                    vt *= 1.0 - k;
                    vrel = normal * vrel.dot(&normal) + vt;
                    let w = touch.velocity + vrel;
                    v[3 * p..3 * p + 3].copy_from_slice(w.as_slice());
                }
                let ft = fp - normal * f_n;
                let (h, m) = (self.contact.h_last, self.particle_mass[p]);
                let q = vt * m + ft * h;
                let stick = if h > 0.0 {
                    q.norm() <= h * friction.mu_s * big_n
                } else {
                    vt.norm() <= STICK_SPEED && ft.norm() <= friction.mu_s * big_n
                };
                if !dirs.push([normal.x, normal.y, normal.z], 0.0) {
                    continue;
                }
                if stick {
                    let (t1, t2) = tangents(&normal);
                    dirs.push([t1.x, t1.y, t1.z], 0.0);
                    dirs.push([t2.x, t2.y, t2.z], 0.0);
                    let w = touch.velocity;
                    v[3 * p..3 * p + 3].copy_from_slice(w.as_slice());
                    self.contact.stats.sticking += 1;
                } else if friction.mu_k > 0.0 && big_n > 0.0 {
                    // The predicted tangential speed at the step's end,
                    // (|q| - h mu_k N) / m > 0 outside the cone; before the
                    // first step (h unknown) the current speed.
                    let pred = if h > 0.0 {
                        (q.norm() - h * friction.mu_k * big_n) / m
                    } else {
                        vt.norm()
                    };
                    let c = friction.mu_k * big_n / pred.max(STICK_SPEED);
                    if c.is_finite() {
                        self.contact.sliding.push(Sliding {
                            p,
                            c,
                            normal,
                            surface_velocity: touch.velocity,
                        });
                        self.contact.stats.sliding += 1;
                    }
                }
                self.active_set.vel[p] = moving;
                self.activate(p, dirs);
                self.active_set.contact_count += 1;
            }
        }
        self.contact.stats.contacts = self.active_set.contact_count;
        self.scratch = f;
        self.contact.found = found;
    }

    /// The state the next step's contact handling starts from, written in
    /// place: every particle (not pinned in all three directions) that
    /// ended closer to a collider than its target (inside a plane or
    /// sphere, within a mesh's thickness) is pushed out along the contact
    /// normal, and the inward normal velocity relative to the surface of
    /// every particle within a band is removed, as `begin_step` does at
    /// time `t` (docs/CONTACT.md). Friction, which only takes tangential
    /// velocity away, is left out, so the kinetic energy of the result is
    /// an upper bound of the next step's. The energy guard of the facade's
    /// `Simulation` compares the energy of this state with its budget: the
    /// push-out of a particle that ended a step deep inside a collider is
    /// where contact can store energy in the springs. No allocation;
    /// particles are independent (threaded, the same bits for every thread
    /// count).
    pub fn put_back_contacts(&self, t: f64, x: &mut [f64], v: &mut [f64]) {
        if self.colliders.is_empty() {
            return;
        }
        let (colliders, fixes) = (&self.colliders, &self.fixes);
        x.par_chunks_exact_mut(3)
            .zip(v.par_chunks_exact_mut(3))
            .enumerate()
            .for_each(|(p, (xp, vp))| {
                if fixes[p].count == 3 {
                    return;
                }
                for c in colliders {
                    let y = Vector3::from_column_slice(xp);
                    let Some((touch, target, band)) = touch(c, t, &y) else {
                        continue;
                    };
                    if touch.phi.is_nan() || touch.phi > band {
                        continue;
                    }
                    if touch.phi < target {
                        xp.copy_from_slice(pushed_out(&y, &touch, target).as_slice());
                    }
                    let w = Vector3::from_column_slice(vp);
                    let vn = (w - touch.velocity).dot(&touch.normal);
                    if vn < 0.0 {
                        vp.copy_from_slice((w - touch.normal * vn).as_slice());
                    }
                }
            });
    }

    /// The first pass of the collider contacts: for every particle (not
    /// pinned in all three directions) and collider, in collider order, the
    /// contact at the particle's position after the push-outs of the
    /// colliders before (`touch`), kept in `found` where the particle is
    /// within the collider's band. The push-outs do not depend on the force
    /// or the velocities, so this pass sees the positions the second pass
    /// will. Particles are independent: threaded, the same bits for every
    /// thread count; `x` is not changed. True if some particle is within a
    /// band.
    fn find_contacts(&self, t: f64, x: &[f64], found: &mut Vec<Option<(Touch, f64, f64)>>) -> bool {
        let n_colliders = self.colliders.len();
        found.resize(self.n_particles() * n_colliders, None);
        let (colliders, fixes) = (&self.colliders, &self.fixes);
        x.par_chunks_exact(3)
            .zip(found.par_chunks_exact_mut(n_colliders))
            .enumerate()
            .map(|(p, (xp, out))| {
                out.fill(None);
                if fixes[p].count == 3 {
                    return false;
                }
                let mut xp = Vector3::from_column_slice(xp);
                let mut any = false;
                for (c, slot) in colliders.iter().zip(out.iter_mut()) {
                    let Some((touch, target, band)) = touch(c, t, &xp) else {
                        continue;
                    };
                    if touch.phi.is_nan() || touch.phi > band {
                        continue;
                    }
                    if touch.phi < target {
                        xp = pushed_out(&xp, &touch, target);
                    }
                    *slot = Some((touch, target, band));
                    any = true;
                }
                any
            })
            .reduce(|| false, |a, b| a || b)
    }

    /// Adds the contact forces of the step to `f` (before the rows of
    /// constrained particles are projected): kinetic friction of sliding
    /// particles and the repulsion of self-contact pairs. No allocation;
    /// nothing when there is no contact.
    pub(crate) fn add_contact_forces(&self, x: &[f64], v: &[f64], f: &mut [f64]) {
        for s in &self.contact.sliding {
            let vrel = point(v, s.p) - s.surface_velocity;
            let vt = vrel - s.normal * vrel.dot(&s.normal);
            for r in 0..3 {
                f[3 * s.p + r] -= s.c * vt[r];
            }
        }
        if let Some(sc) = &self.contact.self_contact {
            sc.add_forces(x, f);
        }
        self.add_soft_pin_forces(x, f);
    }

    /// Adds `a d(f_c)/dx + b d(f_c)/dv` of the contact forces `f_c` to the
    /// diagonal blocks of `m` (projected for constrained particles, `P_p J
    /// P_p`): kinetic friction is the damping `-c P_t` in the tangent plane;
    /// a self-contact pair adds `-k |w_i| (sum_j |w_j|) n n^T` to each of its
    /// particles' blocks (a diagonal bound of its stiffness: the coupling
    /// blocks between the particles are not on the pattern, so Newton
    /// converges linearly, and monotonically, on them). No allocation.
    pub(crate) fn add_contact_jacobians(&self, x: &[f64], a: f64, b: f64, m: &mut SymBlockMatrix) {
        if b != 0.0 {
            for s in &self.contact.sliding {
                let n = [s.normal.x, s.normal.y, s.normal.z];
                let mut j = block::scale(&block::outer(&n, &n), -1.0);
                for r in 0..3 {
                    j[r][r] += 1.0;
                }
                self.add_to_diagonal_projected(m, s.p, &block::scale(&j, -b * s.c));
            }
        }
        if a != 0.0
            && let Some(sc) = &self.contact.self_contact
        {
            sc.for_each_diagonal_block(x, |p, blk| {
                self.add_to_diagonal_projected(m, p, &block::scale(blk, a));
            });
        }
        if a != 0.0 {
            // Soft pins (handles.rs): d(-k (x_p - y_p))/dx_p = -k I.
            for s in &self.soft_pins {
                self.add_to_diagonal_projected(m, s.p, &block::scale(&block::IDENTITY, -a * s.k));
            }
        }
    }

    /// Poses every deforming mesh collider at time `t` (the queries of a
    /// sequence see its latest pose: `begin_step` poses it at the step's
    /// start, `end_step` at its end). No allocation; a mesh shared with a
    /// clone of the model is copied once.
    fn pose_colliders(&mut self, t: f64) {
        for c in &mut self.colliders {
            if let Collider::Mesh { mesh, .. } = c
                && matches!(mesh.motion(), crate::collide::ColliderMotion::Sequence(_))
            {
                std::sync::Arc::make_mut(mesh).pose_at(t);
            }
        }
    }

    /// `m_pp += P_p j P_p` (`P_p` the projector of the step's constraints).
    fn add_to_diagonal_projected(&self, m: &mut SymBlockMatrix, p: usize, j: &Block3) {
        let j = if self.active_set.constrained[p] {
            let pr = &self.active_set.proj[p];
            block::mul(&block::mul(pr, j), pr)
        } else {
            *j
        };
        let d = self.plan.diag_index[p];
        let vals = m.values_mut();
        vals[d] = block::add(&vals[d], &j);
    }

    /// `end_step`: the continuous passes of the step from `t` to `t + h`
    /// that started at `x_start`. Mesh colliders always; with
    /// self-collision, every collider before and after the self-collision
    /// pass (a plane or sphere left to the next `begin_step` would push the
    /// layer on it through the layers above). True if `x` or `v` changed.
    pub(crate) fn end_contact_step(
        &mut self,
        t: f64,
        h: f64,
        x_start: &[f64],
        x: &mut [f64],
        v: &mut [f64],
    ) -> bool {
        self.contact.h_last = h;
        self.pose_colliders(t + h);
        let has_mesh = self
            .colliders
            .iter()
            .any(|c| matches!(c, Collider::Mesh { .. }));
        let Some(mut sc) = self.contact.self_contact.take() else {
            if !has_mesh {
                return false;
            }
            let corrected = self.collider_pass(t, h, x_start, x, v, false);
            self.contact.stats.mesh_corrections = corrected;
            return corrected > 0;
        };
        let mut corrected = self.collider_pass(t, h, x_start, x, v, true);
        let inv_mass: &dyn Fn(usize) -> f64 = &|p| {
            if self.active_set.dirs[p].count == 3 {
                0.0
            } else {
                1.0 / self.particle_mass[p]
            }
        };
        let proj = |p: usize| self.active_set.constrained[p].then(|| self.active_set.proj[p]);
        let out = sc.resolve(h, x_start, x, v, inv_mass, &proj);
        self.contact.stats.impacts = out.impacts;
        self.contact.stats.impact_zones = out.zones;
        self.contact.stats.fallbacks = out.fallbacks;
        self.contact.stats.traversals = std::mem::take(&mut sc.traversals);
        self.contact.self_contact = Some(sc);
        if out.changed {
            corrected += self.collider_pass(t, h, x_start, x, v, true);
        }
        self.contact.stats.mesh_corrections = corrected;
        out.changed || corrected > 0
    }

    /// Puts back every particle whose straight path from `x_start` entered
    /// a mesh collider (or that ended inside one): at the contact point
    /// pushed out by the thickness, its inward normal velocity relative to
    /// the surface removed; with `analytic`, also particles that ended
    /// inside a plane or sphere (onto the surface). Particles are
    /// independent: threaded, the same bits for every thread count. Returns
    /// the number of corrections.
    fn collider_pass(
        &self,
        t: f64,
        h: f64,
        x_start: &[f64],
        x: &mut [f64],
        v: &mut [f64],
        analytic: bool,
    ) -> usize {
        let colliders = &self.colliders;
        let fixes = &self.fixes;
        x.par_chunks_exact_mut(3)
            .zip(v.par_chunks_exact_mut(3))
            .zip(x_start.par_chunks_exact(3))
            .enumerate()
            .map(|(p, ((xp, vp), a))| {
                if fixes[p].count == 3 {
                    return 0;
                }
                let mut hits = 0;
                for c in colliders {
                    let b = Vector3::from_column_slice(xp);
                    let (y, n, vs) = match c {
                        Collider::Mesh { mesh, .. } => {
                            let a = Vector3::from_column_slice(a);
                            let Some((y, n)) = mesh.correct_path(t, h, &a, &b) else {
                                continue;
                            };
                            (y, n, mesh.surface_velocity(t + h, &y))
                        }
                        _ if analytic => {
                            let (phi, n) = c.signed_distance(&b);
                            if !(phi < 0.0) {
                                continue;
                            }
                            (b - n * phi, n, Vector3::zeros())
                        }
                        _ => continue,
                    };
                    xp.copy_from_slice(y.as_slice());
                    let w = Vector3::from_column_slice(vp);
                    let vn = (w - vs).dot(&n);
                    if vn < 0.0 {
                        vp.copy_from_slice((w - n * vn).as_slice());
                    }
                    hits += 1;
                }
                hits
            })
            .sum()
    }

    /// Per collider (in the order they were added), how many particles of
    /// `x` start inside it at time 0: deeper than round-off (`1e-9` of the
    /// particle's distance from the origin, plus `1e-9` m) inside a plane
    /// or sphere, inside a closed mesh, or behind an open one within its
    /// band (where the first step's put-back would move them through the
    /// surface). Particles pinned in all three directions are not counted:
    /// no collider moves them. A scene refuses such a start
    /// (docs/CONTACT.md): the put-back would turn the depth into spring
    /// energy the scene never had.
    pub fn particles_inside(&self, x: &[f64]) -> Vec<usize> {
        let mut inside = vec![0; self.colliders.len()];
        for p in 0..x.len() / 3 {
            if self.fixes.get(p).is_some_and(|d| d.count == 3) {
                continue;
            }
            let xp = point(x, p);
            let round_off = 1e-9 * (1.0 + xp.amax());
            for (c, count) in self.colliders.iter().zip(inside.iter_mut()) {
                if touch(c, 0.0, &xp).is_some_and(|(t, _, _)| t.phi < -round_off) {
                    *count += 1;
                }
            }
        }
        inside
    }

    /// What the contact handling did in the last step.
    pub fn contact_stats(&self) -> ContactStats {
        self.contact.stats
    }
}
