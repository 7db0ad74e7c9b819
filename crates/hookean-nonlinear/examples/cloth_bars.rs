//! Measures the bars on the reference drape scene: total CG
//! iterations of exact vs inexact Newton (and the other variants) for one
//! implicit Euler step, and the nonzeros of the full vs the linearised
//! Jacobian. Prints markdown tables.
//!
//! `cargo run --release -p hookean-nonlinear --example cloth_bars -- [N] [jitter] [rtol] [clamped|exact] [h] [eta_initial]`

#[path = "../tests/common/cloth.rs"]
mod cloth;

use std::time::Instant;

use cloth::{ClothStep, LinearizedCloth, scalar_nonzeros};
use hookean_nonlinear::*;
use hookean_sparse::BlockJacobi;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: usize = args.get(1).map_or(64, |s| s.parse().expect("N"));
    let jitter: f64 = args.get(2).map_or(0.1, |s| s.parse().expect("jitter"));
    let rtol: f64 = args.get(3).map_or(1e-8, |s| s.parse().expect("rtol"));
    let clamp = args.get(4).is_none_or(|s| s != "exact");
    let h: f64 = args.get(5).map_or(0.01, |s| s.parse().expect("h"));
    let eta_initial: f64 = args.get(6).map_or(0.5, |s| s.parse().expect("eta_initial"));
    let (k, d) = (1e4, 0.1);
    println!(
        "drape N = {n}, k = {k:e}, d = {d}, h = {h}, start at rest from a grid jittered by {jitter} spacings, \
         Newton stops at |G| <= {rtol:e} |G_0|, block-Jacobi PCG, {} stiffness Jacobian\n",
        if clamp {
            "clamped"
        } else {
            "exact (unclamped)"
        }
    );
    println!(
        "| method | Newton its | CG its (total) | Jacobian evals | |G|/|G_0| at exit | time (ms) | ms per CG it |"
    );
    println!("|---|---|---|---|---|---|---|");
    let methods: [(&str, NewtonMethod); 6] = [
        ("exact (linear rtol 1e-10)", NewtonMethod::Exact),
        (
            "inexact, eta = 0.02",
            NewtonMethod::Inexact(ForcingTerm::TUTORIAL),
        ),
        (
            "inexact, Eisenstat-Walker 1",
            NewtonMethod::Inexact(ForcingTerm::EisenstatWalker1),
        ),
        (
            "inexact, Eisenstat-Walker 2",
            NewtonMethod::Inexact(ForcingTerm::EW2_DEFAULT),
        ),
        ("simplified (linear rtol 1e-10)", NewtonMethod::Simplified),
        (
            "inexact simplified, eq. (50) Jacobian, eta = 0.02",
            NewtonMethod::InexactSimplified(ForcingTerm::TUTORIAL),
        ),
    ];
    for (name, method) in methods {
        let mut sys = ClothStep::new(n, k, d, h, jitter, 7);
        sys.clamp = clamp;
        let pcg = PcgSolver::new(BlockJacobi::new()).with_constraints(sys.correction_constraints());
        let options = NewtonOptions {
            method,
            rtol,
            atol: 0.0,
            max_iter: 200,
            eta_initial,
            ..Default::default()
        };
        let mut newton = Newton::new(options, sys.jacobian_storage(), pcg).unwrap();
        let mut dv = vec![0.0; sys.dim()];
        let t = Instant::now();
        let r = newton.solve(&mut sys, &mut dv);
        let ms = t.elapsed().as_secs_f64() * 1e3;
        match r {
            Ok(s) => println!(
                "| {name} | {} | {} | {} | {:.2e} | {ms:.1} | {:.3} |",
                s.iterations,
                s.linear_iterations,
                s.jacobian_evaluations,
                s.final_residual() / s.initial_residual(),
                ms / s.linear_iterations.max(1) as f64
            ),
            Err(e) => {
                let s = e.stats().cloned().unwrap_or_default();
                println!(
                    "| {name} | failed: {} | {} | {} | {:.2e} | {ms:.1} | {:.3} |",
                    short(&e),
                    s.linear_iterations,
                    s.jacobian_evaluations,
                    s.final_residual() / s.initial_residual(),
                    ms / s.linear_iterations.max(1) as f64
                )
            }
        }
    }
    {
        // eq. (50) with isotropic-block storage (one scalar per block).
        let name = "inexact simplified, eq. (50) Jacobian in isotropic storage, eta = 0.02";
        let mut step = ClothStep::new(n, k, d, h, jitter, 7);
        step.clamp = clamp;
        let pcg =
            PcgSolver::new(BlockJacobi::new()).with_constraints(step.correction_constraints());
        let mut sys = LinearizedCloth(&mut step);
        let options = NewtonOptions {
            method: NewtonMethod::InexactSimplified(ForcingTerm::TUTORIAL),
            rtol,
            atol: 0.0,
            max_iter: 200,
            ..Default::default()
        };
        let mut newton = Newton::new(options, sys.jacobian_storage(), pcg).unwrap();
        let mut dv = vec![0.0; sys.dim()];
        let t = Instant::now();
        let r = newton.solve(&mut sys, &mut dv);
        let ms = t.elapsed().as_secs_f64() * 1e3;
        let (status, s) = match r {
            Ok(s) => (s.iterations.to_string(), s),
            Err(e) => (
                format!("failed: {}", short(&e)),
                e.stats().cloned().unwrap_or_default(),
            ),
        };
        println!(
            "| {name} | {status} | {} | {} | {:.2e} | {ms:.1} | {:.3} |",
            s.linear_iterations,
            s.jacobian_evaluations,
            s.final_residual() / s.initial_residual(),
            ms / s.linear_iterations.max(1) as f64
        );
    }

    let mut sys = ClothStep::new(n, k, d, h, jitter, 7);
    let dv = vec![0.0; sys.dim()];
    let mut full = sys.jacobian_storage();
    sys.jacobian(&dv, &mut full).unwrap();
    let mut lin = sys.jacobian_storage();
    sys.approximate_jacobian(&dv, &mut lin).unwrap();
    let (nf, nl) = (scalar_nonzeros(&full), scalar_nonzeros(&lin));
    println!("\n| Jacobian | scalar nonzeros | ratio to full |");
    println!("|---|---|---|");
    println!("| full (3x3 spring blocks) | {nf} | 1 |");
    println!(
        "| linearised, eq. (50) (isotropic blocks) | {nl} | {:.3} |",
        nl as f64 / nf as f64
    );
}

fn short(e: &NonlinearError) -> String {
    match e {
        NonlinearError::Diverged { reason, .. } => format!("diverged ({reason:?})"),
        NonlinearError::MaxIterations { .. } => "iteration limit".into(),
        other => other.to_string(),
    }
}
