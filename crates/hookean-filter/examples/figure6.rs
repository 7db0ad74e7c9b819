//! The paper's figure 6: the stable step against the filter parameter
//! lambda, measured by bisection on the actual integration (energy bounded
//! over 0.5 s) and predicted by the modified power method (Algorithm 1,
//! eq. 11), on the 12x12 reference drape and the 20-particle rope.
//!
//! Usage: `cargo run --release -p hookean-filter --example figure6`

use hookean_filter::{BisectionOptions, FilterError, RunOptions, stable_step_against_lambda};
use hookean_massspring::{ClothParams, MassSpringModel, RopeParams, State, cloth, rope};
use hookean_ode::Method;

type Build = Box<dyn Fn() -> Result<(MassSpringModel, State), FilterError>>;

fn main() -> Result<(), FilterError> {
    let opts = BisectionOptions {
        run: RunOptions {
            t_end: 0.5,
            ..Default::default()
        },
        rel_tol: 0.01,
        max_runs: 60,
        ..Default::default()
    };
    let lambdas = [0.25, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0];
    let scenes: [(&str, Build); 2] = [
        (
            "drape 12x12",
            Box::new(|| Ok(cloth(&ClothParams::drape(12))?)),
        ),
        (
            "rope 20",
            Box::new(|| {
                Ok(rope(&RopeParams {
                    n: 20,
                    ..Default::default()
                })?)
            }),
        ),
    ];
    println!(
        "| scene | method | lambda | k0 | predicted dt_max (s) | measured dt (s) | measured / unfiltered | predicted / measured |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for (name, build) in &scenes {
        for method in [Method::FbEuler, Method::Verlet, Method::Rk4] {
            let rows = stable_step_against_lambda(build.as_ref(), &method, &lambdas, &opts)?;
            let base = rows[0].measured_dt;
            for r in rows {
                let l = r.lambda.map_or("none".to_string(), |l| format!("{l}"));
                println!(
                    "| {name} | {method} | {l} | {:.3e} | {:.3e} | {:.3e} | {:.2} | {:.3} |",
                    r.k0,
                    r.predicted_dt,
                    r.measured_dt,
                    r.measured_dt / base,
                    r.predicted_dt / r.measured_dt
                );
            }
        }
    }
    Ok(())
}
