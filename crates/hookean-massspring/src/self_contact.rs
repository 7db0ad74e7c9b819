//! Cloth self-collision after Bridson, Fedkiw and Anderson (SIGGRAPH 2002),
//! on the model's triangles:
//!
//! 1. **Proximity** (at the start of the step): vertex-face and edge-edge
//!    pairs of non-adjacent features closer than the thickness `h_th` (a
//!    tree of the triangles' boxes grown by `h_th / 2`, refitted each step;
//!    the pairs of triangles that share a vertex from a list the topology
//!    fixes, `Near`).
//!    Each pair repels inside the implicit step with the penalty force of
//!    energy `k (h_th - g)^2 / 2` on the gap `g = n . sum_i w_i x_i` along the
//!    pair's normal `n` at the step's start (section 7.2's spring, as a force
//!    of the implicit solve rather than an impulse).
//! 2. **Collisions** (after the step): continuous detection on the straight
//!    paths from the step's start to its end (the tree of the swept boxes;
//!    `hookean_geometry::ccd`), each impact answered by an inelastic impulse
//!    that stops the approach along its normal (section 7.3), in a fixed
//!    order, for a few passes.
//! 3. **Impact zones** (section 7.4): particles of impacts that remain are
//!    merged into zones that move rigidly (their linear and angular momentum
//!    kept), re-detected and merged until no impact is left. If zones keep
//!    colliding, they fall back to their mean translation and then to rest,
//!    which cannot cross anything: the pass ends with no crossing as long as
//!    the step's start had none.

use crate::NonExhaustive;
use hookean_geometry::ccd::{Impact, edge_edge, vertex_face};
use hookean_geometry::proximity::{Proximity, edge_edge_proximity, vertex_face_proximity};
use hookean_geometry::{
    Aabb, Bvh, Overlaps, closest_point_triangle, closest_points_segments,
    point_triangle_farther_than, segments_farther_than,
};
use hookean_sparse::block::Block3;
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

use crate::error::MassSpringError;

mod carry;
pub(crate) use carry::SelfCarried;

type V3 = Vector3<f64>;

/// Options of cloth self-collision.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SelfCollision {
    /// Thickness `h_th` (m): non-adjacent features (vertex-face, edge-edge)
    /// closer than this repel. It must stay below the distance of
    /// non-adjacent features of the cloth at rest (about 0.7 of the grid
    /// spacing for a cloth grid), or the flat cloth repels itself.
    /// Default 0.004.
    pub thickness: f64,
    /// Repulsion stiffness `k` (N/m) of one proximity pair. Default 50.
    pub stiffness: f64,
    /// Build with `..Default::default()` (see [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

impl Default for SelfCollision {
    fn default() -> Self {
        Self {
            thickness: 0.004,
            stiffness: 50.0,
            non_exhaustive: NonExhaustive(()),
        }
    }
}

impl SelfCollision {
    pub(crate) fn check(&self) -> Result<(), MassSpringError> {
        for (name, v, positive) in [
            ("self-collision thickness", self.thickness, true),
            ("self-collision stiffness", self.stiffness, false),
        ] {
            if !(v.is_finite() && (v > 0.0 || (!positive && v == 0.0))) {
                return Err(MassSpringError::InvalidParameter {
                    name: if positive {
                        "self_thickness"
                    } else {
                        "self_stiffness"
                    },
                    message: format!(
                        "{name} {v:?} must be {} and finite",
                        if positive { "positive" } else { "non-negative" }
                    ),
                });
            }
        }
        Ok(())
    }
}

/// A proximity pair: particles `idx`, weights `w` (`sum w_i x_i` is the gap
/// vector), the normal at the step's start.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Pair {
    idx: [u32; 4],
    w: [f64; 4],
    n: V3,
}

/// A feature pair of the candidate list: vertex-face (`idx[0]` and the
/// face `idx[1..]`) or edge-edge.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    idx: [u32; 4],
    ee: bool,
}

/// A feature pair of two triangles that share a vertex: the topology fixes
/// these, so they are listed once ([`SelfContact::near`]) instead of being
/// met in every traversal of the tree, where they are most of the
/// overlapping triangle pairs (every triangle's box overlaps those of its
/// twelve neighbours on a grid). `idx` as in [`Candidate`]; `a = NONE`
/// and `b` the face's triangle for a vertex-face pair, `a` and `b` the two
/// edges (indices into [`SelfContact::edges`]) for an edge-edge pair.
#[derive(Debug, Clone, Copy)]
struct Near {
    idx: [u32; 4],
    a: u32,
    b: u32,
}

/// Feature pairs of [`Near`] per threaded task.
const NEAR_CHUNK: usize = 1024;

/// An impact found by the continuous pass.
#[derive(Debug, Clone, Copy)]
struct Hit {
    idx: [u32; 4],
    w: [f64; 4],
    n: V3,
}

/// What a continuous pass did.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Outcome {
    pub changed: bool,
    pub impacts: usize,
    pub zones: usize,
    pub fallbacks: usize,
}

/// Passes of single impulses before impact zones.
const IMPULSE_PASSES: usize = 3;
/// Zone rounds with rigid motion, then as many with translation only, then
/// at rest, up to [`ZONE_ROUNDS`].
const RIGID_ROUNDS: usize = 8;
const ZONE_ROUNDS: usize = 40;
/// The collision distance of the continuous test, relative to the
/// thickness.
const ETA: f64 = 0.01;
/// The candidate list's margin beyond the thickness, relative to it.
const SKIN: f64 = 1.0;
/// The margin when the cloth moved so fast in the last step (`2 M >= SKIN
/// h_th`) that a list with [`SKIN`] would not outlive the next step: the
/// list is then rebuilt every step anyway, and a thin margin finds fewer
/// pairs to test.
const THIN_SKIN: f64 = 0.25;

const NONE: u32 = u32::MAX;

/// The self-collision state of a model (topology, trees, pairs, scratch).
#[derive(Debug, Clone)]
pub(crate) struct SelfContact {
    opts: SelfCollision,
    tris: Vec<[u32; 3]>,
    /// Bit `k`: triangle owns its vertex `k` (the first triangle of a vertex).
    owned_vertices: Vec<u8>,
    /// Per triangle and local edge `k` (vertex `k` to `k + 1`): the edge's
    /// index in `edges` if the triangle owns it (its first triangle), else
    /// `NONE`.
    edge_ids: Vec<[u32; 3]>,
    /// Every edge once, and its box in the current pass.
    edges: Vec<[u32; 2]>,
    ebox: Vec<Aabb>,
    /// The owned feature pairs of triangles sharing a vertex, in a fixed
    /// order; the traversals skip those triangle pairs.
    near: Vec<Near>,
    /// Per task of a pass over `near`: what it found (storage reused).
    near_found: Vec<Vec<Candidate>>,
    near_hits: Vec<Vec<Hit>>,
    bvh: Option<Bvh>,
    /// Per particle and per triangle: boxes of the current pass (a point
    /// or swept path, grown by half the pass's distance).
    vbox: Vec<Aabb>,
    tbox: Vec<Aabb>,
    /// Feature pairs within `radius` of each other at `reference`.
    candidates: Vec<Candidate>,
    /// The candidate list's radius `R = (1 + skin) h_th` (0 before the
    /// first build).
    radius: f64,
    /// The motion `M` of the last detected step ([`relative_move`]).
    last_move: f64,
    reference: Vec<f64>,
    found: Overlaps<Candidate>,
    hits: Overlaps<Hit>,
    pairs: Vec<Pair>,
    impacts: Vec<Hit>,
    /// Tree traversals since the counter was last taken.
    pub(crate) traversals: usize,
    parent: Vec<u32>,
    zone_members: Vec<u32>,
}

impl SelfContact {
    /// The state for `n` particles and `faces`.
    ///
    /// # Errors
    /// [`MassSpringError::InvalidParameter`] for bad options or a model
    /// without triangles.
    pub(crate) fn new(
        n: usize,
        faces: &[[usize; 3]],
        opts: SelfCollision,
    ) -> Result<Self, MassSpringError> {
        opts.check()?;
        if faces.is_empty() {
            return Err(MassSpringError::InvalidParameter {
                name: "self_collision",
                message: "the model has no triangles (self-collision needs a cloth or mesh)".into(),
            });
        }
        let tris: Vec<[u32; 3]> = faces.iter().map(|f| f.map(|i| i as u32)).collect();
        let mut vertex_owner = vec![NONE; n];
        let mut owned_vertices = vec![0u8; tris.len()];
        let mut edges: Vec<(u32, u32, u32, u8)> = Vec::with_capacity(3 * tris.len());
        for (ti, t) in tris.iter().enumerate() {
            for k in 0..3 {
                if vertex_owner[t[k] as usize] == NONE {
                    vertex_owner[t[k] as usize] = ti as u32;
                    owned_vertices[ti] |= 1 << k;
                }
                let (a, b) = (t[k], t[(k + 1) % 3]);
                if a != b {
                    edges.push((a.min(b), a.max(b), ti as u32, k as u8));
                }
            }
        }
        edges.sort_unstable();
        let mut edge_ids = vec![[NONE; 3]; tris.len()];
        let mut unique = Vec::new();
        for (k, e) in edges.iter().enumerate() {
            if k == 0 || (edges[k - 1].0, edges[k - 1].1) != (e.0, e.1) {
                edge_ids[e.2 as usize][e.3 as usize] = unique.len() as u32;
                unique.push([e.0, e.1]);
            }
        }
        let near = near_pairs(n, &tris, &owned_vertices, &edge_ids);
        Ok(Self {
            opts,
            tris,
            owned_vertices,
            edge_ids,
            ebox: vec![Aabb::EMPTY; unique.len()],
            edges: unique,
            near,
            near_found: Vec::new(),
            near_hits: Vec::new(),
            bvh: None,
            vbox: vec![Aabb::EMPTY; n],
            tbox: vec![Aabb::EMPTY; faces.len()],
            candidates: Vec::new(),
            radius: 0.0,
            last_move: 0.0,
            reference: Vec::new(),
            found: Overlaps::default(),
            hits: Overlaps::default(),
            pairs: Vec::new(),
            impacts: Vec::new(),
            traversals: 0,
            parent: vec![NONE; n],
            zone_members: Vec::new(),
        })
    }

    /// The options.
    pub(crate) fn options(&self) -> SelfCollision {
        self.opts
    }

    /// Number of triangles.
    pub(crate) fn n_triangles(&self) -> usize {
        self.tris.len()
    }

    /// Fills the particle and triangle boxes of the paths `x0 -> x1` (or
    /// the points `x0`), grown by `r`, and refits the tree to them (built on
    /// first use). No allocation after the first call.
    fn fill_boxes(&mut self, x0: &[f64], x1: Option<&[f64]>, r: f64) {
        self.vbox.par_iter_mut().enumerate().for_each(|(p, b)| {
            let mut bx = Aabb::point(&pt(x0, p as u32));
            if let Some(x1) = x1 {
                bx.add_point(&pt(x1, p as u32));
            }
            *b = bx.inflated(r);
        });
        let vbox = &self.vbox;
        self.edges
            .par_iter()
            .zip(self.ebox.par_iter_mut())
            .for_each(|(e, b)| *b = vbox[e[0] as usize].union(&vbox[e[1] as usize]));
        self.tris
            .par_iter()
            .zip(self.tbox.par_iter_mut())
            .for_each(|([i, j, k], b)| {
                *b = vbox[*i as usize]
                    .union(&vbox[*j as usize])
                    .union(&vbox[*k as usize]);
            });
        let tbox = &self.tbox;
        match &mut self.bvh {
            Some(bvh) => bvh.refit(|t| tbox[t]),
            None => self.bvh = Some(Bvh::build(tbox)),
        }
    }

    /// Every owned feature pair (vertex-face, edge-edge; sharing no vertex)
    /// of the triangles `i` and `j` whose particle boxes overlap, handed to
    /// `f(particles, edge_edge)`; nothing for triangles that share a vertex
    /// (their pairs are in [`Self::near`]).
    fn feature_pairs(&self, i: usize, j: usize, mut f: impl FnMut([u32; 4], bool)) {
        let (ti, tj) = (&self.tris[i], &self.tris[j]);
        if ti.iter().any(|p| tj.contains(p)) {
            return;
        }
        owned_feature_pairs(
            &self.tris,
            &self.owned_vertices,
            &self.edge_ids,
            i,
            j,
            |idx, a, b| {
                let near = Near { idx, a, b };
                if self.boxes_overlap(&near) {
                    f(idx, a != NONE);
                }
            },
        );
    }

    /// Whether the particle boxes of a feature pair overlap (the vertex's
    /// and the face's, or the two edges').
    #[inline]
    fn boxes_overlap(&self, c: &Near) -> bool {
        if c.a == NONE {
            self.vbox[c.idx[0] as usize].overlaps(&self.tbox[c.b as usize])
        } else {
            self.ebox[c.a as usize].overlaps(&self.ebox[c.b as usize])
        }
    }

    /// Runs `test` on every pair of [`Self::near`] whose boxes overlap, on
    /// the rayon pool in fixed chunks: `out` holds what each chunk found, in
    /// the list's order for every thread count.
    fn near_pass<T: Send>(
        &self,
        out: &mut Vec<Vec<T>>,
        test: impl Fn([u32; 4], bool) -> Option<T> + Sync,
    ) {
        let chunks = self.near.len().div_ceil(NEAR_CHUNK);
        if out.len() < chunks {
            out.resize_with(chunks, Vec::new);
        }
        out.truncate(chunks);
        out.par_iter_mut()
            .zip(self.near.par_chunks(NEAR_CHUNK))
            .for_each(|(found, near)| {
                found.clear();
                found.extend(
                    near.iter()
                        .filter(|c| self.boxes_overlap(c))
                        .filter_map(|c| test(c.idx, c.a != NONE)),
                );
            });
    }

    /// The radius of the next candidate list: `(1 + SKIN) h_th`, or `(1 +
    /// THIN_SKIN) h_th` after a step that moved more than `SKIN h_th / 2`.
    fn next_radius(&self) -> f64 {
        let th = self.opts.thickness;
        let skin = if 2.0 * self.last_move < SKIN * th {
            SKIN
        } else {
            THIN_SKIN
        };
        (1.0 + skin) * th
    }

    /// The candidate list (a Verlet list): every owned feature pair closer
    /// than `R` ([`Self::next_radius`]) at the positions `x`, which become
    /// the reference positions.
    fn build_candidates(&mut self, x: &[f64]) {
        self.traversals += 1;
        let radius = self.next_radius();
        self.radius = radius;
        self.fill_boxes(x, None, 0.5 * radius);
        let close = |idx: [u32; 4], ee: bool| {
            let y = idx.map(|p| pt(x, p));
            // A separating axis first: most pairs whose boxes overlap lie
            // side by side in the cloth, farther than `R` apart.
            let far = if ee {
                segments_farther_than(&y[0], &y[1], &y[2], &y[3], radius)
            } else {
                point_triangle_farther_than(&y[0], &y[1], &y[2], &y[3], radius)
            };
            if far {
                return None;
            }
            let d = if ee {
                let (_, _, c1, c2) = closest_points_segments(&y[0], &y[1], &y[2], &y[3]);
                (c1 - c2).norm()
            } else {
                (y[0] - closest_point_triangle(&y[0], &y[1], &y[2], &y[3]).point).norm()
            };
            (d < radius).then_some(Candidate { idx, ee })
        };
        let mut near = std::mem::take(&mut self.near_found);
        self.near_pass(&mut near, close);
        let mut found = std::mem::take(&mut self.found);
        let bvh = self.bvh.as_ref().expect("built by fill_boxes");
        bvh.self_overlaps(&mut found, |i, j, out| {
            self.feature_pairs(i, j, |idx, ee| out.extend(close(idx, ee)));
        });
        self.candidates.clear();
        self.candidates.extend(near.iter().flatten().copied());
        self.candidates.extend(found.iter().copied());
        self.found = found;
        self.near_found = near;
        self.reference.clear();
        self.reference.extend_from_slice(x);
    }

    /// How far the particles of `x` have moved from their reference positions
    /// beyond a common translation ([`relative_move`]; infinite before the
    /// first build).
    fn drift(&self, x: &[f64]) -> f64 {
        if self.reference.len() != x.len() {
            return f64::INFINITY;
        }
        relative_move(&self.reference, x)
    }

    /// Finds the proximity pairs of the positions `x` (the step's start)
    /// among the candidates, rebuilt first when a particle has moved more
    /// than `(R - h_th) / 2` beyond the cloth's common translation since they
    /// were found (or a position is NaN) (then no pair closer than
    /// `h_th` can be missing: distance is 1-Lipschitz in each point). Returns
    /// their number.
    pub(crate) fn find_proximity(&mut self, x: &[f64]) -> usize {
        let th = self.opts.thickness;
        if !(2.0 * self.drift(x) < self.radius - th) {
            self.build_candidates(x);
        }
        self.pairs.clear();
        for c in &self.candidates {
            let y = c.idx.map(|p| pt(x, p));
            let q = if c.ee {
                edge_edge_proximity(&y, th)
            } else {
                vertex_face_proximity(&y, th)
            };
            if let Some(q) = q {
                self.pairs.push(pair(c.idx, &q));
            }
        }
        self.pairs.len()
    }
    /// The gap `g = n . sum_i w_i x_i` of a pair and whether it repels.
    fn gap(&self, x: &[f64], p: &Pair) -> Option<f64> {
        let g: f64 = (0..4).map(|i| p.w[i] * p.n.dot(&pt(x, p.idx[i]))).sum();
        (g < self.opts.thickness).then_some(g)
    }

    /// Adds the repulsion `f_i += w_i k (h_th - g) n` of every pair with
    /// `g < h_th` to `f`.
    pub(crate) fn add_forces(&self, x: &[f64], f: &mut [f64]) {
        let k = self.opts.stiffness;
        for p in self.pairs.iter() {
            if let Some(g) = self.gap(x, p) {
                let mag = k * (self.opts.thickness - g);
                for i in 0..4 {
                    let q = p.idx[i] as usize;
                    for r in 0..3 {
                        f[3 * q + r] += p.w[i] * mag * p.n[r];
                    }
                }
            }
        }
    }

    /// Calls `add(particle, block)` with the diagonal blocks that stand for
    /// the repulsion's `df/dx = -k (w w^T) (x) n n^T` of every active pair:
    /// `-k |w_i| (sum_j |w_j|) n n^T`. The coupling blocks between the
    /// pair's particles are not on the matrix's pattern; these diagonal
    /// blocks bound the pair's stiffness from above (Gershgorin: `diag(|w_i|
    /// sum_j |w_j|) - w w^T` is positive semidefinite), so Newton's iteration
    /// on the repulsion converges monotonically instead of overshooting
    /// (with `-k w_i^2` alone, an edge-edge pair is four times too soft
    /// along `w` and Newton diverges once `h^2 k` exceeds the mass).
    pub(crate) fn for_each_diagonal_block(&self, x: &[f64], mut add: impl FnMut(usize, &Block3)) {
        let k = self.opts.stiffness;
        for p in self.pairs.iter() {
            if self.gap(x, p).is_some() {
                let sum: f64 = p.w.iter().map(|w| w.abs()).sum();
                for i in 0..4 {
                    let s = -k * p.w[i].abs() * sum;
                    let mut b = [[0.0; 3]; 3];
                    for r in 0..3 {
                        for c in 0..3 {
                            b[r][c] = s * p.n[r] * p.n[c];
                        }
                    }
                    add(p.idx[i] as usize, &b);
                }
            }
        }
    }

    /// Continuous detection on the straight paths `x0 -> x1`: fills
    /// `impacts` (in a fixed order) and returns their number. Two features
    /// can only meet in the step if they start within `2 M + eta` of each
    /// other (`M` the largest motion of a particle in the step beyond the
    /// cloth's common translation, [`relative_move`]); when every
    /// such pair is among the candidates (`2 M + eta + 2 D < R`, `D` the
    /// drift since they were found, rebuilding them once if needed), only the
    /// candidates are tested; otherwise (fast motion) the tree of the swept
    /// boxes is traversed.
    fn detect(&mut self, x0: &[f64], x1: &[f64]) -> usize {
        let th = self.opts.thickness;
        let eta = ETA * th;
        self.last_move = relative_move(x0, x1);
        let reach = 2.0 * self.last_move + eta;
        if reach + 2.0 * self.drift(x0) >= self.radius && reach < self.next_radius() {
            self.build_candidates(x0);
        }
        self.impacts.clear();
        if reach + 2.0 * self.drift(x0) < self.radius {
            for c in &self.candidates {
                if let Some(hit) = ccd(c.idx, c.ee, x0, x1, eta) {
                    self.impacts.push(hit);
                }
            }
            return self.impacts.len();
        }
        self.traversals += 1;
        self.fill_boxes(x0, Some(x1), 0.5 * eta);
        let mut near = std::mem::take(&mut self.near_hits);
        self.near_pass(&mut near, |idx, ee| ccd(idx, ee, x0, x1, eta));
        let mut found = std::mem::take(&mut self.hits);
        let bvh = self.bvh.as_ref().expect("built by fill_boxes");
        bvh.self_overlaps(&mut found, |i, j, out| {
            self.feature_pairs(i, j, |idx, ee| out.extend(ccd(idx, ee, x0, x1, eta)));
        });
        self.impacts.extend(near.iter().flatten().copied());
        self.impacts.extend(found.iter().copied());
        self.hits = found;
        self.near_hits = near;
        self.impacts.len()
    }

    /// The continuous pass of a step of size `h` from `x0` to `x` (with
    /// velocities `v`, `x = x0 + h v` for the moving particles): impulses,
    /// then impact zones, then the fallbacks, until no impact is left.
    /// `inv_mass(p)` is 0 for particles that cannot move (pinned,
    /// sticking); `proj(p)` the projector of a constrained particle.
    pub(crate) fn resolve(
        &mut self,
        h: f64,
        x0: &[f64],
        x: &mut [f64],
        v: &mut [f64],
        inv_mass: &dyn Fn(usize) -> f64,
        proj: &dyn Fn(usize) -> Option<Block3>,
    ) -> Outcome {
        let mut out = Outcome::default();
        for _ in 0..IMPULSE_PASSES {
            let found = self.detect(x0, x);
            out.impacts += found;
            if found == 0 {
                return out;
            }
            for k in 0..self.impacts.len() {
                let hit = self.impacts[k];
                out.changed |= impulse(&hit, h, x, v, inv_mass, proj);
            }
        }
        // Impact zones.
        for &p in &self.zone_members {
            self.parent[p as usize] = NONE;
        }
        self.zone_members.clear();
        let mut resolved = false;
        for round in 0..ZONE_ROUNDS {
            let found = self.detect(x0, x);
            out.impacts += found;
            if found == 0 {
                resolved = true;
                break;
            }
            for k in 0..self.impacts.len() {
                let idx = self.impacts[k].idx;
                for &p in &idx {
                    if self.parent[p as usize] == NONE {
                        self.parent[p as usize] = p;
                        self.zone_members.push(p);
                    }
                }
                for &p in &idx[1..] {
                    union(&mut self.parent, idx[0], p);
                }
            }
            let mode = if round < RIGID_ROUNDS {
                ZoneMotion::Rigid
            } else if round < 2 * RIGID_ROUNDS {
                ZoneMotion::Translation
            } else {
                ZoneMotion::Rest
            };
            if mode != ZoneMotion::Rigid {
                out.fallbacks += 1;
            }
            out.zones = self.move_zones(mode, h, x0, x, v, inv_mass);
            out.changed = true;
        }
        if !resolved && self.detect(x0, x) > 0 {
            // Never reached in the tests; the guarantee: nothing moves.
            x.copy_from_slice(x0);
            v.fill(0.0);
            out.fallbacks += 1;
            out.changed = true;
        }
        out
    }

    /// Gives every zone its motion; returns the number of zones.
    fn move_zones(
        &mut self,
        mode: ZoneMotion,
        h: f64,
        x0: &[f64],
        x: &mut [f64],
        v: &mut [f64],
        inv_mass: &dyn Fn(usize) -> f64,
    ) -> usize {
        let parent = &mut self.parent;
        let mut keyed: Vec<(u32, u32)> = self
            .zone_members
            .iter()
            .map(|&p| (find(parent, p), p))
            .collect();
        keyed.sort_unstable();
        let mut zones = 0;
        let mut s = 0;
        while s < keyed.len() {
            let mut e = s + 1;
            while e < keyed.len() && keyed[e].0 == keyed[s].0 {
                e += 1;
            }
            zones += 1;
            let members = &keyed[s..e];
            let fixed = members.iter().any(|&(_, p)| inv_mass(p as usize) == 0.0);
            let (vc, omega, xc) = if fixed || mode == ZoneMotion::Rest {
                (V3::zeros(), V3::zeros(), V3::zeros())
            } else {
                rigid_motion(members, x0, v, inv_mass, mode == ZoneMotion::Rigid)
            };
            for &(_, p) in members {
                let w = vc + omega.cross(&(pt(x0, p) - xc));
                let q = p as usize;
                for r in 0..3 {
                    v[3 * q + r] = w[r];
                    x[3 * q + r] = x0[3 * q + r] + h * w[r];
                }
            }
            s = e;
        }
        zones
    }
}

/// Every owned feature pair sharing no vertex of the triangles `i` and `j`
/// (`i != j`), handed to `f(particles, a, b)` as in [`Near`]: vertex-face
/// pairs, those of `i`'s owned vertices first, then `j`'s, then edge-edge
/// pairs.
fn owned_feature_pairs(
    tris: &[[u32; 3]],
    owned_vertices: &[u8],
    edge_ids: &[[u32; 3]],
    i: usize,
    j: usize,
    mut f: impl FnMut([u32; 4], u32, u32),
) {
    let (ti, tj) = (&tris[i], &tris[j]);
    for (a, ta, b, tb) in [(i, ti, j, tj), (j, tj, i, ti)] {
        for k in 0..3 {
            let p = ta[k];
            if owned_vertices[a] & (1 << k) != 0 && !tb.contains(&p) {
                f([p, tb[0], tb[1], tb[2]], NONE, b as u32);
            }
        }
    }
    for ka in 0..3 {
        let ea = edge_ids[i][ka];
        if ea == NONE {
            continue;
        }
        let (p, q) = (ti[ka], ti[(ka + 1) % 3]);
        for kb in 0..3 {
            let eb = edge_ids[j][kb];
            if eb == NONE {
                continue;
            }
            let (r, s) = (tj[kb], tj[(kb + 1) % 3]);
            if p != r && p != s && q != r && q != s {
                f([p, q, r, s], ea, eb);
            }
        }
    }
}

/// The [`Near`] list of a triangle mesh of `n` particles: the owned
/// feature pairs of every two triangles that share a vertex, by the first
/// triangle, then the second.
fn near_pairs(
    n: usize,
    tris: &[[u32; 3]],
    owned_vertices: &[u8],
    edge_ids: &[[u32; 3]],
) -> Vec<Near> {
    let mut start = vec![0u32; n + 1];
    for t in tris {
        for &p in t {
            start[p as usize + 1] += 1;
        }
    }
    for p in 0..n {
        start[p + 1] += start[p];
    }
    let mut fill = start.clone();
    let mut of_vertex = vec![0u32; start[n] as usize];
    for (ti, t) in tris.iter().enumerate() {
        for &p in t {
            of_vertex[fill[p as usize] as usize] = ti as u32;
            fill[p as usize] += 1;
        }
    }
    let mut near = Vec::new();
    let mut others: Vec<u32> = Vec::new();
    for (i, t) in tris.iter().enumerate() {
        others.clear();
        for &p in t {
            let range = start[p as usize] as usize..start[p as usize + 1] as usize;
            others.extend(
                of_vertex[range]
                    .iter()
                    .filter(|&&j| j as usize > i)
                    .copied(),
            );
        }
        others.sort_unstable();
        others.dedup();
        for &j in &others {
            owned_feature_pairs(
                tris,
                owned_vertices,
                edge_ids,
                i,
                j as usize,
                |idx, a, b| near.push(Near { idx, a, b }),
            );
        }
    }
    near
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ZoneMotion {
    Rigid,
    Translation,
    Rest,
}

/// The velocity `vc + omega x (x - xc)` that keeps a zone's linear and
/// angular momentum (Bridson et al. 2002, section 7.4), from the positions
/// at the step's start; `omega = 0` for `rigid = false` or a degenerate
/// (collinear) zone.
fn rigid_motion(
    members: &[(u32, u32)],
    x0: &[f64],
    v: &[f64],
    inv_mass: &dyn Fn(usize) -> f64,
    rigid: bool,
) -> (V3, V3, V3) {
    let mut m_sum = 0.0;
    let mut xc = V3::zeros();
    let mut vc = V3::zeros();
    for &(_, p) in members {
        let m = 1.0 / inv_mass(p as usize);
        m_sum += m;
        xc += pt(x0, p) * m;
        vc += pt(v, p) * m;
    }
    xc /= m_sum;
    vc /= m_sum;
    if !rigid {
        return (vc, V3::zeros(), xc);
    }
    let mut l = V3::zeros();
    let mut inertia = Matrix3::zeros();
    for &(_, p) in members {
        let m = 1.0 / inv_mass(p as usize);
        let r = pt(x0, p) - xc;
        l += r.cross(&(pt(v, p) - vc)) * m;
        inertia += (Matrix3::identity() * r.norm_squared() - r * r.transpose()) * m;
    }
    let omega = inertia
        .try_inverse()
        .filter(|inv| inv.iter().all(|c| c.is_finite()))
        .map_or(V3::zeros(), |inv| inv * l);
    (vc, omega, xc)
}

/// The inelastic impulse of one impact: the relative normal velocity
/// `v_N = n . sum_i w_i v_i`, if approaching, set to zero by the impulse
/// `I = -v_N / sum_i w_i^2 (n^T P_i n) / m_i` spread as `dv_i = w_i I P_i n
/// / m_i`; positions follow (`dx_i = h dv_i`). True if anything moved.
fn impulse(
    hit: &Hit,
    h: f64,
    x: &mut [f64],
    v: &mut [f64],
    inv_mass: &dyn Fn(usize) -> f64,
    proj: &dyn Fn(usize) -> Option<Block3>,
) -> bool {
    let vn: f64 = (0..4)
        .map(|i| hit.w[i] * hit.n.dot(&pt(v, hit.idx[i])))
        .sum();
    if !(vn < 0.0) {
        return false;
    }
    let dirs: [V3; 4] = std::array::from_fn(|i| match proj(hit.idx[i] as usize) {
        Some(p) => V3::new(
            p[0][0] * hit.n.x + p[0][1] * hit.n.y + p[0][2] * hit.n.z,
            p[1][0] * hit.n.x + p[1][1] * hit.n.y + p[1][2] * hit.n.z,
            p[2][0] * hit.n.x + p[2][1] * hit.n.y + p[2][2] * hit.n.z,
        ),
        None => hit.n,
    });
    let denom: f64 = (0..4)
        .map(|i| hit.w[i] * hit.w[i] * hit.n.dot(&dirs[i]) * inv_mass(hit.idx[i] as usize))
        .sum();
    if !(denom > 0.0) {
        return false;
    }
    let big_i = -vn / denom;
    for i in 0..4 {
        let q = hit.idx[i] as usize;
        let dv = dirs[i] * (hit.w[i] * big_i * inv_mass(q));
        for r in 0..3 {
            v[3 * q + r] += dv[r];
            x[3 * q + r] += h * dv[r];
        }
    }
    true
}

/// The continuous test of one feature pair on the paths `x0 -> x1`, if its
/// particles move at all.
fn ccd(idx: [u32; 4], ee: bool, x0: &[f64], x1: &[f64], eta: f64) -> Option<Hit> {
    let moves = idx
        .iter()
        .any(|&p| (0..3).any(|r| x0[3 * p as usize + r] != x1[3 * p as usize + r]));
    if !moves {
        return None;
    }
    let (y0, y1) = (idx.map(|q| pt(x0, q)), idx.map(|q| pt(x1, q)));
    let hit = if ee {
        edge_edge(&y0, &y1, eta)
    } else {
        vertex_face(&y0, &y1, eta)
    };
    hit.map(|h| to_hit(idx, &h))
}

/// The motion from `a` to `b` beyond a common translation: the largest
/// distance of a particle's displacement `d_p = b_p - a_p` from the centre
/// `c` of the displacements' bounding box. Features whose points all move by
/// `c` keep their distances, and moving each point by at most `D` more
/// changes a point-triangle or segment-segment distance by at most `2 D`
/// (distance is 1-Lipschitz in each point), so the candidate list and the
/// continuous pass's reach use this `D` instead of the largest absolute
/// motion: a cloth falling or sliding as a whole keeps its list. NaN when
/// a displacement is not finite.
fn relative_move(a: &[f64], b: &[f64]) -> f64 {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for (p, q) in a.chunks_exact(3).zip(b.chunks_exact(3)) {
        for r in 0..3 {
            let d = q[r] - p[r];
            lo[r] = lo[r].min(d);
            hi[r] = hi[r].max(d);
        }
    }
    let c: [f64; 3] = std::array::from_fn(|r| 0.5 * (lo[r] + hi[r]));
    let mut worst = 0.0_f64;
    for (p, q) in a.chunks_exact(3).zip(b.chunks_exact(3)) {
        let e: [f64; 3] = std::array::from_fn(|r| q[r] - p[r] - c[r]);
        let d2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
        if d2.is_nan() {
            return f64::NAN;
        }
        worst = worst.max(d2);
    }
    worst.sqrt()
}

fn find(parent: &mut [u32], mut p: u32) -> u32 {
    while parent[p as usize] != p {
        let g = parent[parent[p as usize] as usize];
        parent[p as usize] = g;
        p = g;
    }
    p
}

/// Joins the zones of `a` and `b`; the smaller root index wins (a fixed
/// rule: the same zones on every run).
fn union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        let (lo, hi) = (ra.min(rb), ra.max(rb));
        parent[hi as usize] = lo;
    }
}

fn pair(idx: [u32; 4], q: &Proximity) -> Pair {
    Pair {
        idx,
        w: q.weights,
        n: q.normal,
    }
}

fn to_hit(idx: [u32; 4], hit: &Impact) -> Hit {
    Hit {
        idx,
        w: hit.weights,
        n: hit.normal,
    }
}

#[inline]
fn pt(x: &[f64], p: u32) -> V3 {
    let p = p as usize;
    V3::new(x[3 * p], x[3 * p + 1], x[3 * p + 2])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_motion_ignores_a_common_translation() {
        let a = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        let t = [0.3, -2.0, 5.0];
        let mut b = a;
        for p in 0..3 {
            for r in 0..3 {
                b[3 * p + r] += t[r];
            }
        }
        assert!(relative_move(&a, &b) < 1e-14);
        // Particle 2 moves 0.3 further along x: the displacements span
        // [t, t + 0.3 e_x], centre t + 0.15 e_x, so D = 0.15.
        b[6] += 0.3;
        approx::assert_abs_diff_eq!(relative_move(&a, &b), 0.15, epsilon = 1e-14);
        b[4] = f64::NAN;
        assert!(relative_move(&a, &b).is_nan());
    }

    /// A crumpled 9 x 9 grid (every quad split in two) whose layers come
    /// within the candidate radius of each other: the candidate list (the
    /// `near` pass plus the traversal) is exactly the set of feature pairs
    /// closer than `R` found by brute force over every vertex-face and
    /// edge-edge pair sharing no vertex, each pair once.
    #[test]
    fn candidates_equal_brute_force_on_a_crumpled_grid() {
        let m = 9;
        let id = |i: usize, j: usize| (i + m * j) as u32;
        let mut faces = Vec::new();
        for j in 0..m - 1 {
            for i in 0..m - 1 {
                let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i, j + 1), id(i + 1, j + 1));
                faces.push([a as usize, b as usize, c as usize]);
                faces.push([b as usize, d as usize, c as usize]);
            }
        }
        // Folded over along x twice (a Z of three layers 0.04 apart), with
        // a deterministic wobble.
        let mut x = Vec::new();
        for j in 0..m {
            for i in 0..m {
                let u = i as f64 * 0.1;
                let (px, pz) = match i {
                    0..=2 => (u, 0.0),
                    3..=5 => (0.5 - u, 0.04),
                    _ => (u - 0.6, 0.08),
                };
                let w = 0.01 * ((7 * i + 3 * j) as f64).sin();
                x.extend([px + w, j as f64 * 0.1, pz + w]);
            }
        }
        let opts = SelfCollision {
            thickness: 0.03,
            ..Default::default()
        };
        let mut sc = SelfContact::new(m * m, &faces, opts).unwrap();
        sc.build_candidates(&x);
        let radius = sc.radius;
        assert_eq!(radius, (1.0 + SKIN) * 0.03);
        let key = |idx: [u32; 4], ee: bool| -> (bool, [u32; 4]) {
            if ee {
                let (e, f) = (
                    [idx[0].min(idx[1]), idx[0].max(idx[1])],
                    [idx[2].min(idx[3]), idx[2].max(idx[3])],
                );
                let (e, f) = (e.min(f), e.max(f));
                (true, [e[0], e[1], f[0], f[1]])
            } else {
                let mut t = [idx[1], idx[2], idx[3]];
                t.sort_unstable();
                (false, [idx[0], t[0], t[1], t[2]])
            }
        };
        let mut got: Vec<_> = sc.candidates.iter().map(|c| key(c.idx, c.ee)).collect();
        got.sort_unstable();
        let before = got.len();
        got.dedup();
        assert_eq!(got.len(), before, "a pair listed twice");
        // Brute force, with the distances of the tests' own formulas.
        let p3 = |p: u32| pt(&x, p);
        let mut edges: Vec<[u32; 2]> = faces
            .iter()
            .flat_map(|f| (0..3).map(move |k| (f[k] as u32, f[(k + 1) % 3] as u32)))
            .map(|(a, b)| [a.min(b), a.max(b)])
            .collect();
        edges.sort_unstable();
        edges.dedup();
        let mut want = Vec::new();
        for p in 0..(m * m) as u32 {
            for f in &faces {
                let f = f.map(|v| v as u32);
                if f.contains(&p) {
                    continue;
                }
                let q = closest_point_triangle(&p3(p), &p3(f[0]), &p3(f[1]), &p3(f[2]));
                if (p3(p) - q.point).norm() < radius {
                    want.push(key([p, f[0], f[1], f[2]], false));
                }
            }
        }
        for (k, e) in edges.iter().enumerate() {
            for f in &edges[k + 1..] {
                if e.iter().any(|v| f.contains(v)) {
                    continue;
                }
                let (_, _, c1, c2) =
                    closest_points_segments(&p3(e[0]), &p3(e[1]), &p3(f[0]), &p3(f[1]));
                if (c1 - c2).norm() < radius {
                    want.push(key([e[0], e[1], f[0], f[1]], true));
                }
            }
        }
        want.sort_unstable();
        // The layers are close: far more pairs than the flat grid's.
        assert!(want.len() > 500, "{} pairs", want.len());
        assert_eq!(got, want);
    }
}
