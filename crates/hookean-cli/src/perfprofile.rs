//! Dolan-Moré performance profiles and rankings of `hookean bench`'s table.
//!
//! E. D. Dolan and J. J. Moré, "Benchmarking optimization software with
//! performance profiles", Math. Program. 91 (2002): for systems `p` and
//! solvers `s` with costs `t(p, s)` (time, set-up time, iterations, memory;
//! a failure costs infinitely much), the performance ratio is
//! `r(p, s) = t(p, s) / min_s t(p, s)` and solver `s`'s profile is
//! `rho_s(tau) = |{p : r(p, s) <= tau}| / n_p`, the fraction of systems it
//! solves within a factor `tau` of the best solver on each. `rho_s(1)` is
//! the fraction it wins, `rho_s(inf)` the fraction it solves at all.

/// The performance ratios `r(p, s)` of a table of costs, one row per
/// system, one column per solver; `None` (a failure) and every entry of a
/// system no solver solved are infinite. Costs below `floor` (the metric's
/// resolution) count as `floor`, so a zero cost (no set-up) ties with
/// another instead of dividing by zero.
pub fn performance_ratios(costs: &[Vec<Option<f64>>], floor: f64) -> Vec<Vec<f64>> {
    costs
        .iter()
        .map(|row| {
            let cost = |c: &Option<f64>| match c {
                Some(t) if t.is_finite() => t.max(floor),
                _ => f64::INFINITY,
            };
            let best = row.iter().map(cost).fold(f64::INFINITY, f64::min);
            row.iter()
                .map(|c| {
                    if best.is_finite() {
                        cost(c) / best
                    } else {
                        f64::INFINITY
                    }
                })
                .collect()
        })
        .collect()
}

/// `rho_s(tau)`: the fraction of the systems (rows of `ratios`) on which
/// solver `s` is within `tau` of the best; 0 for no systems.
pub fn fraction_within(ratios: &[Vec<f64>], s: usize, tau: f64) -> f64 {
    if ratios.is_empty() {
        return 0.0;
    }
    ratios.iter().filter(|row| row[s] <= tau).count() as f64 / ratios.len() as f64
}

/// Solver `s`'s profile as the corners of its staircase over `[1, tau_max]`:
/// `(1, rho_s(1))`, then at each larger ratio a step up, and a last point
/// at `tau_max`.
pub fn profile_steps(ratios: &[Vec<f64>], s: usize, tau_max: f64) -> Vec<(f64, f64)> {
    let mut taus: Vec<f64> = ratios
        .iter()
        .map(|row| row[s])
        .filter(|&r| r > 1.0 && r <= tau_max)
        .collect();
    taus.sort_by(f64::total_cmp);
    taus.dedup();
    let mut points = vec![(1.0, fraction_within(ratios, s, 1.0))];
    for tau in taus {
        let below = points.last().map_or(0.0, |p| p.1);
        points.push((tau, below));
        points.push((tau, fraction_within(ratios, s, tau)));
    }
    let last = points.last().map_or(0.0, |p| p.1);
    points.push((tau_max, last));
    points
}

/// One solver's place in a [`ranking`].
#[derive(Debug, Clone, PartialEq)]
pub struct Rank {
    /// The solver's column.
    pub solver: usize,
    /// Systems on which it is the best (`r = 1`, ties included).
    pub wins: usize,
    /// Systems it solves.
    pub solved: usize,
    /// The geometric mean of its ratios over the systems it solves (1 for
    /// none).
    pub mean_ratio: f64,
}

/// The solvers from best to worst: most wins, then most systems solved,
/// then the smallest geometric-mean ratio, then the column order.
pub fn ranking(ratios: &[Vec<f64>]) -> Vec<Rank> {
    let solvers = ratios.first().map_or(0, Vec::len);
    let mut ranks: Vec<Rank> = (0..solvers)
        .map(|s| {
            let solved: Vec<f64> = ratios
                .iter()
                .map(|row| row[s])
                .filter(|r| r.is_finite())
                .collect();
            let mean_ratio = if solved.is_empty() {
                1.0
            } else {
                (solved.iter().map(|r| r.ln()).sum::<f64>() / solved.len() as f64).exp()
            };
            Rank {
                solver: s,
                wins: ratios.iter().filter(|row| row[s] == 1.0).count(),
                solved: solved.len(),
                mean_ratio,
            }
        })
        .collect();
    ranks.sort_by(|a, b| {
        b.wins
            .cmp(&a.wins)
            .then(b.solved.cmp(&a.solved))
            .then(a.mean_ratio.total_cmp(&b.mean_ratio))
            .then(a.solver.cmp(&b.solver))
    });
    ranks
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three systems, three solvers, worked out by hand:
    ///
    /// | system | a | b | c |
    /// |---|---|---|---|
    /// | 1 | 1 s | 2 s | failed |
    /// | 2 | 4 s | 2 s | 8 s |
    /// | 3 | failed | 3 s | 3 s |
    ///
    /// Ratios: system 1 (1, 2, inf), system 2 (2, 1, 4), system 3 (inf, 1, 1).
    /// a: rho(1) = 1/3, rho(2) = 2/3, never 1. b: rho(1) = 2/3, rho(2) = 1.
    /// c: rho(1) = 1/3, rho(4) = 2/3.
    fn table() -> Vec<Vec<Option<f64>>> {
        vec![
            vec![Some(1.0), Some(2.0), None],
            vec![Some(4.0), Some(2.0), Some(8.0)],
            vec![None, Some(3.0), Some(3.0)],
        ]
    }

    #[test]
    fn the_profile_of_a_table_worked_by_hand() {
        let r = performance_ratios(&table(), 0.0);
        let inf = f64::INFINITY;
        assert_eq!(
            r,
            vec![
                vec![1.0, 2.0, inf],
                vec![2.0, 1.0, 4.0],
                vec![inf, 1.0, 1.0]
            ]
        );
        let rho = |s, tau| fraction_within(&r, s, tau);
        assert_eq!(
            [rho(0, 1.0), rho(0, 2.0), rho(0, 1e9)],
            [1.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0]
        );
        assert_eq!(
            [rho(1, 1.0), rho(1, 1.99), rho(1, 2.0)],
            [2.0 / 3.0, 2.0 / 3.0, 1.0]
        );
        assert_eq!(
            [rho(2, 1.0), rho(2, 3.9), rho(2, 4.0)],
            [1.0 / 3.0, 1.0 / 3.0, 2.0 / 3.0]
        );
        // The staircase of c: 1/3 from 1, up to 2/3 at 4, flat to 10.
        assert_eq!(
            profile_steps(&r, 2, 10.0),
            vec![
                (1.0, 1.0 / 3.0),
                (4.0, 1.0 / 3.0),
                (4.0, 2.0 / 3.0),
                (10.0, 2.0 / 3.0)
            ]
        );
        // b wins twice; a and c once each, both solve two, and a's ratios
        // (1, 2: geometric mean sqrt 2) beat c's (4, 1: 2).
        let order: Vec<(usize, usize, usize)> = ranking(&r)
            .iter()
            .map(|k| (k.solver, k.wins, k.solved))
            .collect();
        assert_eq!(order, [(1, 2, 3), (0, 1, 2), (2, 1, 2)]);
        let a = &ranking(&r)[1];
        assert!((a.mean_ratio - 2f64.sqrt()).abs() < 1e-15);
    }

    /// A system no solver solves counts against every solver; a zero cost
    /// under the floor ties with the floor.
    #[test]
    fn unsolved_systems_and_zero_costs() {
        let r = performance_ratios(&[vec![None, None], vec![Some(0.0), Some(1e-9)]], 1e-6);
        assert_eq!(r[0], [f64::INFINITY, f64::INFINITY]);
        assert_eq!(r[1], [1.0, 1.0]);
        assert_eq!(fraction_within(&r, 0, f64::MAX), 0.5);
        assert_eq!(fraction_within(&[], 0, 1.0), 0.0);
    }
}
