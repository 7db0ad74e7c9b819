//! The velocity filter of Ahmad et al. (section 4.1, eq. 10).

use hookean_massspring::{MassSpringModel, ParticleConstraint};

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
}

impl Default for FilterOptions {
    fn default() -> Self {
        Self {
            kernel: Kernel::Exponential { lambda: 1.0 },
            form: Form::Symmetric,
            rings: 1,
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
#[derive(Debug, Clone)]
pub struct VelocityFilter {
    options: FilterOptions,
    offsets: Vec<usize>,
    neighbours: Vec<usize>,
    weights: Vec<f64>,
    pinned: Vec<bool>,
    scratch: Vec<f64>,
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
        Ok(Self {
            options,
            offsets,
            neighbours,
            weights,
            pinned: pinned.map_or_else(|| vec![false; n_particles], <[bool]>::to_vec),
            scratch: vec![0.0; 3 * n_particles],
        })
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
        let edges: Vec<Edge> = model
            .springs()
            .iter()
            .map(|s| Edge {
                i: s.i,
                j: s.j,
                rest_length: s.rest_length,
            })
            .collect();
        let pinned: Vec<bool> = (0..n)
            .map(|p| matches!(model.constraint(p), Ok(ParticleConstraint::Pinned { .. })))
            .collect();
        Self::new(n, &edges, Some(&pinned), options)
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

    /// Marks particle `i` as pinned (its velocity is left alone) or free.
    ///
    /// # Errors
    /// [`FilterError::DimensionMismatch`] if `i` is out of range.
    pub fn set_pinned(&mut self, i: usize, pinned: bool) -> Result<(), FilterError> {
        let n = self.n_particles();
        match self.pinned.get_mut(i) {
            Some(p) => {
                *p = pinned;
                Ok(())
            }
            None => Err(FilterError::DimensionMismatch {
                what: "particle index",
                expected: n,
                found: i,
            }),
        }
    }

    /// Filters the velocities `v` (3 per particle) in place. Allocates nothing.
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
        self.scratch.copy_from_slice(v);
        self.apply_from_scratch(v);
        Ok(())
    }

    /// The filter as a linear map, for the modified power method: `v <- F v`.
    /// Same as [`apply`](Self::apply) for vectors of the right length.
    pub(crate) fn apply_unchecked(&mut self, v: &mut [f64]) {
        self.scratch.copy_from_slice(v);
        self.apply_from_scratch(v);
    }

    fn apply_from_scratch(&self, v: &mut [f64]) {
        let (old, _) = self.scratch.as_chunks::<3>();
        let (out, _) = v.as_chunks_mut::<3>();
        let symmetric = self.options.form == Form::Symmetric;
        for i in 0..old.len() {
            if self.pinned[i] {
                continue;
            }
            let mut acc = [0.0; 3];
            for k in self.offsets[i]..self.offsets[i + 1] {
                let w = self.weights[k];
                let vj = &old[self.neighbours[k]];
                acc[0] += w * vj[0];
                acc[1] += w * vj[1];
                acc[2] += w * vj[2];
            }
            out[i] = if symmetric {
                let vi = old[i];
                [
                    0.5 * (vi[0] + acc[0]),
                    0.5 * (vi[1] + acc[1]),
                    0.5 * (vi[2] + acc[2]),
                ]
            } else {
                acc
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chain(n: usize) -> Vec<Edge> {
        (1..n)
            .map(|i| Edge {
                i: i - 1,
                j: i,
                rest_length: 0.5,
            })
            .collect()
    }

    #[test]
    fn weights_follow_the_exponential_kernel_and_sum_to_one() {
        let f = VelocityFilter::new(5, &chain(5), None, FilterOptions::default()).unwrap();
        let (nb, w) = f.neighbourhood(2);
        assert_eq!(nb, &[1, 2, 3]);
        // beta(0) = 1, beta(1) = e^-1 for lambda = 1, normalised.
        let total = 1.0 + 2.0 * (-1.0f64).exp();
        assert!((w[1] - 1.0 / total).abs() < 1e-15);
        assert!((w[0] - (-1.0f64).exp() / total).abs() < 1e-15);
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-15);
    }

    #[test]
    fn two_rings_use_path_lengths_in_units_of_the_shortest_spring() {
        // A triangle 0-1 (1), 1-2 (1), 0-2 (3 units): 2 is at distance 2 from 0 through 1.
        let edges = [
            Edge {
                i: 0,
                j: 1,
                rest_length: 1.0,
            },
            Edge {
                i: 1,
                j: 2,
                rest_length: 1.0,
            },
            Edge {
                i: 0,
                j: 2,
                rest_length: 3.0,
            },
        ];
        let opts = FilterOptions {
            kernel: Kernel::Exponential { lambda: 2.0 },
            form: Form::Plain,
            rings: 2,
        };
        let f = VelocityFilter::new(3, &edges, None, opts).unwrap();
        let (nb, w) = f.neighbourhood(0);
        assert_eq!(nb, &[0, 1, 2]);
        let b = [1.0, (-2.0f64).exp(), (-4.0f64).exp()];
        let s: f64 = b.iter().sum();
        for k in 0..3 {
            assert!((w[k] - b[k] / s).abs() < 1e-15);
        }
    }

    #[test]
    fn uniform_velocity_is_unchanged_and_pinned_particles_keep_theirs() {
        let mut f = VelocityFilter::new(
            4,
            &chain(4),
            Some(&[true, false, false, false]),
            FilterOptions::default(),
        )
        .unwrap();
        let mut v = [1.0, 2.0, 3.0].repeat(4);
        f.apply(&mut v).unwrap();
        for c in v.chunks(3) {
            assert!(
                (c[0] - 1.0).abs() < 1e-15
                    && (c[1] - 2.0).abs() < 1e-15
                    && (c[2] - 3.0).abs() < 1e-15
            );
        }
        let mut v = vec![0.0; 12];
        v[0] = 5.0; // pinned particle 0 moves
        v[3] = 1.0;
        f.apply(&mut v).unwrap();
        assert_eq!(v[0], 5.0);
        // Particle 1 (symmetric form): (v1 + w10 v0 + w11 v1 + w12 v2) / 2.
        let e = (-1.0f64).exp();
        let total = 1.0 + 2.0 * e;
        let expected = 0.5 * (1.0 + (e * 5.0 + 1.0) / total);
        assert!((v[3] - expected).abs() < 1e-14, "{} vs {expected}", v[3]);
    }

    #[test]
    fn alternating_mode_is_damped_more_for_small_lambda() {
        let n = 20;
        let mut amplitude = Vec::new();
        for lambda in [0.5, 1.0, 10.0] {
            let opts = FilterOptions {
                kernel: Kernel::Exponential { lambda },
                ..Default::default()
            };
            let mut f = VelocityFilter::new(n, &chain(n), None, opts).unwrap();
            let mut v: Vec<f64> = (0..n)
                .flat_map(|i| [if i % 2 == 0 { 1.0 } else { -1.0 }, 0.0, 0.0])
                .collect();
            f.apply(&mut v).unwrap();
            amplitude.push(v[3 * 10].abs());
        }
        assert!(
            amplitude[0] < amplitude[1] && amplitude[1] < amplitude[2],
            "{amplitude:?}"
        );
        // lambda = 10 hardly filters: e^-10 weights.
        assert!(amplitude[2] > 0.999);
    }

    #[test]
    fn bad_input_is_a_typed_error() {
        let e = chain(3);
        for lambda in [0.0, -1.0, f64::NAN] {
            let o = FilterOptions {
                kernel: Kernel::Exponential { lambda },
                ..Default::default()
            };
            assert!(matches!(
                VelocityFilter::new(3, &e, None, o),
                Err(FilterError::InvalidLambda { .. })
            ));
        }
        let o = FilterOptions {
            rings: 0,
            ..Default::default()
        };
        assert!(matches!(
            VelocityFilter::new(3, &e, None, o),
            Err(FilterError::InvalidRadius { rings: 0 })
        ));
        let bad = [Edge {
            i: 0,
            j: 7,
            rest_length: 1.0,
        }];
        assert!(matches!(
            VelocityFilter::new(3, &bad, None, FilterOptions::default()),
            Err(FilterError::InvalidSpring { index: 0, .. })
        ));
        let mut f = VelocityFilter::new(3, &e, None, FilterOptions::default()).unwrap();
        assert!(matches!(
            f.apply(&mut [0.0; 8]),
            Err(FilterError::DimensionMismatch {
                expected: 9,
                found: 8,
                ..
            })
        ));
    }
}
