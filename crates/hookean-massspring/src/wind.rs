//! Wind: a velocity field of the air `w(x, t)` and the aerodynamic force it
//! puts on every triangle of the model, with its velocity Jacobian in the
//! implicit matrix.
//!
//! **The field.** A constant mean wind `w_0` plus, with a gust amplitude
//! `A > 0`, a deterministic gusting field of `K = 4` travelling waves
//! drawn from the seed (the random-Fourier-modes construction of synthetic
//! turbulence, with a handful of modes):
//!
//! `w(x, t) = w_0 + (A / K) sum_k sin(2 pi f_k t - kappa_k . x + phi_k) d_k`,
//!
//! `d_k` and the wave directions `e_k` unit vectors, `kappa_k = (2 pi / lambda) e_k`
//! (`lambda` the gust wavelength), `f_k` in `[f / 2, 3 f / 2)` (`f` the gust
//! frequency), `phi_k` in `[0, 2 pi)`. So `|w - w_0| <= A` everywhere: the
//! air is never faster than `|w_0| + A` ([`Wind::max_speed`], which the
//! facade's energy check allows for). The same seed gives the same field
//! on every machine (splitmix64 draws; no thread, no clock).
//!
//! **The force** on a triangle `(a, b, c)` of area `A_t` and unit normal
//! `n`, moving with the mean velocity of its corners `v_t = (v_a + v_b + v_c) / 3`
//! through the air at its centroid, `v_rel = v_t - w`, `v_n = n . v_rel`:
//!
//! `f_t = -1/2 rho A_t (C_d |v_n| + C_l |v_rel|) v_n n`,
//!
//! a third of it on each corner. Both terms push along the normal, as the
//! pressure on a thin plate does (Blender's cloth wind,
//! `SIM_mass_spring_force_face_wind` in its implicit solver, also pushes
//! along the face normal by the normal component of the wind, linearly and
//! with no Jacobian):
//!
//! - **drag** `-1/2 rho C_d A_t |v_n| v_n n`, quadratic in the speed: a plate
//!   held normal to a steady wind feels `1/2 rho C_d A_t |v_rel|^2`, the drag
//!   law of NVIDIA Newton's `tri_drag` (its triangle kernel's
//!   `k_drag A |n . v| v`, which has the same size on such a plate but
//!   points along `v`; here it points along `n`, so that its Jacobian is
//!   symmetric);
//! - **lift** `-1/2 rho C_l A_t |v_rel|^2 sin(alpha) n`, `sin(alpha) = v_n / |v_rel|`
//!   the angle of attack: Newton's `tri_lift` (`k_lift A alpha |v|^2 n`,
//!   the same to first order in `alpha`). Its part across `v_rel` is the
//!   lift of a flat plate, `1/2 rho C_l A_t |v_rel|^2 sin(alpha) cos(alpha)`.
//!
//! A plate moving with the air (`v_rel = 0`) or edge-on to it (`v_n = 0`)
//! feels nothing; the force does not depend on the triangle's orientation
//! (`n -> -n` leaves it alone); in the frame of a uniform wind it never
//! does positive work (`f_t . v_rel = -1/2 rho A_t (C_d |v_n| + C_l |v_rel|) v_n^2 <= 0`).
//!
//! **The Jacobian.** `df_t/dv_rel = -1/2 rho A_t [ (2 C_d |v_n| + C_l |v_rel|)
//! n n^T + C_l v_n n v_rel^T / |v_rel| ]`. The first term is symmetric and negative
//! semidefinite and is kept: `df_i/dv_j = -(1/9) K`, `K = 1/2 rho A_t
//! (2 C_d |v_n| + C_l |v_rel|) n n^T`, for every pair of corners `i, j` (the
//! triangle's block matrix `-(1/9) (1 1^T) (x) K` stays negative
//! semidefinite, so `M - h df/dv - h^2 df/dx` stays SPD); the drag's
//! Jacobian is exact. The lift's second term is not symmetric and is
//! dropped, as Baraff and Witkin drop the non-symmetric position
//! derivative of damping ([`crate::DampingInDfdx::Drop`]). A corner pair
//! that is not on the Jacobian pattern (no spring joins them) has its
//! block lumped onto the two diagonal blocks, which keeps the sign.
//!
//! **Within a step** the triangle's geometry (`n`, `A_t`) and its air
//! velocity (sampled at its centroid) are those at the start of the step
//! (`begin_step`), as soft pins take their targets then: the force depends
//! on `v` only, so `df/dx` has no wind term and the kept `df/dv` is the
//! whole Jacobian of the drag. Taken at the end of the step instead, `n`
//! would bring the position derivative `-(1/3) g'(v_n) n (v_rel^T dn/dx_j)`
//! (`g = 1/2 rho A_t (C_d |v_n| + C_l |v_rel|) v_n`), not symmetric and of
//! size `|v_rel| / (edge length)`: on a flat 64^2 flag edge-on to 8 m/s,
//! whose springs have no stiffness out of its plane yet, an estimated 10%
//! to 60% of the mass in `M - h^2 df/dx` at `h = 0.01` s, which Newton
//! would have to make up by iterating. Lagged, it is an explicit stiffness `k ~ 1/2 rho C |v_rel| |v_n| A_t / l`
//! (`l` the edge length) on the corners' mass: stable while
//! `h < 2 sqrt(m / k)`, about 0.06 s for that flag.

use hookean_sparse::SymBlockMatrix;
use hookean_sparse::block::{self, Block3};
use nalgebra::Vector3;

use crate::NonExhaustive;
use crate::error::MassSpringError;
use crate::model::{MassSpringModel, point};

/// The number of travelling waves of the gust field.
const MODES: usize = 4;

/// The wind and the aerodynamic coefficients of the model's triangles
/// (module docs). Build with `..Default::default()`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wind {
    /// The mean wind `w_0` (m/s). Default `[0, 0, 0]`.
    pub velocity: [f64; 3],
    /// The air density `rho` (kg/m^3), non-negative. Default 1.2 (air at 20 C).
    pub air_density: f64,
    /// The drag coefficient `C_d`, non-negative. Default 1 (a flat plate
    /// normal to the flow: about 1.2).
    pub drag: f64,
    /// The lift coefficient `C_l`, non-negative. Default 0.
    pub lift: f64,
    /// The gusts' amplitude `A` (m/s), non-negative; 0: a constant wind. Default 0.
    pub gust_amplitude: f64,
    /// The gusts' mean frequency `f` (Hz), positive. Default 0.5.
    pub gust_frequency: f64,
    /// The gusts' wavelength `lambda` (m), positive. Default 4.
    pub gust_wavelength: f64,
    /// The seed of the gust field. Default 0.
    pub seed: u64,
    /// Build with `..Default::default()` (see [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

impl Default for Wind {
    fn default() -> Self {
        Self {
            velocity: [0.0; 3],
            air_density: 1.2,
            drag: 1.0,
            lift: 0.0,
            gust_amplitude: 0.0,
            gust_frequency: 0.5,
            gust_wavelength: 4.0,
            seed: 0,
            non_exhaustive: NonExhaustive(()),
        }
    }
}

/// One travelling wave of the gust field.
#[derive(Debug, Clone, Copy)]
struct Mode {
    /// `d_k` times `A / K`.
    direction: [f64; 3],
    /// `kappa_k` (1/m).
    wave: [f64; 3],
    /// `2 pi f_k` (1/s).
    omega: f64,
    phase: f64,
}

/// splitmix64 (Steele, Lea and Flood 2014): the seed's stream of draws.
struct SplitMix(u64);

impl SplitMix {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)` (the top 53 bits).
    fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// A unit vector, uniform on the sphere (Archimedes: `z` uniform).
    fn direction(&mut self) -> [f64; 3] {
        let z = 2.0 * self.unit() - 1.0;
        let (s, c) = (std::f64::consts::TAU * self.unit()).sin_cos();
        let r = (1.0 - z * z).max(0.0).sqrt();
        [r * c, r * s, z]
    }
}

impl Wind {
    /// The air's fastest speed, `|w_0| + A` (m/s): no point of the field is
    /// faster.
    pub fn max_speed(&self) -> f64 {
        norm(self.velocity) + self.gust_amplitude
    }

    /// The air velocity `w(x, t)` (m/s) at `x` (m) and time `t` (s).
    pub fn velocity_at(&self, x: [f64; 3], t: f64) -> [f64; 3] {
        sample(self.velocity, &self.modes(), x, t)
    }

    /// The gust field's waves, drawn from the seed (none without gusts).
    fn modes(&self) -> Option<[Mode; MODES]> {
        if self.gust_amplitude == 0.0 {
            return None;
        }
        let mut rng = SplitMix(self.seed);
        let tau = std::f64::consts::TAU;
        let scale = self.gust_amplitude / MODES as f64;
        Some(std::array::from_fn(|_| {
            let d = rng.direction();
            let e = rng.direction();
            let k = tau / self.gust_wavelength;
            Mode {
                direction: d.map(|c| c * scale),
                wave: e.map(|c| c * k),
                omega: tau * self.gust_frequency * (0.5 + rng.unit()),
                phase: tau * rng.unit(),
            }
        }))
    }

    fn check(&self) -> Result<(), MassSpringError> {
        if let Some(index) = self.velocity.iter().position(|c| !c.is_finite()) {
            return Err(MassSpringError::NonFinite {
                what: "wind velocity",
                index,
            });
        }
        for (name, value, positive) in [
            ("air_density", self.air_density, false),
            ("drag", self.drag, false),
            ("lift", self.lift, false),
            ("gust_amplitude", self.gust_amplitude, false),
            ("gust_frequency", self.gust_frequency, true),
            ("gust_wavelength", self.gust_wavelength, true),
        ] {
            let ok = value.is_finite() && if positive { value > 0.0 } else { value >= 0.0 };
            if !ok {
                return Err(MassSpringError::InvalidParameter {
                    name,
                    message: format!(
                        "{value} must be {} and finite",
                        if positive { "positive" } else { "non-negative" }
                    ),
                });
            }
        }
        Ok(())
    }
}

fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

/// `w_0 + sum_k sin(omega_k t - kappa_k . x + phi_k) d_k (A / K)`.
fn sample(mean: [f64; 3], modes: &Option<[Mode; MODES]>, x: [f64; 3], t: f64) -> [f64; 3] {
    let mut w = mean;
    if let Some(modes) = modes {
        for m in modes {
            let arg =
                m.omega * t - (m.wave[0] * x[0] + m.wave[1] * x[1] + m.wave[2] * x[2]) + m.phase;
            let s = arg.sin();
            for r in 0..3 {
                w[r] += s * m.direction[r];
            }
        }
    }
    w
}

/// The wind of a model: its options, the gust waves, each triangle's
/// corner-pair slots on the Jacobian pattern and its air velocity of the
/// step.
#[derive(Debug, Clone)]
pub(crate) struct WindState {
    wind: Wind,
    modes: Option<[Mode; MODES]>,
    /// Value index of the upper block of corner pairs (0, 1), (1, 2),
    /// (0, 2) of each triangle; `usize::MAX` when not on the pattern.
    pairs: Vec<[usize; 3]>,
    /// The air velocity at each triangle's centroid at the step's start.
    air: Vec<[f64; 3]>,
    /// Each triangle's unit normal and area at the step's start (area 0:
    /// degenerate, no force).
    geometry: Vec<([f64; 3], f64)>,
}

/// The corner pairs of a triangle, in the order of [`WindState::pairs`].
const PAIRS: [(usize, usize); 3] = [(0, 1), (1, 2), (0, 2)];

/// A triangle's aerodynamic state at `(x, v)`: the force on each corner
/// and the coefficient `beta` of its velocity Jacobian blocks
/// `df_i/dv_j = -beta n n^T` (every pair of corners), or `None` for a
/// degenerate triangle.
struct TriangleAero {
    corner_force: Vector3<f64>,
    n: Vector3<f64>,
    beta: f64,
}

impl MassSpringModel {
    /// Turns wind on (`Some`) or off (`None`) for the model's triangles
    /// ([`set_faces`](Self::set_faces) first).
    ///
    /// # Errors
    /// [`MassSpringError::InvalidParameter`] for a negative or non-finite
    /// coefficient, a non-positive gust frequency or wavelength, or a model
    /// without triangles; [`MassSpringError::NonFinite`] for a non-finite
    /// wind velocity.
    pub fn set_wind(&mut self, wind: Option<Wind>) -> Result<(), MassSpringError> {
        // Wind changes the material: eq. 50's Jacobians exist only without it.
        self.revision += 1;
        let Some(wind) = wind else {
            self.wind = None;
            return Ok(());
        };
        wind.check()?;
        if self.faces.is_empty() {
            return Err(MassSpringError::InvalidParameter {
                name: "wind",
                message: "the wind acts on triangles: the model has none".into(),
            });
        }
        let pattern = &self.plan.pattern;
        let pairs = self
            .faces
            .iter()
            .map(|t| PAIRS.map(|(a, b)| pattern.find(t[a], t[b]).map_or(usize::MAX, |s| s.index())))
            .collect();
        self.wind = Some(Box::new(WindState {
            wind,
            modes: wind.modes(),
            pairs,
            air: vec![wind.velocity; self.faces.len()],
            geometry: vec![([0.0; 3], 0.0); self.faces.len()],
        }));
        Ok(())
    }

    /// The wind, if it is on.
    pub fn wind(&self) -> Option<&Wind> {
        self.wind.as_ref().map(|w| &w.wind)
    }

    /// `begin_step` at `t`: each triangle's normal, area and the air
    /// velocity at its centroid, for the step.
    pub(crate) fn begin_wind(&mut self, t: f64, x: &[f64]) {
        let Some(state) = self.wind.as_deref_mut() else {
            return;
        };
        for (k, tri) in self.faces.iter().enumerate() {
            let [xa, xb, xc] = tri.map(|p| point(x, p));
            let s = hookean_geometry::surface::area_vector(&xa, &xb, &xc);
            let area = s.norm();
            state.geometry[k] = if area > 0.0 && area.is_finite() {
                let n = s / area;
                ([n.x, n.y, n.z], area)
            } else {
                ([0.0; 3], 0.0)
            };
            if state.modes.is_some() {
                let c = (xa + xb + xc) / 3.0;
                state.air[k] = sample(state.wind.velocity, &state.modes, [c.x, c.y, c.z], t);
            }
        }
    }

    /// Triangle `k`'s force per corner and Jacobian coefficient at
    /// velocities `v`, on its geometry of the step (module docs).
    #[inline]
    fn triangle_aero(&self, state: &WindState, k: usize, v: &[f64]) -> Option<TriangleAero> {
        let tri = self.faces[k];
        let (n, area) = state.geometry[k];
        if area == 0.0 {
            return None;
        }
        let n = Vector3::from(n);
        let [va, vb, vc] = tri.map(|p| point(v, p));
        let v_rel = (va + vb + vc) / 3.0 - Vector3::from(state.air[k]);
        let v_n = n.dot(&v_rel);
        let speed = v_rel.norm();
        let w = &state.wind;
        let half_rho_a = 0.5 * w.air_density * area;
        let coefficient = half_rho_a * (w.drag * v_n.abs() + w.lift * speed);
        Some(TriangleAero {
            corner_force: n * (-coefficient * v_n / 3.0),
            n,
            beta: half_rho_a * (2.0 * w.drag * v_n.abs() + w.lift * speed) / 9.0,
        })
    }

    /// Adds the wind's force on every triangle to `f` (before the rows of
    /// constrained particles are projected). No allocation.
    pub(crate) fn add_wind_forces(&self, v: &[f64], f: &mut [f64]) {
        let Some(state) = self.wind.as_deref() else {
            return;
        };
        for (k, tri) in self.faces.iter().enumerate() {
            let Some(aero) = self.triangle_aero(state, k, v) else {
                continue;
            };
            for &p in tri {
                for r in 0..3 {
                    f[3 * p + r] += aero.corner_force[r];
                }
            }
        }
    }

    /// Adds `b df_w/dv` of the wind's force to `m`: `-b beta (P_i n)(P_j n)^T`
    /// for every pair of corners `(i, j)` of every triangle (`P_p` the
    /// projector of the step's constraints), a pair off the pattern lumped
    /// onto its two diagonal blocks. No allocation.
    pub(crate) fn add_wind_jacobians(&self, v: &[f64], b: f64, m: &mut SymBlockMatrix) {
        let Some(state) = self.wind.as_deref() else {
            return;
        };
        if b == 0.0 {
            return;
        }
        for (k, tri) in self.faces.iter().enumerate() {
            let Some(aero) = self.triangle_aero(state, k, v) else {
                continue;
            };
            if aero.beta == 0.0 {
                continue;
            }
            let n = [aero.n.x, aero.n.y, aero.n.z];
            let pn = tri.map(|p| {
                if self.active_set.constrained[p] {
                    block::mul_vec(&self.active_set.proj[p], &n)
                } else {
                    n
                }
            });
            let s = -b * aero.beta;
            let vals = m.values_mut();
            let mut add = |idx: usize, blk: &Block3| {
                vals[idx] = block::add(&vals[idx], blk);
            };
            for c in 0..3 {
                add(
                    self.plan.diag_index[tri[c]],
                    &block::scale(&block::outer(&pn[c], &pn[c]), s),
                );
            }
            for (q, &(i, j)) in PAIRS.iter().enumerate() {
                let idx = state.pairs[k][q];
                if idx != usize::MAX {
                    // The stored block is (min, max): P_r B P_c.
                    let (r, c) = if tri[i] < tri[j] { (i, j) } else { (j, i) };
                    add(idx, &block::scale(&block::outer(&pn[r], &pn[c]), s));
                } else {
                    for c in [i, j] {
                        add(
                            self.plan.diag_index[tri[c]],
                            &block::scale(&block::outer(&pn[c], &pn[c]), s),
                        );
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{ClothParams, ModelOptions, cloth};
    use hookean_problem::SecondOrderProblem;
    use hookean_sparse::Constraints;

    /// One free triangle of three 0.1 kg particles, no gravity, its
    /// corners' velocities `v`, in `wind`; `begin_step` at `t`.
    fn triangle(wind: Wind, x: [f64; 9], v: &mut [f64]) -> MassSpringModel {
        let options = ModelOptions {
            gravity: [0.0; 3],
            ..Default::default()
        };
        let mut model = MassSpringModel::new(vec![0.1; 3], vec![], options).unwrap();
        model.set_faces(vec![[0, 1, 2]]).unwrap();
        model.set_wind(Some(wind)).unwrap();
        let mut x = x.to_vec();
        model.begin_step(0.0, &mut x, v, &mut Constraints::new(3));
        model
    }

    /// The right triangle of legs 2 m and 1.5 m in the plane x = 1 (area 1.5 m^2).
    const PLATE: [f64; 9] = [1.0, 0.0, 0.0, 1.0, 2.0, 0.0, 1.0, 0.0, 1.5];

    /// A plate held normal to a steady wind feels `1/2 rho C_d A |v_rel|^2`
    /// along the wind, a third on each corner; moving with the wind, none.
    #[test]
    fn a_plate_normal_to_the_wind_feels_half_rho_cd_a_v_squared_and_none_moving_with_it() {
        let (rho, cd, u) = (1.2, 1.3, 7.0);
        let wind = Wind {
            velocity: [u, 0.0, 0.0],
            air_density: rho,
            drag: cd,
            ..Default::default()
        };
        let mut v = vec![0.0; 9];
        let model = triangle(wind, PLATE, &mut v);
        let mut f = vec![0.0; 9];
        model.force(0.0, &PLATE, &v, &mut f);
        let expected = 0.5 * rho * cd * 1.5 * u * u;
        for c in 0..3 {
            assert!(
                (f[3 * c] - expected / 3.0).abs() < 1e-12 * expected,
                "{f:?}"
            );
            assert_eq!((f[3 * c + 1], f[3 * c + 2]), (0.0, 0.0));
        }
        // The same plate carried by the wind.
        let mut v = [u, 0.0, 0.0].repeat(3);
        let model = triangle(wind, PLATE, &mut v);
        model.force(0.0, &PLATE, &v, &mut f);
        assert!(f.iter().all(|&c| c == 0.0), "{f:?}");
        // Edge-on (the wind along the plate): no force either.
        let along = Wind {
            velocity: [0.0, u, -u],
            ..wind
        };
        let mut v = vec![0.0; 9];
        let model = triangle(along, PLATE, &mut v);
        model.force(0.0, &PLATE, &v, &mut f);
        assert!(f.iter().all(|&c| c.abs() < 1e-12), "{f:?}");
    }

    /// At an angle of attack `alpha` the force is normal to the plate, of
    /// size `1/2 rho A |v|^2 (C_d sin^2 alpha + C_l sin alpha)`, and does not
    /// depend on the order of the corners (the normal's sign).
    #[test]
    fn at_an_angle_of_attack_drag_and_lift_are_normal_with_the_flat_plate_law() {
        let (rho, cd, cl, u) = (1.1, 0.8, 2.0, 5.0);
        let alpha: f64 = 0.3;
        // The wind in the xy plane at alpha to the plate x = 1 (normal x).
        let wind = Wind {
            velocity: [u * alpha.sin(), u * alpha.cos(), 0.0],
            air_density: rho,
            drag: cd,
            lift: cl,
            ..Default::default()
        };
        let size = 0.5 * rho * 1.5 * u * u * (cd * alpha.sin().powi(2) + cl * alpha.sin());
        let flipped = [
            PLATE[0], PLATE[1], PLATE[2], PLATE[6], PLATE[7], PLATE[8], PLATE[3], PLATE[4],
            PLATE[5],
        ];
        for x in [PLATE, flipped] {
            let mut v = vec![0.0; 9];
            let model = triangle(wind, x, &mut v);
            let mut f = vec![0.0; 9];
            model.force(0.0, &x, &v, &mut f);
            let total: [f64; 3] = std::array::from_fn(|r| f[r] + f[3 + r] + f[6 + r]);
            assert!(
                (total[0] - size).abs() < 1e-12 * size,
                "{total:?} vs {size}"
            );
            assert!(
                total[1].abs() < 1e-12 && total[2].abs() < 1e-12,
                "{total:?}"
            );
        }
    }

    /// `df/dv` against central differences of the force: exact for drag
    /// (`C_l = 0`); with lift, the differences minus the dropped term
    /// `-(1/9) 1/2 rho A C_l v_n n v_rel^T / |v_rel|` (module docs). Every
    /// pair of corners, on a cloth triangle with springs on its edges; and
    /// every block of the implicit step's matrix `M + a df/dx + b df/dv`
    /// (`step_matrix`, the one sweep the integrators call, which adds the
    /// wind on its own), whose wind part must be `b` times the differences.
    #[test]
    fn the_velocity_jacobian_is_the_finite_difference_of_the_force() {
        let (model0, state) = cloth(&ClothParams {
            nu: 3,
            nv: 3,
            options: ModelOptions {
                gravity: [0.0; 3],
                ..Default::default()
            },
            pins: crate::ClothPins::None,
            ..Default::default()
        })
        .unwrap();
        for lift in [0.0, 1.7] {
            let mut model = model0.clone();
            let wind = Wind {
                velocity: [0.4, -0.3, 6.0],
                air_density: 1.2,
                drag: 1.1,
                lift,
                ..Default::default()
            };
            model.set_wind(Some(wind)).unwrap();
            let n = model.n_particles();
            let mut x = state.x.clone();
            // Bend the cloth out of its plane, give it velocities.
            for p in 0..n {
                x[3 * p + 2] += 0.05 * ((p * 7 % 5) as f64 - 2.0);
            }
            let mut v: Vec<f64> = (0..3 * n)
                .map(|k| 0.3 * (((k * 13) % 7) as f64 - 3.0))
                .collect();
            model.begin_step(0.0, &mut x, &mut v, &mut Constraints::new(n));
            // The wind's part of df/dv: with wind minus without.
            let (mut dx, mut with) = model.new_jacobians();
            model.force_jacobians(0.0, &x, &v, &mut dx, &mut with);
            let mut calm = model.clone();
            calm.set_wind(None).unwrap();
            let (mut dx0, mut without) = calm.new_jacobians();
            calm.force_jacobians(0.0, &x, &v, &mut dx0, &mut without);
            assert_eq!(dx.values(), dx0.values(), "the wind has no df/dx term");
            // One triangle's corners: a pair's blocks get only that
            // triangle's and its neighbours' terms, so compare the full
            // difference quotients on the corners of triangle 0.
            let tri = model.faces()[0];
            let eps = 1e-6;
            let force = |v: &[f64]| {
                let mut f = vec![0.0; 3 * n];
                model.force(0.0, &x, v, &mut f);
                let mut f0 = vec![0.0; 3 * n];
                calm.force(0.0, &x, v, &mut f0);
                f.iter().zip(&f0).map(|(a, b)| a - b).collect::<Vec<_>>()
            };
            // The dropped term of every triangle, summed per block.
            let dropped = |i: usize, j: usize| -> Block3 {
                let mut d = block::ZERO;
                let state = model.wind.as_deref().unwrap();
                for (k, t) in model.faces().iter().enumerate() {
                    if !(t.contains(&i) && t.contains(&j)) {
                        continue;
                    }
                    let [a, b, c] = t.map(|p| point(&x, p));
                    let cr = (b - a).cross(&(c - a));
                    let nn = cr / cr.norm();
                    let area = 0.5 * cr.norm();
                    let vt = t.map(|p| point(&v, p)).iter().sum::<Vector3<f64>>() / 3.0;
                    let vr = vt - Vector3::from(state.air[k]);
                    let s = -0.5 * 1.2 * area * lift * nn.dot(&vr) / vr.norm() / 9.0;
                    d = block::add(
                        &d,
                        &block::scale(&block::outer(&[nn.x, nn.y, nn.z], &[vr.x, vr.y, vr.z]), s),
                    );
                }
                d
            };
            // The step matrix at a = -h^2, b = -h (h = 0.01 s): with wind
            // minus without, on every pair of particles.
            let (a, b) = (-1e-4, -1e-2);
            let (mut step_with, mut step_without) = model.new_jacobians();
            model
                .step_matrix(
                    0.0,
                    &x,
                    &v,
                    a,
                    b,
                    &mut dx,
                    &mut with.clone(),
                    &mut step_with,
                )
                .unwrap();
            calm.step_matrix(
                0.0,
                &x,
                &v,
                a,
                b,
                &mut dx0,
                &mut without.clone(),
                &mut step_without,
            )
            .unwrap();
            let mut wind_blocks = 0;
            for i in 0..n {
                for j in 0..n {
                    let ours = block::add(
                        &step_with.block(i, j).unwrap(),
                        &block::scale(&step_without.block(i, j).unwrap(), -1.0),
                    );
                    let drop = dropped(i, j);
                    let mut largest = 0.0f64;
                    for c in 0..3 {
                        let (mut vp, mut vm) = (v.clone(), v.clone());
                        vp[3 * j + c] += eps;
                        vm[3 * j + c] -= eps;
                        let (fp, fm) = (force(&vp), force(&vm));
                        for r in 0..3 {
                            let fd = (fp[3 * i + r] - fm[3 * i + r]) / (2.0 * eps);
                            let expected = b * (fd - drop[r][c]);
                            largest = largest.max(expected.abs());
                            assert!(
                                (ours[r][c] - expected).abs() < 1e-8 * (1.0 + expected.abs()),
                                "step matrix, lift {lift}, block ({i}, {j}) [{r}][{c}]: {} vs {expected}",
                                ours[r][c]
                            );
                        }
                    }
                    wind_blocks += usize::from(largest > 1e-6);
                }
            }
            // The wind couples every two corners of a triangle: all 9
            // particles' diagonal blocks and the pairs of the 8 triangles.
            assert!(wind_blocks > 2 * n, "{wind_blocks} blocks of wind");
            for &i in &tri {
                for &j in &tri {
                    let blk_with = with.block(i, j).unwrap();
                    let blk_without = without.block(i, j).unwrap();
                    let drop = dropped(i, j);
                    for c in 0..3 {
                        let (mut vp, mut vm) = (v.clone(), v.clone());
                        vp[3 * j + c] += eps;
                        vm[3 * j + c] -= eps;
                        let (fp, fm) = (force(&vp), force(&vm));
                        for r in 0..3 {
                            let fd = (fp[3 * i + r] - fm[3 * i + r]) / (2.0 * eps);
                            let ours = blk_with[r][c] - blk_without[r][c];
                            let expected = fd - drop[r][c];
                            assert!(
                                (ours - expected).abs() < 1e-6 * (1.0 + expected.abs()),
                                "lift {lift}, block ({i}, {j}) [{r}][{c}]: {ours} vs {expected}"
                            );
                        }
                    }
                }
            }
        }
    }

    /// The gust field is the seed's: the same seed the same air, another
    /// seed other air, never farther than the amplitude from the mean, and
    /// it varies in time and space.
    #[test]
    fn the_gust_field_is_deterministic_bounded_and_varies() {
        let wind = Wind {
            velocity: [3.0, 0.0, 0.0],
            gust_amplitude: 2.0,
            gust_frequency: 1.0,
            gust_wavelength: 3.0,
            seed: 42,
            ..Default::default()
        };
        let other = Wind { seed: 43, ..wind };
        let mut differ = 0;
        let mut spread = 0.0f64;
        for k in 0..200 {
            let t = 0.037 * k as f64;
            let x = [0.1 * k as f64, -0.05 * k as f64, 0.3];
            let w = wind.velocity_at(x, t);
            assert_eq!(w, wind.velocity_at(x, t));
            let d = norm(std::array::from_fn(|r| w[r] - wind.velocity[r]));
            assert!(d <= 2.0 + 1e-12, "{d}");
            spread = spread.max(d);
            differ += usize::from(w != other.velocity_at(x, t));
        }
        assert!(spread > 0.5, "{spread}");
        assert_eq!(differ, 200);
        // A fixed point in time: the field moves; fixed time: it varies in space.
        assert_ne!(
            wind.velocity_at([0.0; 3], 0.0),
            wind.velocity_at([0.0; 3], 0.3)
        );
        assert_ne!(
            wind.velocity_at([0.0; 3], 0.0),
            wind.velocity_at([0.5, 0.0, 0.0], 0.0)
        );
        assert_eq!(
            Wind {
                gust_amplitude: 0.0,
                ..wind
            }
            .velocity_at([1.0; 3], 5.0),
            [3.0, 0.0, 0.0]
        );
        assert_eq!(wind.max_speed(), 5.0);
    }

    #[test]
    fn bad_wind_is_refused_naming_the_parameter() {
        let mut v = vec![0.0; 9];
        let mut model = triangle(Wind::default(), PLATE, &mut v);
        for (bad, name) in [
            (
                Wind {
                    drag: -1.0,
                    ..Default::default()
                },
                "drag",
            ),
            (
                Wind {
                    gust_frequency: 0.0,
                    ..Default::default()
                },
                "gust_frequency",
            ),
            (
                Wind {
                    air_density: f64::NAN,
                    ..Default::default()
                },
                "air_density",
            ),
        ] {
            match model.set_wind(Some(bad)) {
                Err(MassSpringError::InvalidParameter { name: n, .. }) => assert_eq!(n, name),
                other => panic!("{other:?}"),
            }
        }
        let mut bare = MassSpringModel::new(vec![1.0], vec![], ModelOptions::default()).unwrap();
        assert!(bare.set_wind(Some(Wind::default())).is_err());
    }
}
