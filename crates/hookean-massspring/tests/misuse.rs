//! API misuse of hookean-massspring (issue 28): sizes that overflow, an
//! empty model, wrong lengths, indices out of range and endless input are
//! typed errors, never a panic or an attempt to allocate the impossible.
//! (Bad springs, masses and states: `io_and_errors.rs`.)

use hookean_massspring::*;

#[test]
fn builders_refuse_sizes_whose_particle_count_overflows() {
    for (nu, nv) in [(usize::MAX, 2), (1 << 33, 1 << 33), (2, usize::MAX)] {
        let p = ClothParams {
            nu,
            nv,
            ..ClothParams::default()
        };
        assert!(cloth(&p).is_err(), "{nu} x {nv}");
    }
    let p = RopeParams {
        n: usize::MAX,
        ..RopeParams::default()
    };
    assert!(rope(&p).is_err());
    let p = BlockParams {
        n: [usize::MAX, 2, 2],
        ..BlockParams::default()
    };
    assert!(jelly_block(&p).is_err());
}

#[test]
fn an_empty_model_is_refused() {
    assert!(MassSpringModel::new(vec![], vec![], ModelOptions::default()).is_err());
}

#[test]
fn indices_out_of_range_and_wrong_lengths_are_errors() {
    let (mut model, state) = cloth(&ClothParams::drape(4)).unwrap();
    let n = model.n_particles();
    assert!(model.pin(n, [0.0; 3]).is_err());
    assert!(model.pin(usize::MAX, [0.0; 3]).is_err());
    assert!(model.release(n).is_err());
    assert!(model.set_faces(vec![[0, 1, n]]).is_err());
    assert!(model.set_external_force(n, [0.0; 3]).is_err());
    assert!(model.set_external_force(0, [f64::NAN, 0.0, 0.0]).is_err());
    // The trait methods (force, Jacobians) may panic on wrong lengths, as
    // hookean-problem documents; check_state is what a caller checks first.
    assert!(model.check_state(&state.x[1..], &state.v).is_err());
    assert!(model.check_state(&state.x, &state.v[..3]).is_err());
    let colours = vec![[0.0; 3]; n - 1];
    assert!(
        model
            .write_obj(Vec::new(), &state.x, Some(&colours))
            .is_err()
    );
    assert!(write_obj(Vec::new(), &state.x[..5], None, &[], &[]).is_err());
}

#[test]
fn an_obj_without_line_breaks_is_refused_at_the_line_cap() {
    let endless = std::io::BufReader::new(std::io::repeat(b'v'));
    let e = parse_obj(endless).unwrap_err();
    assert!(e.to_string().contains("line 1"), "{e}");
}

#[test]
fn colliders_refuse_non_finite_and_negative_values() {
    assert!(Collider::plane([0.0; 3], [0.0; 3], 0.0).is_err());
    assert!(Collider::plane([f64::NAN, 0.0, 0.0], [0.0, 0.0, 1.0], 0.0).is_err());
    assert!(Collider::plane([0.0; 3], [0.0, 0.0, 1.0], -1.0).is_err());
    assert!(Collider::sphere([0.0; 3], 0.0, 0.0).is_err());
    assert!(Collider::sphere([0.0; 3], f64::INFINITY, 0.0).is_err());
    assert!(Collider::sphere([0.0; 3], 1.0, f64::NAN).is_err());
}
