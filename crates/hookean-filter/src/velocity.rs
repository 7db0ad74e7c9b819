//! The velocity filter of Ahmad et al. (section 4.1, eq. 10).

use crate::NonExhaustive;
use hookean_massspring::{MassSpringModel, ParticleConstraint, Spring};

use hookean_sparse::Constraints;

use crate::error::FilterError;

/// The filter kernel `beta(d)` as a function of the distance `d`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Kernel {
    /// The paper's exponential filter `beta(d) = lambda exp(-lambda |d|)` (eq. 10),
    /// the filter that implicit solves apply (its eq. 9).
    Exponential {
        /// Sharpness: large lambda (> 10) hardly filters, lambda <= 1 filters strongly.
        lambda: f64,
    },
    /// The Gaussian variant the paper reports similar results with:
    /// `beta(d) = exp(-(lambda d)^2 / 2)` (constant factors cancel in the normalisation).
    Gaussian {
        /// Sharpness, as for the exponential kernel.
        lambda: f64,
    },
}

impl Kernel {
    /// `beta(d)` (unnormalised).
    pub fn beta(&self, d: f64) -> f64 {
        match *self {
            Kernel::Exponential { lambda } => lambda * (-lambda * d.abs()).exp(),
            Kernel::Gaussian { lambda } => (-0.5 * (lambda * d) * (lambda * d)).exp(),
        }
    }

    fn lambda(&self) -> f64 {
        match *self {
            Kernel::Exponential { lambda } | Kernel::Gaussian { lambda } => lambda,
        }
    }
}

/// How a particle's filtered velocity combines its neighbours' (section 4.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Form {
    /// `v_i <- sum_j beta_ij (v_j + v_i) / 2`, the paper's symmetric alternative,
    /// which "worked well with our examples" (the default). With normalised
    /// weights it equals `(v_i + sum_j beta_ij v_j) / 2`.
    #[default]
    Symmetric,
    /// `v_i <- sum_j beta_ij v_j`, the plain weighted average.
    Plain,
}

/// Options of a [`VelocityFilter`].
#[derive(Debug, Clone, PartialEq)]
pub struct FilterOptions {
    /// The kernel. Default: exponential with `lambda = 1` (the paper's "time step is doubled").
    pub kernel: Kernel,
    /// Symmetric or plain form. Default [`Form::Symmetric`].
    pub form: Form,
    /// Neighbourhood radius in rings of the spring graph (1 = the springs'
    /// other ends; the particle itself is always included). Default 1.
    pub rings: usize,
    /// Time-dependent weights, as the paper writes them (`beta_j^{t + dt}`,
    /// section 4.1): before each application the distances are the
    /// particles' current straight-line distances (in units of the
    /// shortest rest length) and the weights are normalised again
    /// ([`VelocityFilter::update_distances`]). Every particle is then
    /// gathered (no shared stencils) and each step pays a distance and an
    /// exponential per neighbour: measured in docs/perf/filter.md. Default
    /// `false`: the weights of the rest state (path lengths through the
    /// spring graph), computed once.
    pub current_distances: bool,
    /// Build with `..Default::default()` (see [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

impl Default for FilterOptions {
    fn default() -> Self {
        Self {
            kernel: Kernel::Exponential { lambda: 1.0 },
            form: Form::Symmetric,
            rings: 1,
            current_distances: false,
            non_exhaustive: NonExhaustive(()),
        }
    }
}

/// A spring of the graph the filter works on: its two particles and rest length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Edge {
    /// First particle.
    pub i: usize,
    /// Second particle.
    pub j: usize,
    /// Rest length (m), positive.
    pub rest_length: f64,
}

impl From<&Spring> for Edge {
    /// The spring's particles and rest length (its material does not enter
    /// the filter).
    fn from(s: &Spring) -> Self {
        Self {
            i: s.i,
            j: s.j,
            rest_length: s.rest_length,
        }
    }
}

/// The exponential (or Gaussian) velocity filter on the k-ring neighbourhoods
/// of a spring graph, applied after an explicit step as a post-processing unit.
///
/// **Distance unit.** `d_ij` is the shortest path from `i` to `j` through the
/// spring graph (within the k-ring), each spring counting its rest length
/// divided by the *shortest rest length of the model*. On a cloth grid with
/// spacing `s` a structural neighbour is at `d = 1`, a shear neighbour at
/// `sqrt(2)`, a bend neighbour at `2`; the particle itself at `d = 0`. Being
/// built from rest lengths, the weights are constant: they are computed once
/// per topology, normalised to sum 1, and stored in a flat adjacency array,
/// so one application is `O(n)` and allocates nothing.
///
/// Pinned particles keep their velocity.
///
/// **Evaluation plan.** At construction the neighbourhoods are scanned in
/// particle order for runs of consecutive particles whose neighbourhoods
/// have the same index offsets (the interior of a structured grid, detected
/// from the adjacency alone, whatever the model). Such a run is one
/// stencil: its output is a sum of shifted copies of the input,
/// `sum_s w_s v[i + o_s]`, computed as contiguous loops over the run's
/// `3 len` components, which the compiler vectorises. If the weights of the
/// whole run agree to a relative [`STENCIL_WEIGHT_RTOL`] (they differ only
/// by the rounding of rest lengths computed from grid coordinates) the run
/// uses its first particle's weights for all its particles; otherwise each
/// particle keeps its own weights, stored slot by slot (structure of
/// arrays). Particles outside runs are gathered through `u32` neighbour
/// indices. The symmetric form is folded into the weights
/// (`w_ii <- (1 + w_ii) / 2`, `w_ij <- w_ij / 2`), and pinned particles are
/// copied from the input afterwards. The result equals the straightforward
/// formula to rounding (tests/fast_path.rs checks it against a dense
/// reference).
#[derive(Debug, Clone)]
pub struct VelocityFilter {
    options: FilterOptions,
    offsets: Vec<usize>,
    neighbours: Vec<usize>,
    weights: Vec<f64>,
    pinned: Vec<bool>,
    pinned_list: Vec<usize>,
    plan: Plan,
    scratch: Vec<f64>,
    /// The shortest rest length (the distance unit).
    unit: f64,
}

/// How a [`VelocityFilter`] evaluates its particles (see its evaluation plan).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PlanStats {
    /// Runs of consecutive particles with the same neighbourhood offsets.
    pub stencil_runs: usize,
    /// Particles in runs whose weights are shared by the whole run.
    pub shared_weight_particles: usize,
    /// Particles in runs that keep per-particle weights.
    pub per_particle_weight_particles: usize,
    /// Particles evaluated by gathering through neighbour indices.
    pub gathered_particles: usize,
}

/// Relative tolerance within which the weights of a run of identical
/// neighbourhoods count as one stencil's (about 450 ulp): rest lengths
/// computed from the coordinates of a grid of spacing `s` carry a relative
/// error of about `1e-16 / s` (7e-15, 34 ulp, measured on the 64 x 64
/// drape), so exact equality would split every row into short runs.
/// Treating such weights as equal moves the output by at most
/// `1e-13 max |v|`.
pub const STENCIL_WEIGHT_RTOL: f64 = 1e-13;
/// Shortest run of identical neighbourhood offsets evaluated as a stencil.
const MIN_RUN: usize = 4;
/// Components per register block of a shared-weight stencil.
const BLOCK: usize = 36;
/// Components per small register block (the rest of a run).
const SMALL_BLOCK: usize = 12;
/// Particles per register block of a per-particle-weight stencil.
const PARTICLE_BLOCK: usize = 8;

/// How the particles of a run are weighted.
#[derive(Debug, Clone)]
enum RunWeights {
    /// One weight per tap (in [`Plan::shared_weights`]), for all particles.
    Shared(std::ops::Range<usize>),
    /// Per particle: `per_particle_weights[start + s len + p]`.
    PerParticle(usize),
}

/// A run of consecutive particles with the same neighbourhood offsets.
#[derive(Debug, Clone)]
struct Run {
    /// First particle.
    first: usize,
    /// Number of particles.
    len: usize,
    /// First source component of each tap for the run's first particle,
    /// `3 (first + o_s)`, in [`Plan::tap_starts`].
    taps: std::ops::Range<usize>,
    weights: RunWeights,
}

/// The precomputed evaluation of the filter (see [`VelocityFilter`]).
#[derive(Debug, Clone, Default)]
struct Plan {
    runs: Vec<Run>,
    tap_starts: Vec<usize>,
    shared_weights: Vec<f64>,
    per_particle_weights: Vec<f64>,
    /// Particles evaluated by gathering.
    gather_particles: Vec<u32>,
    /// Tap ranges of the gathered particles (`gather_particles.len() + 1`).
    gather_ptr: Vec<u32>,
    /// Neighbour indices of the gathered particles.
    gather_index: Vec<u32>,
    /// Effective weights of the gathered particles.
    gather_weight: Vec<f64>,
}

impl Plan {
    /// Builds the plan from the normalised neighbourhoods (CSR, sorted).
    fn build(
        offsets: &[usize],
        neighbours: &[usize],
        weights: &[f64],
        form: Form,
        gather_all: bool,
    ) -> Result<Self, FilterError> {
        let n = offsets.len() - 1;
        if u32::try_from(neighbours.len()).is_err() || u32::try_from(n).is_err() {
            return Err(FilterError::DimensionMismatch {
                what: "neighbourhood entries (at most u32::MAX)",
                expected: u32::MAX as usize,
                found: neighbours.len().max(n),
            });
        }
        // The weight of tap k of particle i in `dst_i = sum_k w_k src_{j_k}`.
        let effective = |i: usize, k: usize| -> f64 {
            match form {
                Form::Plain => weights[k],
                Form::Symmetric if neighbours[k] == i => 0.5 + 0.5 * weights[k],
                Form::Symmetric => 0.5 * weights[k],
            }
        };
        let same_offsets = |i: usize| -> bool {
            let (a, b) = (offsets[i - 1]..offsets[i], offsets[i]..offsets[i + 1]);
            a.len() == b.len()
                && a.zip(b)
                    .all(|(ka, kb)| neighbours[kb] == neighbours[ka] + 1)
        };
        let mut plan = Plan::default();
        plan.gather_ptr.push(0);
        let mut first = 0;
        while first < n {
            let mut end = first + 1;
            while end < n && same_offsets(end) {
                end += 1;
            }
            let len = end - first;
            if len >= MIN_RUN && !gather_all {
                let taps = offsets[first]..offsets[first + 1];
                let t0 = plan.tap_starts.len();
                plan.tap_starts
                    .extend(taps.clone().map(|k| 3 * neighbours[k]));
                let shared = (first..end).all(|i| {
                    taps.clone().all(|k| {
                        let (w0, w) = (
                            effective(first, k),
                            effective(i, k - offsets[first] + offsets[i]),
                        );
                        (w - w0).abs() <= STENCIL_WEIGHT_RTOL * w0.abs()
                    })
                });
                let weights = if shared {
                    let w0 = plan.shared_weights.len();
                    plan.shared_weights
                        .extend(taps.clone().map(|k| effective(first, k)));
                    RunWeights::Shared(w0..plan.shared_weights.len())
                } else {
                    let w0 = plan.per_particle_weights.len();
                    for s in 0..taps.len() {
                        plan.per_particle_weights
                            .extend((first..end).map(|i| effective(i, offsets[i] + s)));
                    }
                    RunWeights::PerParticle(w0)
                };
                plan.runs.push(Run {
                    first,
                    len,
                    taps: t0..plan.tap_starts.len(),
                    weights,
                });
            } else {
                for i in first..end {
                    plan.gather_particles.push(i as u32);
                    for k in offsets[i]..offsets[i + 1] {
                        plan.gather_index.push(neighbours[k] as u32);
                        plan.gather_weight.push(effective(i, k));
                    }
                    plan.gather_ptr.push(plan.gather_index.len() as u32);
                }
            }
            first = end;
        }
        Ok(plan)
    }

    /// `dst <- F src` for all particles (pinned ones included), compiled
    /// for the best instruction set of this CPU (AVX2 and FMA on x86-64
    /// when present, checked at run time by `pulp::Arch::dispatch`; the
    /// stencil loops vectorise four doubles wide) without `unsafe` here.
    fn apply(&self, src: &[f64], dst: &mut [f64]) {
        struct Apply<'a> {
            plan: &'a Plan,
            src: &'a [f64],
            dst: &'a mut [f64],
        }
        impl pulp::WithSimd for Apply<'_> {
            type Output = ();
            #[inline(always)]
            fn with_simd<S: pulp::Simd>(self, simd: S) {
                self.plan.apply_with(simd, self.src, self.dst);
            }
        }
        pulp::Arch::new().dispatch(Apply {
            plan: self,
            src,
            dst,
        });
    }

    /// The body of [`apply`](Self::apply), inlined into each instruction-set
    /// version `simd`.
    #[inline(always)]
    fn apply_with<S: pulp::Simd>(&self, simd: S, src: &[f64], dst: &mut [f64]) {
        for run in &self.runs {
            let out = &mut dst[3 * run.first..3 * (run.first + run.len)];
            let starts = &self.tap_starts[run.taps.clone()];
            match &run.weights {
                RunWeights::Shared(w) => {
                    shared_stencil(simd, src, out, starts, &self.shared_weights[w.clone()])
                }
                RunWeights::PerParticle(w0) => {
                    let w = &self.per_particle_weights[*w0..*w0 + starts.len() * run.len];
                    per_particle_stencil(src, out, starts, w)
                }
            }
        }
        let (old, _) = src.as_chunks::<3>();
        let (out, _) = dst.as_chunks_mut::<3>();
        for (p, &i) in self.gather_particles.iter().enumerate() {
            let r = self.gather_ptr[p] as usize..self.gather_ptr[p + 1] as usize;
            let mut acc = [0.0; 3];
            for (&j, &w) in self.gather_index[r.clone()]
                .iter()
                .zip(&self.gather_weight[r])
            {
                let vj = &old[j as usize];
                acc[0] += w * vj[0];
                acc[1] += w * vj[1];
                acc[2] += w * vj[2];
            }
            out[i as usize] = acc;
        }
    }
}

/// A run with shared weights: `out[k] = sum_s w_s src[start_s + k]` for
/// every component `k` of the run, in register blocks.
#[inline(always)]
fn shared_stencil<S: pulp::Simd>(
    simd: S,
    src: &[f64],
    out: &mut [f64],
    starts: &[usize],
    w: &[f64],
) {
    let (blocks, rest) = out.as_chunks_mut::<BLOCK>();
    let mut base = 0;
    for ob in blocks {
        shared_block(simd, src, ob, base, starts, w);
        base += BLOCK;
    }
    let (blocks, tail) = rest.as_chunks_mut::<SMALL_BLOCK>();
    for ob in blocks {
        shared_block(simd, src, ob, base, starts, w);
        base += SMALL_BLOCK;
    }
    for (t, o) in tail.iter_mut().enumerate() {
        let k = base + t;
        *o = starts
            .iter()
            .zip(w)
            .map(|(&st, &ws)| ws * src[st + k])
            .sum();
    }
}

/// One register block of a shared-weight run, `ob[t] = sum_s w_s
/// src[start_s + base + t]`, accumulated with fused multiply-adds where the
/// instruction set has them (`mul_add_e`: one rounding per tap there, two
/// elsewhere).
#[inline(always)]
fn shared_block<S: pulp::Simd, const B: usize>(
    simd: S,
    src: &[f64],
    ob: &mut [f64; B],
    base: usize,
    starts: &[usize],
    w: &[f64],
) {
    let mut acc = [0.0; B];
    let (acc_v, acc_t) = S::as_mut_simd_f64s(&mut acc);
    for (&st, &ws) in starts.iter().zip(w) {
        let (x_v, x_t) = S::as_simd_f64s(&src[st + base..st + base + B]);
        let wv = simd.splat_f64s(ws);
        for (a, &x) in acc_v.iter_mut().zip(x_v) {
            *a = simd.mul_add_e_f64s(wv, x, *a);
        }
        for (a, &x) in acc_t.iter_mut().zip(x_t) {
            *a += ws * x;
        }
    }
    *ob = acc;
}

/// A run with per-particle weights `w[s len + p]`:
/// `out_p = sum_s w[s len + p] src_{p + o_s}`, in blocks of particles.
#[inline(always)]
fn per_particle_stencil(src: &[f64], out: &mut [f64], starts: &[usize], w: &[f64]) {
    let len = out.len() / 3;
    let (blocks, tail) = out.as_chunks_mut::<{ 3 * PARTICLE_BLOCK }>();
    let mut p0 = 0;
    for ob in blocks {
        let mut acc = [0.0; 3 * PARTICLE_BLOCK];
        for (s, &st) in starts.iter().enumerate() {
            let x = &src[st + 3 * p0..st + 3 * (p0 + PARTICLE_BLOCK)];
            let ws = &w[s * len + p0..s * len + p0 + PARTICLE_BLOCK];
            for p in 0..PARTICLE_BLOCK {
                for c in 0..3 {
                    acc[3 * p + c] += ws[p] * x[3 * p + c];
                }
            }
        }
        *ob = acc;
        p0 += PARTICLE_BLOCK;
    }
    let (tail, _) = tail.as_chunks_mut::<3>();
    for (t, o) in tail.iter_mut().enumerate() {
        let p = p0 + t;
        let mut acc = [0.0; 3];
        for (s, &st) in starts.iter().enumerate() {
            let ws = w[s * len + p];
            for c in 0..3 {
                acc[c] += ws * src[st + 3 * p + c];
            }
        }
        *o = acc;
    }
}

impl VelocityFilter {
    /// Builds the filter for `n_particles` particles joined by `edges`;
    /// `pinned[i]` (if given, length `n_particles`) keeps particle `i` unfiltered.
    ///
    /// # Errors
    /// [`FilterError::InvalidLambda`] for lambda <= 0 or NaN,
    /// [`FilterError::InvalidRadius`] for `rings == 0`,
    /// [`FilterError::InvalidSpring`] for an index out of range or a rest length
    /// that is not positive and finite, [`FilterError::DimensionMismatch`] for a
    /// `pinned` mask of the wrong length.
    pub fn new(
        n_particles: usize,
        edges: &[Edge],
        pinned: Option<&[bool]>,
        options: FilterOptions,
    ) -> Result<Self, FilterError> {
        let lambda = options.kernel.lambda();
        if !(lambda > 0.0 && lambda.is_finite()) {
            return Err(FilterError::InvalidLambda { lambda });
        }
        if options.rings == 0 {
            return Err(FilterError::InvalidRadius { rings: 0 });
        }
        if let Some(p) = pinned
            && p.len() != n_particles
        {
            return Err(FilterError::DimensionMismatch {
                what: "pinned mask",
                expected: n_particles,
                found: p.len(),
            });
        }
        let mut shortest = f64::INFINITY;
        for (k, e) in edges.iter().enumerate() {
            if e.i >= n_particles || e.j >= n_particles || e.i == e.j {
                return Err(FilterError::InvalidSpring {
                    index: k,
                    message: format!(
                        "particles ({}, {}) with {} particles in the model",
                        e.i, e.j, n_particles
                    ),
                });
            }
            if !(e.rest_length > 0.0 && e.rest_length.is_finite()) {
                return Err(FilterError::InvalidSpring {
                    index: k,
                    message: format!("rest length {} is not positive", e.rest_length),
                });
            }
            shortest = shortest.min(e.rest_length);
        }
        // Adjacency of the spring graph with edge lengths in units of the shortest spring.
        let mut degree = vec![0usize; n_particles + 1];
        for e in edges {
            degree[e.i + 1] += 1;
            degree[e.j + 1] += 1;
        }
        for i in 0..n_particles {
            degree[i + 1] += degree[i];
        }
        let adj_ptr = degree;
        let mut fill = adj_ptr.clone();
        let mut adj = vec![(0usize, 0.0f64); adj_ptr[n_particles]];
        for e in edges {
            let d = e.rest_length / shortest;
            adj[fill[e.i]] = (e.j, d);
            fill[e.i] += 1;
            adj[fill[e.j]] = (e.i, d);
            fill[e.j] += 1;
        }
        // k-ring shortest distances by a bounded Bellman-Ford per particle
        // (rings are small: the work is O(n * ring size * degree)).
        let mut offsets = Vec::with_capacity(n_particles + 1);
        let mut neighbours = Vec::new();
        let mut weights = Vec::new();
        offsets.push(0);
        let mut dist = vec![f64::INFINITY; n_particles];
        let mut hops = vec![usize::MAX; n_particles];
        let mut ring: Vec<usize> = Vec::new();
        let mut frontier: Vec<usize> = Vec::new();
        let mut next: Vec<usize> = Vec::new();
        for i in 0..n_particles {
            ring.clear();
            frontier.clear();
            dist[i] = 0.0;
            hops[i] = 0;
            ring.push(i);
            frontier.push(i);
            for h in 1..=options.rings {
                next.clear();
                for &u in &frontier {
                    for &(w, len) in &adj[adj_ptr[u]..adj_ptr[u + 1]] {
                        if hops[w] == usize::MAX {
                            hops[w] = h;
                            ring.push(w);
                            next.push(w);
                        }
                        let nd = dist[u] + len;
                        if nd < dist[w] {
                            dist[w] = nd;
                        }
                    }
                }
                std::mem::swap(&mut frontier, &mut next);
                if frontier.is_empty() {
                    break; // the whole connected component is in the ring
                }
            }
            // Relax distances inside the ring until stable (paths may revisit
            // ring members through shorter chains).
            loop {
                let mut changed = false;
                for &u in &ring {
                    for &(w, len) in &adj[adj_ptr[u]..adj_ptr[u + 1]] {
                        if hops[w] != usize::MAX && dist[u] + len < dist[w] {
                            dist[w] = dist[u] + len;
                            changed = true;
                        }
                    }
                }
                if !changed {
                    break;
                }
            }
            ring.sort_unstable();
            let start = weights.len();
            let mut sum = 0.0;
            for &w in &ring {
                let b = options.kernel.beta(dist[w]);
                neighbours.push(w);
                weights.push(b);
                sum += b;
            }
            for b in &mut weights[start..] {
                *b /= sum;
            }
            offsets.push(neighbours.len());
            for &w in &ring {
                dist[w] = f64::INFINITY;
                hops[w] = usize::MAX;
            }
        }
        let plan = Plan::build(
            &offsets,
            &neighbours,
            &weights,
            options.form,
            options.current_distances,
        )?;
        let pinned = pinned.map_or_else(|| vec![false; n_particles], <[bool]>::to_vec);
        let pinned_list = (0..n_particles).filter(|&i| pinned[i]).collect();
        Ok(Self {
            options,
            offsets,
            neighbours,
            weights,
            pinned,
            pinned_list,
            plan,
            scratch: vec![0.0; 3 * n_particles],
            unit: if shortest.is_finite() { shortest } else { 1.0 },
        })
    }

    /// With [`FilterOptions::current_distances`], recomputes the weights
    /// from the positions `x` (3 per particle): `d_ij = |x_j - x_i|` in
    /// units of the shortest rest length, `beta(d_ij)` normalised over each
    /// neighbourhood (the paper's `beta_j^{t + dt}`). Without it, only
    /// checks the length of `x`. Allocates nothing.
    ///
    /// # Errors
    /// [`FilterError::DimensionMismatch`] if `x.len() != 3 n_particles`,
    /// [`FilterError::NonFinite`] for a non-finite position.
    pub fn update_distances(&mut self, x: &[f64]) -> Result<(), FilterError> {
        let n = self.n_particles();
        if x.len() != 3 * n {
            return Err(FilterError::DimensionMismatch {
                what: "positions",
                expected: 3 * n,
                found: x.len(),
            });
        }
        if !self.options.current_distances {
            return Ok(());
        }
        let (p, _) = x.as_chunks::<3>();
        let kernel = self.options.kernel;
        let form = self.options.form;
        let inv_unit = 1.0 / self.unit;
        for i in 0..n {
            let r = self.offsets[i]..self.offsets[i + 1];
            let mut sum = 0.0;
            for k in r.clone() {
                let q = &p[self.neighbours[k]];
                let d2 =
                    (q[0] - p[i][0]).powi(2) + (q[1] - p[i][1]).powi(2) + (q[2] - p[i][2]).powi(2);
                let b = kernel.beta(d2.sqrt() * inv_unit);
                self.weights[k] = b;
                sum += b;
            }
            if !(sum > 0.0 && sum.is_finite()) {
                return Err(FilterError::NonFinite { what: "positions" });
            }
            for k in r {
                self.weights[k] /= sum;
            }
        }
        // Every particle is gathered (see `Plan::build`), in particle order,
        // its taps in neighbourhood order: refill the effective weights.
        for (w, (k, i)) in
            self.plan.gather_weight.iter_mut().zip(
                (0..n).flat_map(|i| (self.offsets[i]..self.offsets[i + 1]).map(move |k| (k, i))),
            )
        {
            *w = match form {
                Form::Plain => self.weights[k],
                Form::Symmetric if self.neighbours[k] == i => 0.5 + 0.5 * self.weights[k],
                Form::Symmetric => 0.5 * self.weights[k],
            };
        }
        Ok(())
    }

    /// Builds the filter on the spring graph of a mass-spring model: one
    /// [`Edge`] per spring (its rest length), and the model's pinned
    /// particles (fully constrained, [`ParticleConstraint::Pinned`]) left
    /// unfiltered. Sliding particles are filtered; the integrator
    /// re-imposes their constraints in its next step.
    ///
    /// # Errors
    /// As [`new`](Self::new).
    pub fn from_model(
        model: &MassSpringModel,
        options: FilterOptions,
    ) -> Result<Self, FilterError> {
        let n = model.n_particles();
        let edges: Vec<Edge> = model.springs().iter().map(Edge::from).collect();
        let pinned: Vec<bool> = (0..n)
            .map(|p| matches!(model.constraint(p), Ok(ParticleConstraint::Pinned { .. })))
            .collect();
        Self::new(n, &edges, Some(&pinned), options)
    }

    /// How the filter evaluates its particles: stencil runs and gathers.
    pub fn plan_stats(&self) -> PlanStats {
        let mut st = PlanStats {
            stencil_runs: self.plan.runs.len(),
            gathered_particles: self.plan.gather_particles.len(),
            ..Default::default()
        };
        for r in &self.plan.runs {
            match r.weights {
                RunWeights::Shared(_) => st.shared_weight_particles += r.len,
                RunWeights::PerParticle(_) => st.per_particle_weight_particles += r.len,
            }
        }
        st
    }

    /// Whether particle `i` is pinned (kept unfiltered); `false` out of range.
    pub fn is_pinned(&self, i: usize) -> bool {
        self.pinned.get(i).copied().unwrap_or(false)
    }

    /// Number of particles.
    pub fn n_particles(&self) -> usize {
        self.offsets.len() - 1
    }

    /// The options it was built with.
    pub fn options(&self) -> &FilterOptions {
        &self.options
    }

    /// The neighbours of particle `i` (itself included) and their normalised weights.
    pub fn neighbourhood(&self, i: usize) -> (&[usize], &[f64]) {
        let r = self.offsets[i]..self.offsets[i + 1];
        (&self.neighbours[r.clone()], &self.weights[r])
    }

    /// Makes exactly the particles whose velocity `constraints` prescribe in
    /// all three directions pinned (kept unfiltered): the step's pins, read
    /// from the model through the integrator. Allocates nothing unless the
    /// set changed.
    ///
    /// # Errors
    /// [`FilterError::DimensionMismatch`] if `constraints` are for another
    /// number of particles.
    pub fn pin_fully_constrained(&mut self, constraints: &Constraints) -> Result<(), FilterError> {
        let n = self.n_particles();
        if constraints.n_particles() != n {
            return Err(FilterError::DimensionMismatch {
                what: "constraints (particles)",
                expected: n,
                found: constraints.n_particles(),
            });
        }
        let full = || {
            constraints
                .counts()
                .filter(|&(_, c)| c == 3)
                .map(|(p, _)| p)
        };
        if full().count() == self.pinned_list.len() && full().all(|p| self.pinned[p]) {
            return Ok(());
        }
        for &p in &self.pinned_list {
            self.pinned[p] = false;
        }
        self.pinned_list.clear();
        self.pinned_list.extend(full());
        self.pinned_list.sort_unstable();
        for &p in &self.pinned_list {
            self.pinned[p] = true;
        }
        Ok(())
    }

    /// Marks particle `i` as pinned (its velocity is left alone) or free.
    ///
    /// # Errors
    /// [`FilterError::DimensionMismatch`] if `i` is out of range.
    pub fn set_pinned(&mut self, i: usize, pinned: bool) -> Result<(), FilterError> {
        let n = self.n_particles();
        match self.pinned.get_mut(i) {
            Some(p) => {
                *p = pinned;
                match (self.pinned_list.binary_search(&i), pinned) {
                    (Err(at), true) => self.pinned_list.insert(at, i),
                    (Ok(at), false) => {
                        self.pinned_list.remove(at);
                    }
                    _ => {}
                }
                Ok(())
            }
            None => Err(FilterError::DimensionMismatch {
                what: "particle index",
                expected: n,
                found: i,
            }),
        }
    }

    /// Filters the velocities `v` (3 per particle) in place: `v <- F v`
    /// (eq. 10, symmetric or plain form; pinned particles unchanged).
    /// Allocates nothing (the input is copied to an internal buffer; use
    /// [`apply_to`](Self::apply_to) to avoid the copy).
    ///
    /// # Errors
    /// [`FilterError::DimensionMismatch`] if `v.len() != 3 n_particles`.
    pub fn apply(&mut self, v: &mut [f64]) -> Result<(), FilterError> {
        let n = self.n_particles();
        if v.len() != 3 * n {
            return Err(FilterError::DimensionMismatch {
                what: "velocity vector",
                expected: 3 * n,
                found: v.len(),
            });
        }
        self.apply_unchecked(v);
        Ok(())
    }

    /// Filters `src` into `dst`: `dst <- F src` (eq. 10; pinned particles
    /// copied unchanged). Reads `src` once per neighbourhood, copies nothing
    /// and allocates nothing.
    ///
    /// # Errors
    /// [`FilterError::DimensionMismatch`] if `src` or `dst` is not `3 n_particles` long.
    pub fn apply_to(&self, src: &[f64], dst: &mut [f64]) -> Result<(), FilterError> {
        self.check_lengths([
            ("source velocity vector", src.len()),
            ("destination velocity vector", dst.len()),
        ])?;
        self.apply_to_unchecked(src, dst);
        Ok(())
    }

    /// [`FilterError::DimensionMismatch`] for the first `(what, length)` that
    /// is not `3 n_particles`.
    fn check_lengths<const K: usize>(
        &self,
        vectors: [(&'static str, usize); K],
    ) -> Result<(), FilterError> {
        let expected = 3 * self.n_particles();
        match vectors.into_iter().find(|&(_, len)| len != expected) {
            Some((what, found)) => Err(FilterError::DimensionMismatch {
                what,
                expected,
                found,
            }),
            None => Ok(()),
        }
    }

    /// The filter as a linear map, for the modified power method: `v <- F v`.
    /// Same as [`apply`](Self::apply) for vectors of the right length.
    pub(crate) fn apply_unchecked(&mut self, v: &mut [f64]) {
        let mut scratch = std::mem::take(&mut self.scratch);
        scratch.copy_from_slice(v);
        self.apply_to_unchecked(&scratch, v);
        self.scratch = scratch;
    }

    fn apply_to_unchecked(&self, src: &[f64], dst: &mut [f64]) {
        self.plan.apply(src, dst);
        for &p in &self.pinned_list {
            dst[3 * p..3 * p + 3].copy_from_slice(&src[3 * p..3 * p + 3]);
        }
    }

    /// The increment coupling's whole update of a step
    /// ([`FilterCoupling::Increment`](crate::FilterCoupling::Increment)):
    /// with `v` the integrator's `v_{n+1}` and `prev` its `v_n`,
    /// `dv <- v - prev`, `v <- prev + F dv`, `x <- x + h (F dv - dv)` and
    /// `prev <- v`. One instruction-set dispatch for the three passes, so
    /// the two element-wise passes run as wide as the stencil (AVX2 where
    /// the CPU has it) rather than at the baseline width.
    ///
    /// # Errors
    /// [`FilterError::DimensionMismatch`] unless all four vectors are
    /// `3 n_particles` long.
    pub(crate) fn apply_increment(
        &self,
        v: &mut [f64],
        x: &mut [f64],
        prev: &mut [f64],
        dv: &mut [f64],
        h: f64,
    ) -> Result<(), FilterError> {
        self.check_lengths([
            ("velocity vector", v.len()),
            ("position vector", x.len()),
            ("previous velocity vector", prev.len()),
            ("velocity increment vector", dv.len()),
        ])?;
        struct Increment<'a> {
            filter: &'a VelocityFilter,
            v: &'a mut [f64],
            x: &'a mut [f64],
            prev: &'a mut [f64],
            dv: &'a mut [f64],
            h: f64,
        }
        impl pulp::WithSimd for Increment<'_> {
            type Output = ();
            #[inline(always)]
            fn with_simd<S: pulp::Simd>(self, simd: S) {
                let Increment {
                    filter,
                    v,
                    x,
                    prev,
                    dv,
                    h,
                } = self;
                for ((d, r), p) in dv.iter_mut().zip(v.iter()).zip(prev.iter()) {
                    *d = r - p;
                }
                filter.plan.apply_with(simd, dv, v);
                for &p in &filter.pinned_list {
                    v[3 * p..3 * p + 3].copy_from_slice(&dv[3 * p..3 * p + 3]);
                }
                // v holds F dv: x += h (F dv - dv), v = v_n + F dv.
                for (((v, x), d), p) in v
                    .iter_mut()
                    .zip(x.iter_mut())
                    .zip(dv.iter())
                    .zip(prev.iter_mut())
                {
                    *x += h * (*v - d);
                    *v += *p;
                    *p = *v;
                }
            }
        }
        pulp::Arch::new().dispatch(Increment {
            filter: self,
            v,
            x,
            prev,
            dv,
            h,
        });
        Ok(())
    }
}

#[cfg(test)]
mod tests;
