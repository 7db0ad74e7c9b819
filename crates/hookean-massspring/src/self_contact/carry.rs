//! What cloth self-collision carries from one step into the next
//! ([`SelfCarried`]): kept before a step so that a step redone in
//! substeps starts from it, and written into a checkpoint.

use hookean_geometry::Bvh;

use super::{Candidate, SelfContact};

/// What a [`SelfContact`] carries from one step into the next: the
/// candidate list (its radius, reference positions and pairs, in their
/// order), the motion of the last detected step (which picks the next
/// list's margin) and the shape of the tree (its leaf order; the tree is
/// built once and refitted). Everything else is scratch or recomputed
/// from the state at the step's start (the proximity pairs, the boxes,
/// the impact zones). Kept with [`SelfContact::keep_carried`] (no
/// allocation once grown), restored with [`SelfContact::restore_carried`].
#[derive(Debug, Clone, Default)]
pub(crate) struct SelfCarried {
    radius: f64,
    last_move: f64,
    reference: Vec<f64>,
    candidates: Vec<Candidate>,
    /// The tree's leaf order; empty before the tree is built.
    tree_order: Vec<u32>,
}

/// Numbers per candidate in [`SelfCarried::write`]: four particles and the
/// edge-edge flag.
const CANDIDATE_NUMBERS: usize = 5;

impl SelfCarried {
    /// Appends the state as numbers to `out`: `[R, M, n_x, reference (n_x
    /// numbers), n_c, candidates (5 each: particles, edge-edge 0/1), n_t,
    /// leaf order (n_t numbers)]` (integers below 2^32, exact as `f64`).
    pub(crate) fn write(&self, out: &mut Vec<f64>) {
        out.extend([self.radius, self.last_move, self.reference.len() as f64]);
        out.extend_from_slice(&self.reference);
        out.push(self.candidates.len() as f64);
        for c in &self.candidates {
            out.extend(c.idx.map(f64::from));
            out.push(f64::from(u8::from(c.ee)));
        }
        out.push(self.tree_order.len() as f64);
        out.extend(self.tree_order.iter().map(|&t| f64::from(t)));
    }

    /// Reads [`write`](Self::write)'s numbers for `n` particles and
    /// `n_tris` triangles from the front of `s`: the state and the count
    /// of numbers read, or what does not fit.
    pub(crate) fn read(s: &[f64], n: usize, n_tris: usize) -> Result<(Self, usize), String> {
        let mut at = 0;
        let mut take = |k: usize, what: &str| -> Result<&[f64], String> {
            let part = s
                .get(at..at + k)
                .ok_or_else(|| format!("the self-collision state ends inside its {what}"))?;
            at += k;
            Ok(part)
        };
        let count = |v: f64, what: &str| -> Result<usize, String> {
            if v >= 0.0 && v.fract() == 0.0 && v <= u32::MAX as f64 {
                Ok(v as usize)
            } else {
                Err(format!("the self-collision {what} {v} is not a count"))
            }
        };
        let head = take(3, "header")?;
        let (radius, last_move) = (head[0], head[1]);
        if !(radius >= 0.0 && radius.is_finite() && last_move >= 0.0) {
            return Err(format!(
                "the self-collision list's radius {radius} or motion {last_move} is not a length"
            ));
        }
        let n_x = count(head[2], "reference length")?;
        if n_x != 0 && n_x != 3 * n {
            return Err(format!(
                "the self-collision reference has {n_x} numbers, this model {}",
                3 * n
            ));
        }
        let reference = take(n_x, "reference positions")?.to_vec();
        let n_c = count(take(1, "candidate count")?[0], "candidate count")?;
        let mut candidates = Vec::with_capacity(n_c.min(s.len() / CANDIDATE_NUMBERS));
        for _ in 0..n_c {
            let c = take(CANDIDATE_NUMBERS, "candidates")?;
            let mut idx = [0u32; 4];
            for (i, &v) in idx.iter_mut().zip(&c[..4]) {
                let p = count(v, "candidate particle")?;
                if p >= n {
                    return Err(format!(
                        "a self-collision candidate names particle {p} of {n}"
                    ));
                }
                *i = p as u32;
            }
            let ee = match c[4] {
                0.0 => false,
                1.0 => true,
                f => return Err(format!("a candidate's edge-edge flag {f} is not 0 or 1")),
            };
            candidates.push(Candidate { idx, ee });
        }
        let n_t = count(take(1, "tree size")?[0], "tree size")?;
        if n_t != 0 && n_t != n_tris {
            return Err(format!(
                "the self-collision tree has {n_t} triangles, this model {n_tris}"
            ));
        }
        let tree_order = take(n_t, "tree order")?
            .iter()
            .map(|&v| count(v, "tree entry").map(|t| t as u32))
            .collect::<Result<Vec<u32>, String>>()?;
        Ok((
            Self {
                radius,
                last_move,
                reference,
                candidates,
                tree_order,
            },
            at,
        ))
    }
}

impl SelfContact {
    /// Copies what carries over to the next step into `into` (storage
    /// reused: no allocation once it has grown).
    pub(crate) fn keep_carried(&self, into: &mut SelfCarried) {
        into.radius = self.radius;
        into.last_move = self.last_move;
        into.reference.clone_from(&self.reference);
        into.candidates.clone_from(&self.candidates);
        into.tree_order.clear();
        if let Some(bvh) = &self.bvh {
            into.tree_order.extend_from_slice(bvh.leaf_order());
        }
    }

    /// Makes `from` ([`keep_carried`](Self::keep_carried)'s, or a
    /// checkpoint's [`SelfCarried::read`]) the state the next step starts
    /// from: after it, the next steps are those of the state it was kept
    /// from, bit for bit. The tree is rebuilt from its leaf order only when
    /// that differs (its boxes are refitted before every use).
    ///
    /// # Errors
    /// A message for a leaf order that is not a permutation of the
    /// triangles.
    pub(crate) fn restore_carried(&mut self, from: &SelfCarried) -> Result<(), String> {
        let same_tree = match &self.bvh {
            Some(bvh) => bvh.leaf_order() == from.tree_order.as_slice(),
            None => from.tree_order.is_empty(),
        };
        if !same_tree {
            self.bvh = if from.tree_order.is_empty() {
                None
            } else {
                Some(
                    Bvh::with_leaf_order(&self.tbox, &from.tree_order).ok_or_else(|| {
                        "the self-collision tree's order is not a permutation of the triangles"
                            .to_string()
                    })?,
                )
            };
        }
        self.radius = from.radius;
        self.last_move = from.last_move;
        self.reference.clone_from(&from.reference);
        self.candidates.clone_from(&from.candidates);
        Ok(())
    }
}
