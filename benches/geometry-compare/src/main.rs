//! hookean-geometry against parry3d-f64 on the work the contact does each
//! step (docs/ARCHITECTURE.md, "hookean-geometry and parry3d"):
//!
//! - signed distance of every cloth vertex to a closed collider mesh (the
//!   shipped table, and a finer sphere), through angle-weighted pseudo-normals
//!   on both sides (ours: `TriMesh::closest`; parry: `project_local_point` on a
//!   `TriMesh` with `TriMeshFlags::ORIENTED`);
//! - the refit of a deforming cloth's triangle tree (ours: `Bvh::refit`;
//!   parry: `insert_or_update_partially` on every leaf, then `refit_without_opt`);
//! - all overlapping leaf pairs of that tree (self-collision's candidates;
//!   ours: `Bvh::self_overlaps` on rayon's threads; parry:
//!   `traverse_bvtt_single_tree` and its parallel form).
//!
//! Both libraries get the same meshes and points; the answers are compared
//! (distances, signs, pair sets and their order across thread counts) before
//! any time is printed. Times are the best of `REPEAT` runs.
//!
//! Usage: `geometry-compare [CLOTH_N] [REPEAT]` (defaults 128, 7).

use std::time::Instant;

use hookean_geometry::{Aabb, Bvh, Overlaps, TriMesh};
use nalgebra::Vector3;
use parry3d_f64::bounding_volume::Aabb as PAabb;
use parry3d_f64::math::Vector as PVec;
use parry3d_f64::partitioning::{Bvh as PBvh, BvhBuildStrategy, BvhWorkspace};
use parry3d_f64::query::PointQuery;
use parry3d_f64::shape::{TriMesh as PTriMesh, TriMeshFlags};

type V3 = Vector3<f64>;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let parse = |i: usize, d: usize| -> usize {
        args.get(i).map_or(d, |s| {
            s.parse().unwrap_or_else(|_| {
                eprintln!("geometry-compare: argument {i} ({s:?}) must be a positive integer");
                std::process::exit(2)
            })
        })
    };
    let n = parse(1, 128).max(2);
    let repeat = parse(2, 7).max(1);
    println!(
        "cloth {n} x {n} ({} vertices), best of {repeat}, rayon threads {}",
        n * n,
        rayon::current_num_threads()
    );
    println!(
        "{:<44} {:>12} {:>12} {:>8}",
        "work", "hookean", "parry3d", "ratio"
    );

    let table = read_obj(concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/table.obj"));
    // Over the table: the cloth-table scene's drape, points 0-10 cm above the top (z = 0.5).
    let over_table = grid_points(n, 0.4, |u, v| {
        0.5 + 0.05 * (1.0 + (9.0 * u).sin() * (7.0 * v).cos())
    });
    distances(
        "signed distance, table (30 triangles)",
        &table,
        &over_table,
        repeat,
    );

    let sphere = uv_sphere(0.5, 100, 100);
    // Through the sphere: half the points inside, half outside, all within 0.15 m of it.
    let through_sphere = grid_points(n, 0.6, |u, v| {
        0.45 * (1.0 - u * u - v * v).max(0.0).sqrt() + 0.1 * (5.0 * u).sin()
    });
    distances(
        &format!("signed distance, sphere ({} triangles)", sphere.1.len()),
        &sphere,
        &through_sphere,
        repeat,
    );

    refit_and_pairs(n, repeat);
    open_mesh_side();
}

/// Issue 37's open-mesh case: a point below the plane of a single triangle
/// but beside it (its closest point is a boundary vertex or edge). Ours says
/// outside (the contact leaves it alone); a pseudo-normal that is the face
/// normal on the boundary says inside, and the contact would put the point
/// onto the edge (the 5 J -> 890 J case).
fn open_mesh_side() {
    let tri: Mesh = (
        vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2]],
    );
    let ours = TriMesh::new(tri.0.clone(), tri.1.clone()).expect("a valid mesh");
    let theirs = PTriMesh::with_flags(
        tri.0.iter().map(|p| PVec::new(p[0], p[1], p[2])).collect(),
        vec![[0, 1, 2]],
        TriMeshFlags::ORIENTED,
    )
    .expect("parry accepts the triangle");
    for p in [
        V3::new(-0.5, -0.5, -0.01),
        V3::new(0.5, -0.5, -0.01),
        V3::new(0.2, 0.2, -0.01),
    ] {
        let c = ours.closest(&p);
        let q = theirs.project_local_point(pv(&p), false);
        println!(
            "open mesh, point {:?}: hookean {}, parry3d {}",
            [p.x, p.y, p.z],
            if c.distance < 0.0 {
                "behind"
            } else {
                "outside"
            },
            if q.is_inside { "inside" } else { "outside" }
        );
    }
}

/// A mesh as vertices and triangles.
type Mesh = (Vec<[f64; 3]>, Vec<[usize; 3]>);

fn read_obj(path: &str) -> Mesh {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| {
        eprintln!("geometry-compare: {path}: {e}");
        std::process::exit(1)
    });
    let (mut v, mut f) = (Vec::new(), Vec::new());
    for line in text.lines() {
        let mut w = line.split_whitespace();
        match w.next() {
            Some("v") => {
                let c: Vec<f64> = w.take(3).map(|s| s.parse().expect("a number")).collect();
                v.push([c[0], c[1], c[2]]);
            }
            Some("f") => {
                let i: Vec<usize> = w
                    .map(|s| {
                        s.split('/')
                            .next()
                            .unwrap()
                            .parse::<usize>()
                            .expect("an index")
                            - 1
                    })
                    .collect();
                for k in 1..i.len() - 1 {
                    f.push([i[0], i[k], i[k + 1]]);
                }
            }
            _ => {}
        }
    }
    (v, f)
}

/// A closed sphere of radius `r`, counter-clockwise seen from outside.
fn uv_sphere(r: f64, lat: usize, lon: usize) -> Mesh {
    let mut v = vec![[0.0, 0.0, r]];
    for i in 1..lat {
        let th = std::f64::consts::PI * i as f64 / lat as f64;
        for j in 0..lon {
            let ph = 2.0 * std::f64::consts::PI * j as f64 / lon as f64;
            v.push([
                r * th.sin() * ph.cos(),
                r * th.sin() * ph.sin(),
                r * th.cos(),
            ]);
        }
    }
    v.push([0.0, 0.0, -r]);
    let ring = |i: usize, j: usize| 1 + (i - 1) * lon + j % lon;
    let south = v.len() - 1;
    let mut f = Vec::new();
    for j in 0..lon {
        f.push([0, ring(1, j), ring(1, j + 1)]);
        f.push([south, ring(lat - 1, j + 1), ring(lat - 1, j)]);
    }
    for i in 1..lat - 1 {
        for j in 0..lon {
            let (a, b, c, d) = (
                ring(i, j),
                ring(i, j + 1),
                ring(i + 1, j),
                ring(i + 1, j + 1),
            );
            f.push([a, c, d]);
            f.push([a, d, b]);
        }
    }
    (v, f)
}

/// `n x n` points over `[-half, half]^2` at height `z(u, v)`, `u, v` in [-1, 1].
fn grid_points(n: usize, half: f64, z: impl Fn(f64, f64) -> f64) -> Vec<V3> {
    let mut p = Vec::with_capacity(n * n);
    for i in 0..n {
        for j in 0..n {
            let u = 2.0 * i as f64 / (n - 1) as f64 - 1.0;
            let v = 2.0 * j as f64 / (n - 1) as f64 - 1.0;
            p.push(V3::new(half * u, half * v, z(u, v)));
        }
    }
    p
}

fn pv(p: &V3) -> PVec {
    PVec::new(p.x, p.y, p.z)
}

/// Best wall time of `repeat` calls of `f` (s).
fn best(repeat: usize, mut f: impl FnMut()) -> f64 {
    (0..repeat)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

fn row(work: &str, ours: f64, theirs: f64) {
    println!(
        "{work:<44} {:>10.3} ms {:>10.3} ms {:>8.2}",
        1e3 * ours,
        1e3 * theirs,
        theirs / ours
    );
}

fn distances(work: &str, mesh: &Mesh, points: &[V3], repeat: usize) {
    let ours = TriMesh::new(mesh.0.clone(), mesh.1.clone()).expect("a valid mesh");
    let theirs = PTriMesh::with_flags(
        mesh.0.iter().map(|p| PVec::new(p[0], p[1], p[2])).collect(),
        mesh.1.iter().map(|t| t.map(|i| i as u32)).collect(),
        TriMeshFlags::ORIENTED,
    )
    .expect("parry accepts the mesh");
    // The answers first: the same signed distance from both.
    let (mut inside, mut worst) = (0usize, 0.0f64);
    for p in points {
        let c = ours.closest(p);
        let q = theirs.project_local_point(pv(p), false);
        let d = (pv(p) - q.point).length();
        let signed = if q.is_inside { -d } else { d };
        if c.distance < 0.0 {
            inside += 1;
        }
        assert_eq!(
            c.distance < 0.0,
            q.is_inside,
            "the two disagree on the side of {p:?}"
        );
        worst = worst.max((c.distance - signed).abs());
    }
    assert!(worst < 1e-12, "the two distances differ by {worst:e}");
    let mut sink = 0.0;
    let t_ours = best(repeat, || {
        for p in points {
            sink += ours.closest(p).distance;
        }
    });
    let t_theirs = best(repeat, || {
        for p in points {
            sink += theirs.project_local_point(pv(p), false).point.x;
        }
    });
    std::hint::black_box(sink);
    row(work, t_ours, t_theirs);
    println!(
        "    ({} points, {inside} inside, largest difference {worst:.1e} m)",
        points.len()
    );
}

/// A cloth of `n x n` vertices and its triangles, displaced by a wave at phase `s`.
fn cloth(n: usize, s: f64, x: &mut Vec<V3>) -> Vec<[usize; 3]> {
    x.clear();
    let h = 1.0 / (n - 1) as f64;
    for i in 0..n {
        for j in 0..n {
            let (u, v) = (i as f64 * h, j as f64 * h);
            x.push(V3::new(
                u,
                v,
                0.02 * (12.0 * u + s).sin() * (9.0 * v - s).cos(),
            ));
        }
    }
    let mut t = Vec::new();
    for i in 0..n - 1 {
        for j in 0..n - 1 {
            let a = i * n + j;
            t.push([a, a + n, a + n + 1]);
            t.push([a, a + n + 1, a + 1]);
        }
    }
    t
}

fn tri_box(x: &[V3], t: &[usize; 3], r: f64) -> Aabb {
    let mut b = Aabb::point(&x[t[0]]);
    b.add_point(&x[t[1]]);
    b.add_point(&x[t[2]]);
    b.inflated(r)
}

fn to_parry(b: &Aabb) -> PAabb {
    PAabb::new(PVec::from_array(b.min), PVec::from_array(b.max))
}

fn refit_and_pairs(n: usize, repeat: usize) {
    let mut x = Vec::new();
    let tris = cloth(n, 0.0, &mut x);
    // The self-collision thickness: a third of the grid spacing.
    let r = 1.0 / (3.0 * (n - 1) as f64);
    let boxes: Vec<Aabb> = tris.iter().map(|t| tri_box(&x, t, r)).collect();
    let mut ours = Bvh::build(&boxes);
    let pboxes: Vec<PAabb> = boxes.iter().map(to_parry).collect();
    let mut theirs = PBvh::from_leaves(BvhBuildStrategy::Binned, &pboxes);
    let mut ws = BvhWorkspace::default();
    // A frame later: the wave moved.
    cloth(n, 0.3, &mut x);
    let moved: Vec<Aabb> = tris.iter().map(|t| tri_box(&x, t, r)).collect();
    let t_ours = best(repeat, || ours.refit(|i| moved[i]));
    let t_theirs = best(repeat, || {
        for (i, b) in moved.iter().enumerate() {
            theirs.insert_or_update_partially(to_parry(b), i as u32, 0.0);
        }
        theirs.refit_without_opt();
    });
    row(
        &format!("refit, cloth tree ({} triangles)", tris.len()),
        t_ours,
        t_theirs,
    );

    // All overlapping pairs, as sets, then their order across thread counts.
    let mut overlaps: Overlaps<(u32, u32)> = Overlaps::default();
    let visit = |a: usize, b: usize, out: &mut Vec<(u32, u32)>| {
        out.push((a.min(b) as u32, a.max(b) as u32))
    };
    ours.self_overlaps(&mut overlaps, visit);
    let mut ours_pairs: Vec<(u32, u32)> = overlaps.iter().copied().collect();
    let mut theirs_pairs = Vec::new();
    theirs.traverse_bvtt_single_tree::<false>(&mut ws, &mut |a, b| {
        theirs_pairs.push((a.min(b), a.max(b)))
    });
    let ours_order = ours_pairs.clone();
    ours_pairs.sort_unstable();
    theirs_pairs.sort_unstable();
    theirs_pairs.dedup();
    // parry's tree holds whole leaves; ours tests leaf boxes too: the sets must match.
    assert_eq!(
        ours_pairs, theirs_pairs,
        "the two trees find different overlapping pairs"
    );
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let ours_one: Vec<(u32, u32)> = one.install(|| {
        let mut o = Overlaps::default();
        ours.self_overlaps(&mut o, visit);
        o.iter().copied().collect()
    });
    let theirs_par = |pool: &rayon::ThreadPool| -> Vec<(u32, u32)> {
        pool.install(|| theirs.traverse_bvtt_single_tree_parallel::<false>())
    };
    let two = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    println!(
        "    ({} pairs; order on 1 and 2 threads: hookean {}, parry3d parallel {})",
        ours_pairs.len(),
        if ours_one == ours_order {
            "same"
        } else {
            "differs"
        },
        if theirs_par(&one) == theirs_par(&two) {
            "same"
        } else {
            "differs"
        },
    );
    let t_ours = best(repeat, || {
        ours.self_overlaps(&mut overlaps, visit);
        std::hint::black_box(overlaps.len());
    });
    // The same output as ours: the pairs in a reused vector.
    let t_serial = best(repeat, || {
        theirs_pairs.clear();
        theirs.traverse_bvtt_single_tree::<false>(&mut ws, &mut |a, b| {
            theirs_pairs.push((a.min(b), a.max(b)))
        });
        std::hint::black_box(theirs_pairs.len());
    });
    let t_par = best(repeat, || {
        std::hint::black_box(theirs_par(&two).len());
    });
    row(
        "overlapping pairs (ours threaded, parry serial)",
        t_ours,
        t_serial,
    );
    row("overlapping pairs (both threaded)", t_ours, t_par);
}
