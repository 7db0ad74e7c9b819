//! `hookean bench --sequence DIR`: the reuse question over a run's
//! sequence of Newton systems (`hookean export-system --every K`, or any
//! folder of numbered systems; [`crate::system_sequence`]): rebuild the
//! preconditioner for every system, refill it, or keep it for a few?
//!
//! Every policy replays the systems in order through the run's own PCG
//! solver (`hookean_nonlinear::PcgSolver`: the same start, constraints,
//! tolerance and iteration limit as the run, from `index.csv`):
//!
//! - `amg-rebuild`: the multigrid set up afresh for every system
//!   (`AmgReuse::Rebuild`);
//! - `amg-refill`: aggregates and patterns of system 1, new values every
//!   system (`AmgReuse::Refill`, the scenes' default);
//! - `amg-keep-N`, N = 2, 4, 8: the hierarchy of one system kept for the
//!   next N, then refilled (`AmgReuse::Keep { updates: N }`, the scene's
//!   `reuse = "keep"`, `keep_updates = N`);
//! - `ic0-rebuild`, `mic0-rebuild`: the factorisation of every system (what
//!   a scene with that preconditioner does);
//! - `ic0-keep-N`, `mic0-keep-N`: one factorisation kept for the next N
//!   systems (a lagged preconditioner, still SPD).
//!
//! Per policy: the total time (set-ups and solves), the mean per system, the
//! iterations, and the break-even point against the same preconditioner
//! rebuilt for every system: the first system from which on the policy's
//! cumulative time stays below the rebuild's ([`break_even`]). The chosen
//! policy is the one of least total time among those that converged on every
//! system ([`choose`]). Written: the table (stdout and `sequence.md`),
//! `sequence.csv` (one row per policy and system) and `cumulative.svg`
//! (cumulative time against the system index). `--repeat` replays every
//! policy that many times, interleaved; each policy's fastest replay is kept.
//!
//! A run with `warm_start` starts the first PCG solve of each step from the
//! previous step's velocity change, which depends on how accurately the
//! run's own preconditioner solved the previous step. A replay of another
//! policy therefore does not start from the recorded guess `x0` but from
//! the guess it would have armed itself ([`OwnWarmStart`]): `x0` plus the
//! sum, over the previous step's solves, of the replay's solution minus the
//! run's (`x.mtx`). Folders without the run's solutions, or with systems
//! left out (`--every K > 1`), are replayed from `x0` as recorded.

use std::path::Path;
use std::time::Instant;

use hookean::nonlinear::{LinearSolver, PcgOptions, PcgSolver};
use hookean_sparse::{AmgOptions, AmgReuse, PrecondKind, SymBlockMatrix};

use crate::CliError;
use crate::lineplot::{LogLogPlot, Series};
use crate::system_sequence::{SequenceSystem, read_sequence};

/// One way of reusing the preconditioner over the sequence.
#[derive(Debug, Clone)]
pub struct Policy {
    /// The name in the table, the CSV and the plot.
    pub name: String,
    kind: PrecondKind,
    /// The multigrid's reuse (set up at every system; it decides).
    amg: Option<AmgReuse>,
    /// Systems that keep a factorisation after the one it was made for.
    keep: usize,
    /// The policy it breaks even against (the same preconditioner rebuilt
    /// for every system); itself for a rebuild.
    baseline: usize,
}

/// The replay's policies, in the table's order.
pub fn policies() -> Vec<Policy> {
    let mut out = Vec::new();
    let mut add = |name: String, kind, amg, keep, baseline| {
        out.push(Policy {
            name,
            kind,
            amg,
            keep,
            baseline,
        });
    };
    add(
        "amg-rebuild".into(),
        PrecondKind::Amg,
        Some(AmgReuse::Rebuild),
        0,
        0,
    );
    add(
        "amg-refill".into(),
        PrecondKind::Amg,
        Some(AmgReuse::Refill),
        0,
        0,
    );
    for n in [2, 4, 8] {
        let reuse = AmgReuse::Keep { updates: n };
        add(format!("amg-keep-{n}"), PrecondKind::Amg, Some(reuse), 0, 0);
    }
    let mic0 = PrecondKind::Mic0 {
        omega: PrecondKind::MIC_OMEGA,
    };
    for (name, kind) in [("ic0", PrecondKind::Ic0), ("mic0", mic0)] {
        let base = 5 + if name == "ic0" { 0 } else { 4 };
        add(format!("{name}-rebuild"), kind, None, 0, base);
        for n in [2, 4, 8] {
            add(format!("{name}-keep-{n}"), kind, None, n, base);
        }
    }
    out
}

/// What one system's replay did.
#[derive(Debug, Clone, PartialEq)]
pub struct SystemResult {
    pub setup_s: f64,
    pub solve_s: f64,
    pub iterations: usize,
    pub converged: bool,
    /// Why the set-up or the solve failed.
    pub error: Option<String>,
}

/// The tolerance and iteration limit of systems without a row of `index.csv`.
#[derive(Debug, Clone, Copy)]
pub struct Fallback {
    pub rtol: f64,
    pub max_iter: Option<usize>,
}

/// The warm start a policy arms itself in a replay (module doc): a step's
/// first solve starts from the run's guess `x0` plus `d`, the sum over the
/// previous step's solves of the replay's solution minus the run's. In the
/// run, `x0 = V_prev - v_prev - (V - v)`, the last step's velocity change
/// (`hookean_ode`'s `begin_stage`), and the replay starts every step from
/// the run's state, so its last velocity change differs from the run's by
/// exactly `d`.
struct OwnWarmStart {
    /// Whether the correction applies: every system carries the run's
    /// solution and the solves are consecutive.
    on: bool,
    /// The step of the last recorded solve, and the sums `d` of that step
    /// and of the step before it.
    step: Option<usize>,
    this_step: Vec<f64>,
    last_step: Vec<f64>,
}

impl OwnWarmStart {
    fn new(systems: &[SequenceSystem]) -> Self {
        let n = systems.first().map_or(0, |s| s.b.len());
        let consecutive = systems.windows(2).all(|w| match (&w[0].run, &w[1].run) {
            (Some(a), Some(b)) => b.solve == a.solve + 1,
            _ => false,
        });
        let on = consecutive && systems.iter().all(|s| s.x.is_some() && s.run.is_some());
        Self {
            on,
            step: None,
            this_step: vec![0.0; if on { n } else { 0 }],
            last_step: vec![0.0; if on { n } else { 0 }],
        }
    }

    /// Before `system`'s solve: its step begins (the sums move on), and
    /// its guess, if it has one, is written into `guess`.
    fn guess(&mut self, system: &SequenceSystem, guess: Option<&mut [f64]>) {
        let step = system.run.as_ref().map(|r| r.step);
        if self.on && step != self.step {
            std::mem::swap(&mut self.this_step, &mut self.last_step);
            self.this_step.fill(0.0);
            self.step = step;
        }
        if let (Some(x0), Some(g)) = (&system.x0, guess) {
            g.copy_from_slice(x0);
            if self.on {
                for (g, d) in g.iter_mut().zip(&self.last_step) {
                    *g += d;
                }
            }
        }
    }

    /// After `system`'s solve with the replay's solution `x`.
    fn solved(&mut self, system: &SequenceSystem, x: &[f64]) {
        if let (true, Some(run)) = (self.on, &system.x) {
            for ((d, a), b) in self.this_step.iter_mut().zip(x).zip(run) {
                *d += a - b;
            }
        }
    }
}

/// Replays `systems` in order with `policy`: one PCG solver, set up as the
/// policy says, each solve from the system's start on its constraints (a
/// warm start corrected to the policy's own, [`OwnWarmStart`]).
pub fn replay(
    policy: &Policy,
    amg: &AmgOptions,
    systems: &[SequenceSystem],
    fallback: Fallback,
) -> Vec<SystemResult> {
    let max_iter = systems
        .first()
        .and_then(|s| s.run.as_ref())
        .map_or(fallback.max_iter, |r| r.max_iter);
    let mut options = PcgOptions {
        max_iter,
        ..PcgOptions::default()
    };
    options.preconditioner.kind = policy.kind;
    options.preconditioner.amg = AmgOptions {
        reuse: policy.amg.unwrap_or_default(),
        ..amg.clone()
    };
    let mut results = Vec::with_capacity(systems.len());
    let mut solver = match PcgSolver::from_options(&options) {
        Ok(s) => s,
        Err(e) => {
            let failed = SystemResult {
                setup_s: 0.0,
                solve_s: 0.0,
                iterations: 0,
                converged: false,
                error: Some(e.to_string()),
            };
            return vec![failed; systems.len()];
        }
    };
    let n = systems.first().map_or(0, |s| s.b.len());
    let mut x = vec![0.0; n];
    let mut ready = false;
    let mut warm = OwnWarmStart::new(systems);
    for (k, system) in systems.iter().enumerate() {
        solver.set_constraints(system.constraints.clone());
        let guess = system.x0.is_some().then(|| solver.arm_guess(n));
        warm.guess(system, guess);
        let set_up = policy.amg.is_some() || !ready || k.is_multiple_of(policy.keep + 1);
        let start = Instant::now();
        let setup = if set_up {
            LinearSolver::<SymBlockMatrix>::setup(&mut solver, &system.a)
        } else {
            Ok(())
        };
        let setup_s = start.elapsed().as_secs_f64();
        ready = setup.is_ok() && (ready || set_up);
        let rtol = system.run.as_ref().map_or(fallback.rtol, |r| r.rtol);
        let start = Instant::now();
        let solved = setup.and_then(|()| solver.solve(&system.a, &system.b, &mut x, rtol));
        let solve_s = start.elapsed().as_secs_f64();
        solver.disarm_guess();
        if solved.is_ok() {
            warm.solved(system, &x);
        }
        results.push(match solved {
            Ok(stats) => SystemResult {
                setup_s,
                solve_s,
                iterations: stats.iterations,
                converged: stats.converged,
                error: None,
            },
            Err(e) => {
                ready = false;
                SystemResult {
                    setup_s,
                    solve_s,
                    iterations: 0,
                    converged: false,
                    error: Some(e.to_string()),
                }
            }
        });
    }
    results
}

/// The running sums of `times`.
pub fn cumulative(times: impl IntoIterator<Item = f64>) -> Vec<f64> {
    times
        .into_iter()
        .scan(0.0, |sum, t| {
            *sum += t;
            Some(*sum)
        })
        .collect()
}

/// The break-even point of a policy against a baseline, from their
/// cumulative times over the same systems: the first system (numbered
/// from one) from which on the policy's cumulative time stays below the
/// baseline's, `None` if it is not below at the last system.
pub fn break_even(policy: &[f64], baseline: &[f64]) -> Option<usize> {
    let below: Vec<bool> = policy.iter().zip(baseline).map(|(p, b)| p < b).collect();
    if !below.last().copied().unwrap_or(false) {
        return None;
    }
    let last_not_below = below.iter().rposition(|b| !b);
    Some(last_not_below.map_or(1, |k| k + 2))
}

/// The chosen policy: the least total time among the policies that
/// converged on every system (the first of equal ones); `None` if none did.
pub fn choose(totals: &[(f64, bool)]) -> Option<usize> {
    totals
        .iter()
        .enumerate()
        .filter(|(_, (t, ok))| *ok && t.is_finite())
        .fold(
            None,
            |best: Option<(usize, f64)>, (k, &(t, _))| match best {
                Some((_, b)) if b <= t => best,
                _ => Some((k, t)),
            },
        )
        .map(|(k, _)| k)
}

/// The settings of a replay from `hookean bench`'s flags.
pub struct SequenceOptions<'a> {
    pub amg: AmgOptions,
    pub fallback: Fallback,
    pub repeat: usize,
    pub quiet: bool,
    pub cap: u64,
    pub dir: &'a Path,
}

/// Reads the sequence in `options.dir`, replays every policy and writes
/// `sequence.md`, `sequence.csv` and `cumulative.svg` into `out`; returns
/// the table for stdout.
pub fn bench_sequence(options: &SequenceOptions<'_>, out: &Path) -> Result<String, CliError> {
    let systems = read_sequence(options.dir, options.cap)?;
    let policies = policies();
    let count = systems.len();
    let mut best: Vec<Option<Vec<SystemResult>>> = vec![None; policies.len()];
    for round in 0..options.repeat {
        for (p, policy) in policies.iter().enumerate() {
            if !options.quiet {
                crate::errln!(
                    "hookean bench: round {}/{}, [{}/{}] {}: {count} systems",
                    round + 1,
                    options.repeat,
                    p + 1,
                    policies.len(),
                    policy.name
                );
            }
            let results = replay(policy, &options.amg, &systems, options.fallback);
            let total = |r: &[SystemResult]| r.iter().map(|s| s.setup_s + s.solve_s).sum::<f64>();
            if best[p].as_ref().is_none_or(|b| total(&results) < total(b)) {
                best[p] = Some(results);
            }
        }
    }
    let results: Vec<Vec<SystemResult>> = best.into_iter().map(Option::unwrap_or_default).collect();
    let cumulatives: Vec<Vec<f64>> = results
        .iter()
        .map(|r| cumulative(r.iter().map(|s| s.setup_s + s.solve_s)))
        .collect();
    let totals: Vec<(f64, bool)> = results
        .iter()
        .zip(&cumulatives)
        .map(|(r, c)| {
            (
                c.last().copied().unwrap_or(0.0),
                r.iter().all(|s| s.converged),
            )
        })
        .collect();
    let chosen = choose(&totals);
    let table = table(&policies, &results, &cumulatives, chosen, &systems);
    crate::output::write_text(&out.join("sequence.md"), &table)?;
    crate::output::write_text(&out.join("sequence.csv"), &csv(&policies, &results))?;
    let plot = LogLogPlot {
        title: format!("Cumulative time of set-ups and solves over {count} systems"),
        x_label: "system".into(),
        y_label: "cumulative time (s)".into(),
        series: policies
            .iter()
            .zip(&cumulatives)
            .map(|(p, c)| Series {
                name: p.name.clone(),
                points: crate::bench::thin(
                    &c.iter()
                        .enumerate()
                        .map(|(k, &t)| ((k + 1) as f64, t))
                        .collect::<Vec<_>>(),
                    crate::bench::PLOT_POINTS,
                ),
            })
            .collect(),
    };
    let svg = plot.render().map_err(CliError::Failed)?;
    crate::output::write_text(&out.join("cumulative.svg"), &svg)?;
    Ok(table)
}

/// The markdown table, the chosen policy and what the run did.
fn table(
    policies: &[Policy],
    results: &[Vec<SystemResult>],
    cumulatives: &[Vec<f64>],
    chosen: Option<usize>,
    systems: &[SequenceSystem],
) -> String {
    let mut md = String::from(
        "| policy | systems | set-up (s) | solve (s) | total (s) | per system (ms) | iterations | converged | break-even vs rebuild |\n\
         |---|---|---|---|---|---|---|---|---|\n",
    );
    for (p, policy) in policies.iter().enumerate() {
        let r = &results[p];
        let setup: f64 = r.iter().map(|s| s.setup_s).sum();
        let solve: f64 = r.iter().map(|s| s.solve_s).sum();
        let total = setup + solve;
        let iterations: usize = r.iter().map(|s| s.iterations).sum();
        let converged = r.iter().filter(|s| s.converged).count();
        let even = if policy.baseline == p {
            "-".to_string()
        } else {
            match break_even(&cumulatives[p], &cumulatives[policy.baseline]) {
                Some(k) => format!("system {k}"),
                None => "never".to_string(),
            }
        };
        let name = if chosen == Some(p) {
            format!("**{}**", policy.name)
        } else {
            policy.name.clone()
        };
        md.push_str(&format!(
            "| {name} | {} | {setup:.3} | {solve:.3} | {total:.3} | {:.3} | {iterations} | {converged}/{} | {even} |\n",
            r.len(),
            1e3 * total / r.len().max(1) as f64,
            r.len(),
        ));
    }
    md.push('\n');
    match chosen {
        Some(p) => md.push_str(&format!(
            "Chosen policy: {} (the least total time among the policies that converged on every system).\n",
            policies[p].name
        )),
        None => md.push_str("Chosen policy: none (no policy converged on every system).\n"),
    }
    let runs: Vec<_> = systems.iter().filter_map(|s| s.run.as_ref()).collect();
    if runs.len() == systems.len() && !runs.is_empty() {
        let iterations: usize = runs.iter().map(|r| r.iterations).sum();
        md.push_str(&format!(
            "The run (index.csv): {} systems, {iterations} PCG iterations.\n",
            runs.len()
        ));
    }
    if let Some((p, k, e)) = results.iter().enumerate().find_map(|(p, r)| {
        r.iter()
            .enumerate()
            .find_map(|(k, s)| s.error.as_ref().map(|e| (p, k, e)))
    }) {
        md.push_str(&format!(
            "First failure: {} on system {}: {e}.\n",
            policies[p].name,
            k + 1
        ));
    }
    md
}

/// `sequence.csv`: one row per policy and system.
fn csv(policies: &[Policy], results: &[Vec<SystemResult>]) -> String {
    let mut s = String::from("policy,system,setup_s,solve_s,iterations,converged\n");
    for (policy, r) in policies.iter().zip(results) {
        for (k, x) in r.iter().enumerate() {
            s.push_str(&format!(
                "{},{},{:e},{:e},{},{}\n",
                policy.name,
                k + 1,
                x.setup_s,
                x.solve_s,
                x.iterations,
                u8::from(x.converged)
            ));
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::system_sequence::IndexRow;
    use hookean_sparse::BlockPattern;
    use std::sync::Arc;

    /// A one-particle system of a sequence: solve number `solve`, in step
    /// `step`, with the run's guess `x0` and solution `x`.
    fn system(
        solve: usize,
        step: usize,
        x0: Option<[f64; 3]>,
        x: Option<[f64; 3]>,
    ) -> SequenceSystem {
        let pattern = Arc::new(BlockPattern::new(1, []).unwrap());
        SequenceSystem {
            a: SymBlockMatrix::new(pattern),
            b: vec![0.0; 3],
            x0: x0.map(|v| v.to_vec()),
            x: x.map(|v| v.to_vec()),
            constraints: None,
            run: Some(IndexRow {
                solve,
                step,
                t: 0.0,
                newton_iteration: 1,
                unknowns: 3,
                rtol: 1e-6,
                max_iter: None,
                set_up: true,
                iterations: 1,
                converged: true,
            }),
        }
    }

    /// The replay's own warm start, worked by hand: step 1 has two solves
    /// whose replayed solutions differ from the run's by (1, 0, 0) and (0,
    /// 0, 2), so step 2's guess is its x0 (1, 2, 3) plus (1, 0, 2); step
    /// 2's one solve differs by (0, 0, 1), which is all step 3's guess
    /// gets (step 1's differences are not carried twice).
    #[test]
    fn a_replayed_warm_start_moves_by_the_last_steps_own_differences() {
        let systems = [
            system(1, 1, None, Some([10.0; 3])),
            system(2, 1, None, Some([1.0; 3])),
            system(3, 2, Some([1.0, 2.0, 3.0]), Some([5.0, 5.0, 4.0])),
            system(4, 3, Some([0.0; 3]), Some([0.0; 3])),
        ];
        let replayed = [[11.0, 10.0, 10.0], [1.0, 1.0, 3.0], [5.0; 3]];
        let mut warm = OwnWarmStart::new(&systems);
        let mut g = [0.0; 3];
        for (s, x) in systems[..3].iter().zip(&replayed) {
            warm.guess(s, s.x0.is_some().then_some(&mut g[..]));
            if s.run.as_ref().unwrap().solve == 3 {
                assert_eq!(g, [2.0, 2.0, 5.0]);
            }
            warm.solved(s, x);
        }
        warm.guess(&systems[3], Some(&mut g));
        assert_eq!(g, [0.0, 0.0, 1.0]);

        // Without every run solution, or with a solve left out (--every 2),
        // the recorded guess as it is.
        let without_x = [
            system(1, 1, None, Some([10.0; 3])),
            system(2, 1, None, None),
            system(3, 2, Some([1.0, 2.0, 3.0]), Some([5.0, 5.0, 4.0])),
        ];
        let every_2 = [
            system(1, 1, None, Some([10.0; 3])),
            system(3, 1, None, Some([1.0; 3])),
            system(5, 2, Some([1.0, 2.0, 3.0]), Some([5.0, 5.0, 4.0])),
        ];
        for systems in [without_x, every_2] {
            let mut warm = OwnWarmStart::new(&systems);
            for (s, x) in systems.iter().zip(&replayed) {
                warm.guess(s, s.x0.is_some().then_some(&mut g[..]));
                warm.solved(s, x);
            }
            assert_eq!(g, [1.0, 2.0, 3.0]);
        }
    }

    /// Per-system times worked by hand. Rebuild: 3 s every system, so
    /// cumulative 3, 6, 9, 12, 15. Refill: 5 s for system 1, then 1 s:
    /// cumulative 5, 6, 7, 8, 9: above 3, equal to 6 (not below), then 7 < 9
    /// and below ever after: break-even at system 3. Keep: 4, 0.5, 0.5, 4,
    /// 4: cumulative 4, 4.5, 5, 9, 13: below from system 2 on (4.5 < 6,
    /// 5 < 9, 9 < 12, 13 < 15), but not at system 1 (4 > 3): system 2. A
    /// policy that dips below and ends above (1, 1, 1, 10, 10: cumulative 1,
    /// 2, 3, 13, 23 against 15 at the end) never breaks even.
    #[test]
    fn break_even_and_choice_on_a_hand_worked_table() {
        let rebuild = cumulative([3.0; 5]);
        assert_eq!(rebuild, [3.0, 6.0, 9.0, 12.0, 15.0]);
        let refill = cumulative([5.0, 1.0, 1.0, 1.0, 1.0]);
        let keep = cumulative([4.0, 0.5, 0.5, 4.0, 4.0]);
        let dip = cumulative([1.0, 1.0, 1.0, 10.0, 10.0]);
        let cheap = cumulative([1.0; 5]);
        assert_eq!(break_even(&refill, &rebuild), Some(3));
        assert_eq!(break_even(&keep, &rebuild), Some(2));
        assert_eq!(break_even(&dip, &rebuild), None);
        assert_eq!(break_even(&cheap, &rebuild), Some(1));
        assert_eq!(break_even(&rebuild, &rebuild), None);
        // Totals 15, 9, 13, 23, 5; the cheapest did not converge everywhere.
        let totals = [
            (15.0, true),
            (9.0, true),
            (13.0, true),
            (23.0, true),
            (5.0, false),
        ];
        assert_eq!(choose(&totals), Some(1));
        assert_eq!(choose(&[(2.0, false)]), None);
        // Ties go to the first.
        assert_eq!(choose(&[(3.0, true), (2.0, true), (2.0, true)]), Some(1));
    }

    #[test]
    fn every_keep_policy_breaks_even_against_its_own_rebuild() {
        let p = policies();
        assert_eq!(p.len(), 13);
        for q in &p {
            let base = &p[q.baseline];
            assert!(base.name.ends_with("-rebuild"), "{}", q.name);
            assert_eq!(
                base.name.split('-').next(),
                q.name.split('-').next(),
                "{}",
                q.name
            );
        }
    }
}
