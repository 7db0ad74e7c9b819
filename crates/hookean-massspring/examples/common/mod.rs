//! The state both assembly examples time: an `n x n` reference cloth, every
//! coordinate moved by up to +-0.05 mm (a deterministic pattern, so runs of
//! two builds see the same bits) and velocities up to +-0.05 m/s.

use hookean_massspring::{ClothParams, MassSpringModel, State, cloth};

pub fn deformed_cloth(n: usize) -> (MassSpringModel, State) {
    let (model, mut s) = cloth(&ClothParams {
        nu: n,
        nv: n,
        ..Default::default()
    })
    .expect("the reference cloth is valid");
    for (k, x) in s.x.iter_mut().enumerate() {
        *x += 1e-4 * ((k * 7919 % 101) as f64 / 101.0 - 0.5);
    }
    for (k, v) in s.v.iter_mut().enumerate() {
        *v = 0.1 * ((k * 104729 % 97) as f64 / 97.0 - 0.5);
    }
    (model, s)
}
