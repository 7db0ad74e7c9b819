use super::*;

fn chain(n: usize) -> Vec<Edge> {
    (1..n)
        .map(|i| Edge {
            i: i - 1,
            j: i,
            rest_length: 0.5,
        })
        .collect()
}

#[test]
fn weights_follow_the_exponential_kernel_and_sum_to_one() {
    let f = VelocityFilter::new(5, &chain(5), None, FilterOptions::default()).unwrap();
    let (nb, w) = f.neighbourhood(2);
    assert_eq!(nb, &[1, 2, 3]);
    // beta(0) = 1, beta(1) = e^-1 for lambda = 1, normalised.
    let total = 1.0 + 2.0 * (-1.0f64).exp();
    assert!((w[1] - 1.0 / total).abs() < 1e-15);
    assert!((w[0] - (-1.0f64).exp() / total).abs() < 1e-15);
    assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-15);
}

#[test]
fn two_rings_use_path_lengths_in_units_of_the_shortest_spring() {
    // A triangle 0-1 (1), 1-2 (1), 0-2 (3 units): 2 is at distance 2 from 0 through 1.
    let edges = [
        Edge {
            i: 0,
            j: 1,
            rest_length: 1.0,
        },
        Edge {
            i: 1,
            j: 2,
            rest_length: 1.0,
        },
        Edge {
            i: 0,
            j: 2,
            rest_length: 3.0,
        },
    ];
    let opts = FilterOptions {
        kernel: Kernel::Exponential { lambda: 2.0 },
        form: Form::Plain,
        rings: 2,
        current_distances: false,
        ..Default::default()
    };
    let f = VelocityFilter::new(3, &edges, None, opts).unwrap();
    let (nb, w) = f.neighbourhood(0);
    assert_eq!(nb, &[0, 1, 2]);
    let b = [1.0, (-2.0f64).exp(), (-4.0f64).exp()];
    let s: f64 = b.iter().sum();
    for k in 0..3 {
        assert!((w[k] - b[k] / s).abs() < 1e-15);
    }
}

#[test]
fn uniform_velocity_is_unchanged_and_pinned_particles_keep_theirs() {
    let mut f = VelocityFilter::new(
        4,
        &chain(4),
        Some(&[true, false, false, false]),
        FilterOptions::default(),
    )
    .unwrap();
    let mut v = [1.0, 2.0, 3.0].repeat(4);
    f.apply(&mut v).unwrap();
    for c in v.chunks(3) {
        assert!(
            (c[0] - 1.0).abs() < 1e-15 && (c[1] - 2.0).abs() < 1e-15 && (c[2] - 3.0).abs() < 1e-15
        );
    }
    let mut v = vec![0.0; 12];
    v[0] = 5.0; // pinned particle 0 moves
    v[3] = 1.0;
    f.apply(&mut v).unwrap();
    assert_eq!(v[0], 5.0);
    // Particle 1 (symmetric form): (v1 + w10 v0 + w11 v1 + w12 v2) / 2.
    let e = (-1.0f64).exp();
    let total = 1.0 + 2.0 * e;
    let expected = 0.5 * (1.0 + (e * 5.0 + 1.0) / total);
    assert!((v[3] - expected).abs() < 1e-14, "{} vs {expected}", v[3]);
}

#[test]
fn alternating_mode_is_damped_more_for_small_lambda() {
    let n = 20;
    let mut amplitude = Vec::new();
    for lambda in [0.5, 1.0, 10.0] {
        let opts = FilterOptions {
            kernel: Kernel::Exponential { lambda },
            ..Default::default()
        };
        let mut f = VelocityFilter::new(n, &chain(n), None, opts).unwrap();
        let mut v: Vec<f64> = (0..n)
            .flat_map(|i| [if i % 2 == 0 { 1.0 } else { -1.0 }, 0.0, 0.0])
            .collect();
        f.apply(&mut v).unwrap();
        amplitude.push(v[3 * 10].abs());
    }
    assert!(
        amplitude[0] < amplitude[1] && amplitude[1] < amplitude[2],
        "{amplitude:?}"
    );
    // lambda = 10 hardly filters: e^-10 weights.
    assert!(amplitude[2] > 0.999);
}

/// Time-dependent weights: at the rest state of a chain they are the
/// rest weights; with the chain stretched to twice its length they are
/// `beta(2 d)` normalised, computed here by hand.
#[test]
fn current_distances_follow_the_positions() {
    let n = 6;
    let rest = VelocityFilter::new(n, &chain(n), None, FilterOptions::default()).unwrap();
    let mut f = VelocityFilter::new(
        n,
        &chain(n),
        None,
        FilterOptions {
            current_distances: true,
            ..FilterOptions::default()
        },
    )
    .unwrap();
    assert_eq!(f.plan_stats().gathered_particles, n);
    // The chain's springs are 0.5 long: particles 0.5 apart are at rest.
    let x: Vec<f64> = (0..3 * n)
        .map(|k| {
            if k % 3 == 0 {
                0.5 * (k / 3) as f64
            } else {
                0.0
            }
        })
        .collect();
    f.update_distances(&x).unwrap();
    for i in 0..n {
        let (a, b) = (rest.neighbourhood(i).1, f.neighbourhood(i).1);
        for (p, q) in a.iter().zip(b) {
            assert!((p - q).abs() < 1e-15);
        }
    }
    let stretched: Vec<f64> = x.iter().map(|v| 2.0 * v).collect();
    f.update_distances(&stretched).unwrap();
    // Interior particle: itself at d = 0, two neighbours at d = 2.
    let (b0, b2) = (1.0, (-2.0f64).exp());
    let w = f.neighbourhood(2).1.to_vec();
    let w1 = f.neighbourhood(1).1.to_vec();
    assert!((w[1] - b0 / (b0 + 2.0 * b2)).abs() < 1e-15, "{w:?}");
    assert!((w[0] - b2 / (b0 + 2.0 * b2)).abs() < 1e-15, "{w:?}");
    // The application uses them: symmetric form, a spike on particle 2.
    let mut v = vec![0.0; 3 * n];
    v[6] = 1.0;
    f.apply(&mut v).unwrap();
    assert!((v[6] - (0.5 + 0.5 * w[1])).abs() < 1e-15);
    assert!((v[3] - 0.5 * w1[2]).abs() < 1e-15);
    assert!(f.update_distances(&x[..3]).is_err());
}

#[test]
fn bad_input_is_a_typed_error() {
    let e = chain(3);
    for lambda in [0.0, -1.0, f64::NAN] {
        let o = FilterOptions {
            kernel: Kernel::Exponential { lambda },
            ..Default::default()
        };
        assert!(matches!(
            VelocityFilter::new(3, &e, None, o),
            Err(FilterError::InvalidLambda { .. })
        ));
    }
    let o = FilterOptions {
        rings: 0,
        ..Default::default()
    };
    assert!(matches!(
        VelocityFilter::new(3, &e, None, o),
        Err(FilterError::InvalidRadius { rings: 0 })
    ));
    let bad = [Edge {
        i: 0,
        j: 7,
        rest_length: 1.0,
    }];
    assert!(matches!(
        VelocityFilter::new(3, &bad, None, FilterOptions::default()),
        Err(FilterError::InvalidSpring { index: 0, .. })
    ));
    let mut f = VelocityFilter::new(3, &e, None, FilterOptions::default()).unwrap();
    assert!(matches!(
        f.apply(&mut [0.0; 8]),
        Err(FilterError::DimensionMismatch {
            expected: 9,
            found: 8,
            ..
        })
    ));
}
