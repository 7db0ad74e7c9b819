//! API misuse of hookean-filter (issue 28): bad options, indices out of
//! range, wrong lengths and empty inputs are typed errors, never a panic.

use hookean_filter::*;

fn chain(n: usize) -> Vec<Edge> {
    (0..n - 1)
        .map(|i| Edge {
            i,
            j: i + 1,
            rest_length: 0.1,
        })
        .collect()
}

#[test]
fn bad_options_and_springs_are_errors() {
    for lambda in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let o = FilterOptions {
            kernel: Kernel::Exponential { lambda },
            ..FilterOptions::default()
        };
        assert!(
            VelocityFilter::new(4, &chain(4), None, o).is_err(),
            "{lambda}"
        );
    }
    let o = FilterOptions {
        rings: 0,
        ..FilterOptions::default()
    };
    assert!(VelocityFilter::new(4, &chain(4), None, o).is_err());
    let out_of_range = [Edge {
        i: 0,
        j: 9,
        rest_length: 0.1,
    }];
    assert!(VelocityFilter::new(4, &out_of_range, None, FilterOptions::default()).is_err());
    for rest_length in [0.0, -1.0, f64::NAN] {
        let e = [Edge {
            i: 0,
            j: 1,
            rest_length,
        }];
        assert!(VelocityFilter::new(2, &e, None, FilterOptions::default()).is_err());
    }
    assert!(
        VelocityFilter::new(4, &chain(4), Some(&[false; 3]), FilterOptions::default()).is_err()
    );
}

#[test]
fn wrong_lengths_and_indices_are_errors() {
    let mut f = VelocityFilter::new(4, &chain(4), None, FilterOptions::default()).unwrap();
    assert!(f.apply(&mut [0.0; 11]).is_err());
    let mut dst = [0.0; 12];
    assert!(f.apply_to(&[0.0; 9], &mut dst).is_err());
    assert!(f.set_pinned(4, true).is_err());
    assert!(f.update_distances(&[0.0; 3]).is_err());
    let mut v = [0.0; 12];
    v[5] = f64::NAN;
    // A NaN velocity is filtered into NaNs or refused, never a panic.
    let _ = f.apply(&mut v);
}

#[test]
fn an_empty_model_is_an_error_or_a_no_op() {
    if let Ok(mut f) = VelocityFilter::new(0, &[], None, FilterOptions::default()) {
        assert!(f.apply(&mut []).is_ok());
    }
}
