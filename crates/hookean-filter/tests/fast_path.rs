//! The filter's evaluation plan (stencil runs with shared or per-particle
//! weights, gathers, pinned particles) against a dense reference matrix
//! built here from the definition of the weights (eq. 10): for particle
//! `i`, the particles within `rings` hops of the spring graph, their
//! shortest-path distances through those particles in units of the shortest
//! rest length, `beta(d)` normalised to sum 1, the symmetric form
//! `(I + B) / 2`, and identity rows for pinned particles.

use hookean_filter::{Edge, FilterOptions, Form, Kernel, PlanStats, VelocityFilter};
use hookean_massspring::{ClothParams, MeshParams, ObjMesh, cloth, from_mesh};

/// The dense filter matrix `F` (row-major, n x n) from the definition.
fn dense_filter(n: usize, edges: &[Edge], pinned: &[bool], o: &FilterOptions) -> Vec<f64> {
    let shortest = edges
        .iter()
        .map(|e| e.rest_length)
        .fold(f64::INFINITY, f64::min);
    let mut adj = vec![Vec::new(); n];
    for e in edges {
        let d = e.rest_length / shortest;
        adj[e.i].push((e.j, d));
        adj[e.j].push((e.i, d));
    }
    let beta = |d: f64| match o.kernel {
        Kernel::Exponential { lambda } => lambda * (-lambda * d).exp(),
        Kernel::Gaussian { lambda } => (-0.5 * (lambda * d).powi(2)).exp(),
    };
    let mut f = vec![0.0; n * n];
    for i in 0..n {
        if pinned[i] {
            f[i * n + i] = 1.0;
            continue;
        }
        // The k-ring by breadth-first search on hops.
        let mut in_ring = vec![false; n];
        in_ring[i] = true;
        let mut frontier = vec![i];
        for _ in 0..o.rings {
            let mut next = Vec::new();
            for &u in &frontier {
                for &(w, _) in &adj[u] {
                    if !in_ring[w] {
                        in_ring[w] = true;
                        next.push(w);
                    }
                }
            }
            frontier = next;
        }
        // Dijkstra (dense, O(n^2)) on the ring's induced subgraph.
        let mut dist = vec![f64::INFINITY; n];
        let mut done = vec![false; n];
        dist[i] = 0.0;
        loop {
            let u = (0..n)
                .filter(|&u| in_ring[u] && !done[u] && dist[u].is_finite())
                .min_by(|&a, &b| dist[a].total_cmp(&dist[b]));
            let Some(u) = u else { break };
            done[u] = true;
            for &(w, d) in &adj[u] {
                if in_ring[w] && dist[u] + d < dist[w] {
                    dist[w] = dist[u] + d;
                }
            }
        }
        let total: f64 = (0..n).filter(|&j| in_ring[j]).map(|j| beta(dist[j])).sum();
        for j in (0..n).filter(|&j| in_ring[j]) {
            f[i * n + j] = beta(dist[j]) / total;
        }
        if o.form == Form::Symmetric {
            for j in 0..n {
                f[i * n + j] *= 0.5;
            }
            f[i * n + i] += 0.5;
        }
    }
    f
}

/// A deterministic pseudo-random sequence in [-1, 1) (64-bit LCG).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

/// Filters a random velocity with `apply` and `apply_to` and compares both
/// with the dense reference `F v`: the difference must be at the level of
/// rounding (the stencil runs share weights that agree to 1e-13).
fn check_against_dense(n: usize, edges: &[Edge], pinned: &[bool], o: FilterOptions) -> PlanStats {
    let mut filter = VelocityFilter::new(n, edges, Some(pinned), o.clone()).unwrap();
    let f = dense_filter(n, edges, pinned, &o);
    let mut rng = Lcg(n as u64 + 7);
    let v: Vec<f64> = (0..3 * n).map(|_| rng.next()).collect();
    let mut expected = vec![0.0; 3 * n];
    for i in 0..n {
        for j in 0..n {
            for c in 0..3 {
                expected[3 * i + c] += f[i * n + j] * v[3 * j + c];
            }
        }
    }
    let mut out = vec![f64::NAN; 3 * n];
    filter.apply_to(&v, &mut out).unwrap();
    let mut in_place = v.clone();
    filter.apply(&mut in_place).unwrap();
    for k in 0..3 * n {
        assert!(
            (out[k] - expected[k]).abs() < 1e-13,
            "apply_to component {k}: {} vs {}",
            out[k],
            expected[k]
        );
        assert_eq!(
            out[k].to_bits(),
            in_place[k].to_bits(),
            "apply vs apply_to at {k}"
        );
    }
    for i in (0..n).filter(|&i| pinned[i]) {
        assert_eq!(
            &out[3 * i..3 * i + 3],
            &v[3 * i..3 * i + 3],
            "pinned particle {i}"
        );
    }
    filter.plan_stats()
}

fn model_edges(model: &hookean_massspring::MassSpringModel) -> Vec<Edge> {
    model.springs().iter().map(Edge::from).collect()
}

#[test]
fn drape_grid_with_pins_runs_as_stencils_and_matches_the_dense_filter() {
    let n_side = 16;
    let (model, _) = cloth(&ClothParams::drape(n_side)).unwrap();
    let n = model.n_particles();
    let edges = model_edges(&model);
    // Two pinned corners as in the drape, plus one interior particle
    // (inside a stencil run) to check pinning there.
    let mut pinned = vec![false; n];
    pinned[0] = true;
    pinned[n_side - 1] = true;
    pinned[5 * n_side + 7] = true;
    let stats = check_against_dense(n, &edges, &pinned, FilterOptions::default());
    // Rows of the grid are numbered consecutively: in every row, columns
    // 2..N-3 see the same offsets (structural +-1, +-N, shear, bend +-2,
    // +-2N as far as the grid reaches), columns 0, 1, N-2, N-1 each differ.
    assert_eq!(
        stats,
        PlanStats {
            stencil_runs: n_side,
            shared_weight_particles: n_side * (n_side - 4),
            per_particle_weight_particles: 0,
            gathered_particles: 4 * n_side,
        }
    );
    // The plain form takes the same paths; with two rings (bend springs
    // reach 4 columns) the runs are columns 4..N-5 of every row.
    let plain = FilterOptions {
        form: Form::Plain,
        ..Default::default()
    };
    assert_eq!(check_against_dense(n, &edges, &pinned, plain), stats);
    let two_rings = FilterOptions {
        kernel: Kernel::Gaussian { lambda: 0.7 },
        rings: 2,
        ..Default::default()
    };
    let s = check_against_dense(n, &edges, &pinned, two_rings);
    assert_eq!(s.stencil_runs, n_side);
    assert_eq!(s.shared_weight_particles, n_side * (n_side - 8));
    assert_eq!(s.gathered_particles, 8 * n_side);
}

#[test]
fn unevenly_spaced_grid_uses_per_particle_weights_and_matches_the_dense_filter() {
    // A 12 x 10 grid whose column spacing grows (x_c = c + 0.05 c^2): every
    // particle of a row has the same neighbour offsets but its own weights.
    let (cols, rows) = (12, 10);
    let x = |c: usize| c as f64 + 0.05 * (c * c) as f64;
    let pos = |r: usize, c: usize| [x(c), r as f64];
    let id = |r: usize, c: usize| r * cols + c;
    let mut edges = Vec::new();
    let mut add = |a: (usize, usize), b: (usize, usize)| {
        let (p, q) = (pos(a.0, a.1), pos(b.0, b.1));
        edges.push(Edge {
            i: id(a.0, a.1),
            j: id(b.0, b.1),
            rest_length: ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt(),
        });
    };
    for r in 0..rows {
        for c in 0..cols {
            if c + 1 < cols {
                add((r, c), (r, c + 1));
            }
            if r + 1 < rows {
                add((r, c), (r + 1, c));
            }
            if c + 1 < cols && r + 1 < rows {
                add((r, c), (r + 1, c + 1));
                add((r, c + 1), (r + 1, c));
            }
            if c + 2 < cols {
                add((r, c), (r, c + 2));
            }
            if r + 2 < rows {
                add((r, c), (r + 2, c));
            }
        }
    }
    let n = rows * cols;
    let mut pinned = vec![false; n];
    pinned[id(0, 0)] = true;
    pinned[id(4, 6)] = true;
    let stats = check_against_dense(n, &edges, &pinned, FilterOptions::default());
    assert_eq!(stats.stencil_runs, rows);
    assert_eq!(stats.per_particle_weight_particles, rows * (cols - 4));
    assert_eq!(stats.shared_weight_particles, 0);
    assert_eq!(stats.gathered_particles, 4 * rows);
}

#[test]
fn rope_matches_the_dense_filter() {
    // A chain: the interior shares offsets (-1, 0, +1) and weights.
    let n = 25;
    let edges: Vec<Edge> = (1..n)
        .map(|i| Edge {
            i: i - 1,
            j: i,
            rest_length: 0.04,
        })
        .collect();
    let mut pinned = vec![false; n];
    pinned[0] = true;
    let stats = check_against_dense(n, &edges, &pinned, FilterOptions::default());
    assert_eq!(
        stats,
        PlanStats {
            stencil_runs: 1,
            shared_weight_particles: n - 2,
            per_particle_weight_particles: 0,
            gathered_particles: 2,
        }
    );
    let stats = check_against_dense(
        n,
        &edges,
        &pinned,
        FilterOptions {
            rings: 3,
            form: Form::Plain,
            ..Default::default()
        },
    );
    assert_eq!(stats.shared_weight_particles, n - 6);
}

#[test]
fn irregular_mesh_with_shuffled_vertices_is_gathered_and_matches_the_dense_filter() {
    // An OBJ-like mesh: a jittered 9 x 9 grid, each quad split along a
    // pseudo-random diagonal, vertices numbered in a shuffled order, edge and
    // bend springs from `from_mesh`.
    let side = 9;
    let mut rng = Lcg(42);
    let mut perm: Vec<usize> = (0..side * side).collect();
    for k in (1..perm.len()).rev() {
        let j = ((rng.next() + 1.0) * 0.5 * (k + 1) as f64) as usize;
        perm.swap(k, j.min(k));
    }
    let mut positions = vec![[0.0; 3]; side * side];
    for r in 0..side {
        for c in 0..side {
            positions[perm[r * side + c]] = [
                0.1 * (c as f64 + 0.3 * rng.next()),
                0.1 * (r as f64 + 0.3 * rng.next()),
                0.01 * rng.next(),
            ];
        }
    }
    let mut triangles = Vec::new();
    for r in 0..side - 1 {
        for c in 0..side - 1 {
            let [a, b, d, e] = [
                perm[r * side + c],
                perm[r * side + c + 1],
                perm[(r + 1) * side + c],
                perm[(r + 1) * side + c + 1],
            ];
            if rng.next() > 0.0 {
                triangles.push([a, b, e]);
                triangles.push([a, e, d]);
            } else {
                triangles.push([a, b, d]);
                triangles.push([b, e, d]);
            }
        }
    }
    let (model, _) = from_mesh(
        &ObjMesh {
            positions,
            triangles,
            ..ObjMesh::default()
        },
        &MeshParams::default(),
    )
    .unwrap();
    let n = model.n_particles();
    let edges = model_edges(&model);
    let mut pinned = vec![false; n];
    pinned[3] = true;
    pinned[40] = true;
    let stats = check_against_dense(n, &edges, &pinned, FilterOptions::default());
    assert_eq!(stats.gathered_particles, n, "{stats:?}");
    check_against_dense(
        n,
        &edges,
        &pinned,
        FilterOptions {
            kernel: Kernel::Exponential { lambda: 0.3 },
            rings: 2,
            ..Default::default()
        },
    );
}

#[test]
fn set_pinned_after_construction_is_respected_inside_a_stencil_run() {
    let n = 12;
    let edges: Vec<Edge> = (1..n)
        .map(|i| Edge {
            i: i - 1,
            j: i,
            rest_length: 1.0,
        })
        .collect();
    let mut f = VelocityFilter::new(n, &edges, None, FilterOptions::default()).unwrap();
    f.set_pinned(6, true).unwrap();
    f.set_pinned(6, true).unwrap();
    let v: Vec<f64> = (0..3 * n)
        .map(|k| if k / 3 == 6 { 1.0 } else { 0.0 })
        .collect();
    let mut out = vec![0.0; 3 * n];
    f.apply_to(&v, &mut out).unwrap();
    assert_eq!(&out[18..21], &[1.0, 1.0, 1.0]);
    // Its neighbours: (0 + w_i,i+1 * 1) / 2 with w = e^-1 / (1 + 2 e^-1).
    let e = (-1.0f64).exp();
    assert!((out[15] - 0.5 * e / (1.0 + 2.0 * e)).abs() < 1e-15);
    f.set_pinned(6, false).unwrap();
    f.apply_to(&v, &mut out).unwrap();
    assert!((out[18] - 0.5 * (1.0 + 1.0 / (1.0 + 2.0 * e))).abs() < 1e-15);
    assert!(!f.is_pinned(6));
}
