//! A bounding volume hierarchy of axis-aligned boxes, up to four
//! primitives per leaf: built once per topology (median splits along the longest axis of
//! the centroids, a deterministic order), refitted in place when the
//! primitives move, queried by box, by nearest primitive, and for all
//! overlapping pairs of its own leaves (self-collision), on rayon threads
//! with results in a fixed order.

use nalgebra::Vector3;
use rayon::prelude::*;

use crate::aabb::Aabb;

const NONE: u32 = u32::MAX;

/// Primitives per leaf: a leaf tests its primitives' own boxes, which is
/// cheaper than descending two more levels of nodes.
const LEAF: usize = 4;

#[derive(Debug, Clone, Copy)]
struct Node {
    aabb: Aabb,
    /// Children (internal nodes) or `NONE` for leaves.
    left: u32,
    right: u32,
    /// A leaf's primitives: `order[first..first + count]`.
    first: u32,
    count: u32,
}

impl Node {
    fn is_leaf(&self) -> bool {
        self.left == NONE
    }
}

/// A binary tree of boxes over primitives `0..n`; node 0 is the root, every
/// parent is stored before its children (so a reverse sweep refits).
///
/// ```
/// use hookean_geometry::{Aabb, Bvh};
/// use nalgebra::Vector3;
///
/// let boxes: Vec<Aabb> = (0..10)
///     .map(|i| Aabb::point(&Vector3::new(i as f64, 0.0, 0.0)).inflated(0.6))
///     .collect();
/// let bvh = Bvh::build(&boxes);
/// let mut hits = Vec::new();
/// bvh.for_each_overlap(&Aabb::point(&Vector3::new(4.5, 0.0, 0.0)), |i| hits.push(i));
/// hits.sort();
/// assert_eq!(hits, [4, 5]);
/// ```
#[derive(Debug, Clone)]
pub struct Bvh {
    nodes: Vec<Node>,
    /// Primitives in leaf order.
    order: Vec<u32>,
    /// The primitives' boxes (of the last build or refit).
    boxes: Vec<Aabb>,
}

/// Pairs of overlapping leaves found by [`Bvh::self_overlaps`], in a fixed
/// order (independent of the thread count): per task, the pairs each task
/// produced. Keep it between calls so that its storage is reused.
#[derive(Debug, Clone)]
pub struct Overlaps<T> {
    tasks: Vec<(u32, u32)>,
    out: Vec<Vec<T>>,
}

impl<T> Default for Overlaps<T> {
    fn default() -> Self {
        Self {
            tasks: Vec::new(),
            out: Vec::new(),
        }
    }
}

impl<T> Overlaps<T> {
    /// Everything the visitor emitted, task by task in a fixed order.
    pub fn iter(&self) -> impl Iterator<Item = &T> {
        self.out.iter().flatten()
    }

    /// Number of items emitted.
    pub fn len(&self) -> usize {
        self.out.iter().map(Vec::len).sum()
    }

    /// True when nothing was emitted.
    pub fn is_empty(&self) -> bool {
        self.out.iter().all(Vec::is_empty)
    }
}

/// Top-level tasks of a threaded self-overlap traversal: enough to keep the
/// threads busy, few enough that the task list stays small.
const TASKS: usize = 128;

impl Bvh {
    /// Builds the tree over `boxes` (primitive `i` has box `boxes[i]`).
    /// An empty slice gives an empty tree.
    pub fn build(boxes: &[Aabb]) -> Self {
        let centers: Vec<Vector3<f64>> = boxes.iter().map(Aabb::center).collect();
        Self::grow(boxes, (0..boxes.len() as u32).collect(), |order, k| {
            let mut cb = Aabb::EMPTY;
            for &p in order.iter() {
                cb.add_point(&centers[p as usize]);
            }
            let e = cb.extent();
            let axis = if e.x >= e.y && e.x >= e.z {
                0
            } else if e.y >= e.z {
                1
            } else {
                2
            };
            // A total order (coordinate, index): the same tree on every run.
            order.select_nth_unstable_by(k, |&a, &b| {
                centers[a as usize][axis]
                    .total_cmp(&centers[b as usize][axis])
                    .then(a.cmp(&b))
            });
        })
    }

    /// The tree whose [`leaf_order`](Self::leaf_order) is `order`, over
    /// `boxes`: the tree of that order is unique (every node splits its
    /// range of the order at its middle, as [`build`](Self::build) does), so
    /// this gives back the shape of a built tree, traversals in the same
    /// order, from its leaf order alone (a checkpoint's). `None` unless
    /// `order` is a permutation of `0..boxes.len()`.
    pub fn with_leaf_order(boxes: &[Aabb], order: &[u32]) -> Option<Self> {
        let n = boxes.len();
        if order.len() != n {
            return None;
        }
        let mut seen = vec![false; n];
        for &p in order {
            let slot = seen.get_mut(p as usize)?;
            if std::mem::replace(slot, true) {
                return None;
            }
        }
        Some(Self::grow(boxes, order.to_vec(), |_, _| {}))
    }

    /// The primitives in the order of the leaves (left to right): with
    /// [`with_leaf_order`](Self::with_leaf_order), the tree's shape.
    pub fn leaf_order(&self) -> &[u32] {
        &self.order
    }

    /// The tree over `boxes` whose nodes split their range of `order` at
    /// its middle, `partition(range, k)` first putting the range's `k`
    /// smallest primitives (by the split's rule) before the others.
    fn grow(boxes: &[Aabb], order: Vec<u32>, mut partition: impl FnMut(&mut [u32], usize)) -> Self {
        let n = boxes.len();
        let mut bvh = Bvh {
            nodes: Vec::with_capacity((2 * n / LEAF + 1).max(1)),
            order,
            boxes: boxes.to_vec(),
        };
        if n == 0 {
            return bvh;
        }
        let leaf = |first: usize, count: usize| Node {
            aabb: Aabb::EMPTY,
            left: NONE,
            right: NONE,
            first: first as u32,
            count: count as u32,
        };
        bvh.nodes.push(leaf(0, n));
        // Explicit stack of (node, range) to build without recursion.
        let mut stack = vec![(0usize, 0usize, n)];
        while let Some((node, lo, hi)) = stack.pop() {
            if hi - lo <= LEAF {
                continue;
            }
            let mid = lo + (hi - lo) / 2;
            partition(&mut bvh.order[lo..hi], mid - lo);
            let left = bvh.nodes.len();
            bvh.nodes.push(leaf(lo, mid - lo));
            bvh.nodes.push(leaf(mid, hi - mid));
            bvh.nodes[node].left = left as u32;
            bvh.nodes[node].right = left as u32 + 1;
            stack.push((left + 1, mid, hi));
            stack.push((left, lo, mid));
        }
        bvh.refit(|i| boxes[i]);
        bvh
    }

    /// Number of primitives.
    pub fn len(&self) -> usize {
        self.order.len()
    }

    /// True for a tree without primitives.
    pub fn is_empty(&self) -> bool {
        self.order.is_empty()
    }

    /// The box of the whole tree ([`Aabb::EMPTY`] when empty).
    pub fn root_aabb(&self) -> Aabb {
        self.nodes.first().map_or(Aabb::EMPTY, |n| n.aabb)
    }

    /// The primitives of a leaf.
    fn prims(&self, nd: &Node) -> &[u32] {
        &self.order[nd.first as usize..(nd.first + nd.count) as usize]
    }

    /// Replaces every primitive's box by `aabb(primitive)` and recomputes
    /// the nodes' boxes bottom-up. The tree's shape is kept (its quality
    /// degrades gracefully under the small motions of one time step). No
    /// allocation.
    pub fn refit(&mut self, aabb: impl Fn(usize) -> Aabb) {
        for (i, b) in self.boxes.iter_mut().enumerate() {
            *b = aabb(i);
        }
        for k in (0..self.nodes.len()).rev() {
            let nd = self.nodes[k];
            self.nodes[k].aabb = if nd.is_leaf() {
                self.prims(&nd)
                    .iter()
                    .fold(Aabb::EMPTY, |b, &p| b.union(&self.boxes[p as usize]))
            } else {
                self.nodes[nd.left as usize]
                    .aabb
                    .union(&self.nodes[nd.right as usize].aabb)
            };
        }
    }

    /// Calls `f(primitive)` for every primitive whose box overlaps `query`.
    pub fn for_each_overlap(&self, query: &Aabb, mut f: impl FnMut(usize)) {
        if !self.nodes.is_empty() {
            self.overlap_rec(0, query, &mut f);
        }
    }

    fn overlap_rec(&self, k: usize, query: &Aabb, f: &mut impl FnMut(usize)) {
        let nd = &self.nodes[k];
        if !nd.aabb.overlaps(query) {
            return;
        }
        if nd.is_leaf() {
            for &p in self.prims(nd) {
                if self.boxes[p as usize].overlaps(query) {
                    f(p as usize);
                }
            }
        } else {
            self.overlap_rec(nd.left as usize, query, f);
            self.overlap_rec(nd.right as usize, query, f);
        }
    }

    /// The primitive nearest to `p` and its squared distance, by branch and
    /// bound: `dist2(primitive)` is the exact squared distance from `p` to a
    /// primitive, never less than the squared distance to its box. Ties go
    /// to the primitive visited first (a fixed order). `None` when empty.
    pub fn nearest(
        &self,
        p: &Vector3<f64>,
        mut dist2: impl FnMut(usize) -> f64,
    ) -> Option<(usize, f64)> {
        if self.nodes.is_empty() {
            return None;
        }
        let mut best = (NONE as usize, f64::INFINITY);
        self.nearest_rec(0, p, &mut dist2, &mut best);
        (best.0 != NONE as usize).then_some(best)
    }

    fn nearest_rec(
        &self,
        k: usize,
        p: &Vector3<f64>,
        dist2: &mut impl FnMut(usize) -> f64,
        best: &mut (usize, f64),
    ) {
        let nd = &self.nodes[k];
        if nd.is_leaf() {
            for &q in self.prims(nd) {
                if self.boxes[q as usize].distance_squared(p) < best.1 {
                    let d = dist2(q as usize);
                    if d < best.1 {
                        *best = (q as usize, d);
                    }
                }
            }
            return;
        }
        let (l, r) = (nd.left as usize, nd.right as usize);
        let (dl, dr) = (
            self.nodes[l].aabb.distance_squared(p),
            self.nodes[r].aabb.distance_squared(p),
        );
        let (first, df, second, ds) = if dl <= dr {
            (l, dl, r, dr)
        } else {
            (r, dr, l, dl)
        };
        if df < best.1 {
            self.nearest_rec(first, p, dist2, best);
        }
        if ds < best.1 {
            self.nearest_rec(second, p, dist2, best);
        }
    }

    /// Every unordered pair `{i, j}` (`i != j`) of primitives whose boxes
    /// overlap, handed to `visit(i, j, out)` (with `i < j`), which may push
    /// results into `out`. Runs on the rayon pool in up to 128 tasks whose
    /// outputs are kept in task order, so the results are the same for every
    /// thread count and every run.
    pub fn self_overlaps<T: Send>(
        &self,
        overlaps: &mut Overlaps<T>,
        visit: impl Fn(usize, usize, &mut Vec<T>) + Sync,
    ) {
        overlaps.tasks.clear();
        if self.nodes.is_empty() {
            for o in &mut overlaps.out {
                o.clear();
            }
            return;
        }
        // Expand (a, a) self tasks and (a, b) pair tasks level by level;
        // pairs of disjoint nodes are dropped.
        overlaps.tasks.push((0, 0));
        loop {
            let end = overlaps.tasks.len();
            if end >= TASKS {
                break;
            }
            let mut expanded = false;
            for t in 0..end {
                let (a, b) = overlaps.tasks[t];
                let (na, nb) = (self.nodes[a as usize], self.nodes[b as usize]);
                if a == b && !na.is_leaf() {
                    overlaps.tasks.push((na.left, na.left));
                    overlaps.tasks.push((na.right, na.right));
                    overlaps.tasks.push((na.left, na.right));
                    expanded = true;
                } else if a != b && na.aabb.overlaps(&nb.aabb) && !(na.is_leaf() && nb.is_leaf()) {
                    if !na.is_leaf() {
                        overlaps.tasks.push((na.left, b));
                        overlaps.tasks.push((na.right, b));
                    } else {
                        overlaps.tasks.push((a, nb.left));
                        overlaps.tasks.push((a, nb.right));
                    }
                    expanded = true;
                } else if a == b || na.aabb.overlaps(&nb.aabb) {
                    // A leaf, or two overlapping leaves: a task of its own.
                    overlaps.tasks.push((a, b));
                }
            }
            overlaps.tasks.drain(..end);
            if !expanded {
                break;
            }
        }
        let n_tasks = overlaps.tasks.len();
        if overlaps.out.len() < n_tasks {
            overlaps.out.resize_with(n_tasks, Vec::new);
        }
        for o in &mut overlaps.out[n_tasks..] {
            o.clear();
        }
        let tasks = &overlaps.tasks;
        overlaps.out[..n_tasks]
            .par_iter_mut()
            .enumerate()
            .for_each(|(t, out)| {
                out.clear();
                let (a, b) = tasks[t];
                if a == b {
                    self.self_rec(a as usize, &visit, out);
                } else {
                    self.pair_rec(a as usize, b as usize, &visit, out);
                }
            });
    }

    fn self_rec<T>(&self, k: usize, visit: &impl Fn(usize, usize, &mut Vec<T>), out: &mut Vec<T>) {
        let nd = &self.nodes[k];
        if nd.is_leaf() {
            let prims = self.prims(nd);
            for (x, &i) in prims.iter().enumerate() {
                for &j in &prims[x + 1..] {
                    self.visit_prims(i, j, visit, out);
                }
            }
            return;
        }
        self.self_rec(nd.left as usize, visit, out);
        self.self_rec(nd.right as usize, visit, out);
        self.pair_rec(nd.left as usize, nd.right as usize, visit, out);
    }

    #[inline]
    fn visit_prims<T>(
        &self,
        i: u32,
        j: u32,
        visit: &impl Fn(usize, usize, &mut Vec<T>),
        out: &mut Vec<T>,
    ) {
        let (i, j) = (i as usize, j as usize);
        if self.boxes[i].overlaps(&self.boxes[j]) {
            visit(i.min(j), i.max(j), out);
        }
    }

    fn pair_rec<T>(
        &self,
        a: usize,
        b: usize,
        visit: &impl Fn(usize, usize, &mut Vec<T>),
        out: &mut Vec<T>,
    ) {
        let (na, nb) = (&self.nodes[a], &self.nodes[b]);
        if !na.aabb.overlaps(&nb.aabb) {
            return;
        }
        match (na.is_leaf(), nb.is_leaf()) {
            (true, true) => {
                for &i in self.prims(na) {
                    if !self.boxes[i as usize].overlaps(&nb.aabb) {
                        continue;
                    }
                    for &j in self.prims(nb) {
                        self.visit_prims(i, j, visit, out);
                    }
                }
            }
            (true, false) => {
                self.pair_rec(a, nb.left as usize, visit, out);
                self.pair_rec(a, nb.right as usize, visit, out);
            }
            (false, true) => {
                self.pair_rec(na.left as usize, b, visit, out);
                self.pair_rec(na.right as usize, b, visit, out);
            }
            (false, false) => {
                // Descend the larger box first (a fixed rule).
                let ea = na.aabb.extent();
                let eb = nb.aabb.extent();
                if ea.x + ea.y + ea.z >= eb.x + eb.y + eb.z {
                    self.pair_rec(na.left as usize, b, visit, out);
                    self.pair_rec(na.right as usize, b, visit, out);
                } else {
                    self.pair_rec(a, nb.left as usize, visit, out);
                    self.pair_rec(a, nb.right as usize, visit, out);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::SmallRng;
    use rand::{Rng, SeedableRng};

    fn random_boxes(n: usize, seed: u64) -> Vec<Aabb> {
        let mut rng = SmallRng::seed_from_u64(seed);
        (0..n)
            .map(|_| {
                let c = Vector3::new(
                    rng.random::<f64>(),
                    rng.random::<f64>(),
                    rng.random::<f64>(),
                );
                Aabb::point(&c).inflated(0.02 + 0.03 * rng.random::<f64>())
            })
            .collect()
    }

    #[test]
    fn self_overlaps_equal_brute_force_for_every_thread_count() {
        for n in [0, 1, 2, 3, 7, 300] {
            let boxes = random_boxes(n, n as u64 + 1);
            let bvh = Bvh::build(&boxes);
            let mut brute = Vec::new();
            for i in 0..n {
                for j in i + 1..n {
                    if boxes[i].overlaps(&boxes[j]) {
                        brute.push((i, j));
                    }
                }
            }
            let mut runs = Vec::new();
            for threads in [1, 2, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let mut ov = Overlaps::default();
                pool.install(|| bvh.self_overlaps(&mut ov, |i, j, out| out.push((i, j))));
                runs.push(ov.iter().copied().collect::<Vec<_>>());
            }
            assert_eq!(runs[0], runs[1]);
            assert_eq!(runs[0], runs[2]);
            let mut got = runs[0].clone();
            got.sort();
            assert_eq!(got, brute, "n = {n}");
        }
    }

    #[test]
    fn queries_and_nearest_match_brute_force_after_refit() {
        let boxes = random_boxes(200, 7);
        let mut bvh = Bvh::build(&boxes);
        // Move every box and refit.
        let moved: Vec<Aabb> = boxes
            .iter()
            .map(|b| {
                let mut m = *b;
                for k in 0..3 {
                    m.min[k] = 1.0 - b.max[k];
                    m.max[k] = 1.0 - b.min[k];
                }
                m
            })
            .collect();
        bvh.refit(|i| moved[i]);
        let q = Aabb::point(&Vector3::new(0.3, 0.6, 0.5)).inflated(0.1);
        let mut hits = Vec::new();
        bvh.for_each_overlap(&q, |i| hits.push(i));
        hits.sort();
        let brute: Vec<usize> = (0..200).filter(|&i| moved[i].overlaps(&q)).collect();
        assert_eq!(hits, brute);
        let p = Vector3::new(0.25, 0.5, 0.75);
        let d2 = |i: usize| (moved[i].center() - p).norm_squared();
        let (best, d) = bvh.nearest(&p, d2).unwrap();
        let brute_best = (0..200).min_by(|&a, &b| d2(a).total_cmp(&d2(b))).unwrap();
        assert_eq!(d, d2(brute_best));
        assert_eq!(best, brute_best);
    }

    /// The tree rebuilt from a built tree's leaf order (as a checkpoint
    /// restores it) is the same tree: refitted to other boxes, its
    /// traversals visit the pairs in the same order, which a tree built
    /// from those other boxes does not; orders that are not permutations
    /// are refused.
    #[test]
    fn a_tree_rebuilt_from_its_leaf_order_traverses_in_the_same_order() {
        let (first, later) = (random_boxes(300, 3), random_boxes(300, 4));
        let mut built = Bvh::build(&first);
        let mut again = Bvh::with_leaf_order(&later, built.leaf_order()).unwrap();
        built.refit(|i| later[i]);
        again.refit(|i| later[i]);
        let pairs = |bvh: &Bvh| {
            let mut ov = Overlaps::default();
            bvh.self_overlaps(&mut ov, |i, j, out| out.push((i, j)));
            ov.iter().copied().collect::<Vec<_>>()
        };
        let want = pairs(&built);
        assert!(want.len() > 100, "{} pairs", want.len());
        assert_eq!(pairs(&again), want);
        // A tree built from `later` finds the same pairs in another order.
        let fresh = pairs(&Bvh::build(&later));
        assert_ne!(fresh, want);
        let (mut a, mut b) = (fresh, want);
        a.sort_unstable();
        b.sort_unstable();
        assert_eq!(a, b);
        let mut order = built.leaf_order().to_vec();
        order[0] = order[1];
        assert!(Bvh::with_leaf_order(&later, &order).is_none());
        assert!(Bvh::with_leaf_order(&later, &order[1..]).is_none());
        order[0] = 300;
        assert!(Bvh::with_leaf_order(&later, &order).is_none());
    }
}
