use hookean_filter::*;
use hookean_massspring::*;
use hookean_ode::Method;

#[test]
fn explore() {
    let scene = DrapeScene {
        n: 12,
        ..Default::default()
    };
    let build = || scene.build();
    let opts = BisectionOptions {
        run: RunOptions {
            t_end: 0.5,
            ..Default::default()
        },
        rel_tol: 0.02,
        max_runs: 40,
    };
    let (model, state) = build().unwrap();
    let p0 = predict_dt_max(
        &model,
        &state.x,
        None,
        ExplicitScheme::ForwardBackwardEuler,
        &Default::default(),
    )
    .unwrap();
    let t = std::time::Instant::now();
    let m0 = measure_stable_step(&build, &Method::FbEuler, None, p0.dt_max, &opts).unwrap();
    eprintln!("unfiltered: pred {:?} meas {:?} {:?}", p0, m0, t.elapsed());
    for (lambda, form, rings) in [
        (1.0, Form::Plain, 1),
        (1.0, Form::Symmetric, 1),
        (0.5, Form::Symmetric, 1),
    ] {
        let o = FilterOptions {
            kernel: Kernel::Exponential { lambda },
            form,
            rings,
        };
        let p = predict_dt_max(
            &model,
            &state.x,
            Some(&o),
            ExplicitScheme::ForwardBackwardEuler,
            &Default::default(),
        )
        .unwrap();
        for c in [FilterCoupling::CorrectPositions, FilterCoupling::Increment] {
            let m = measure_stable_step(
                &build,
                &Method::FbEuler,
                Some((o.clone(), c)),
                p0.dt_max,
                &opts,
            )
            .unwrap();
            eprintln!(
                "lambda {lambda} {form:?} {rings} {c:?}: pred {:.3e} meas {:.3e} ratio meas/unf {:.3} pred/meas {:.3}",
                p.dt_max,
                m.lo,
                m.lo / m0.lo,
                p.dt_max / m.lo
            );
        }
    }
}
