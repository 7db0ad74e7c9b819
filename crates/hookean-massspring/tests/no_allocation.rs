//! Issue 5's "no allocation per call": `force`, `force_jacobians`,
//! `force_and_jacobians` and `begin_step` (with pins and a collider in
//! contact) allocate nothing once the model is built, checked with a
//! counting global allocator (hookean-testkit's).

use hookean_massspring::{ClothParams, Collider, SecondOrderProblem, cloth};
use hookean_sparse::Constraints;
use hookean_testkit::alloc::{Counting, allocations};

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn assembly_and_begin_step_do_not_allocate() {
    let (mut model, mut state) = cloth(&ClothParams {
        nu: 12,
        nv: 10,
        ..Default::default()
    })
    .expect("valid cloth");
    // A floor just below the lowest particle, pushed up into the cloth:
    // begin_step finds contacts and constrains them.
    let z_min = state
        .x
        .chunks_exact(3)
        .map(|p| p[2])
        .fold(f64::INFINITY, f64::min);
    model.add_collider(Collider::plane([0.0, 0.0, z_min + 1e-3], [0.0, 0.0, 1.0], 0.0).unwrap());
    for (k, v) in state.v.iter_mut().enumerate() {
        *v = 0.01 * ((k * 37 % 11) as f64 - 5.0);
    }
    let (mut dfdx, mut dfdv) = model.new_jacobians();
    let mut f = vec![0.0; model.dim()];
    let mut constraints = Constraints::new(model.n_particles());
    // Warm-up: the first begin_step may size the constraint list.
    model.begin_step(0.0, &mut state.x, &mut state.v, &mut constraints);
    assert!(model.contact_count() > 0, "the floor must touch the cloth");
    let (x, v) = (state.x.clone(), state.v.clone());
    let (calls, ()) = allocations(|| {
        for _ in 0..3 {
            model.force(0.0, &x, &v, &mut f);
            model.force_jacobians(0.0, &x, &v, &mut dfdx, &mut dfdv);
            model.force_and_jacobians(&x, &v, &mut f, &mut dfdx, &mut dfdv);
        }
    });
    assert_eq!(calls, 0, "assembly allocated {calls} times");
    let (steps, ()) = allocations(|| {
        for _ in 0..3 {
            model.begin_step(0.0, &mut state.x, &mut state.v, &mut constraints);
        }
    });
    assert_eq!(steps, 0, "begin_step allocated {steps} times");
    // The counter works: this allocates.
    assert!(allocations(|| drop(std::hint::black_box(vec![0u8; 64]))).0 > 0);
}
