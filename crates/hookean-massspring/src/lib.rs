#![doc = include_str!("../README.md")]
//!
//! # The crate's map
//!
//! - [`MassSpringModel`] (module `model`): lumped masses, [`Spring`]s with
//!   stiffness and damping ([`SpringDamping`]: projected, the "incorrect"
//!   `d (v_j - v_i)`, or none), air friction, gravity, external forces,
//!   pinned and sliding particles. It implements
//!   [`hookean_problem::SecondOrderProblem`]: `f(x, v)`, `df/dx` (exact or
//!   definiteness-clamped) and `df/dv` assembled into the 3x3 block
//!   matrices of `hookean-sparse` on a pattern built once, refilled in place
//!   without allocation; the tutorial's constant linearised Jacobian (eq. 50);
//!   `begin_step` handles pins and [`Collider`]s and fills the
//!   [`hookean_sparse::Constraints`] of the filtered PCG.
//!   [`MassSpringModel::force_and_jacobians`] computes all three in one sweep;
//!   [`MassSpringModel::material_revision`] tells when the constant
//!   linearised Jacobian must be rebuilt.
//! - Analysis: [`MassSpringModel::stability`] (`k0` of `M^-1 K` by the
//!   power method and `dt_max = 2 / sqrt(k0)`, the filtering paper's eq. 11),
//!   [`MassSpringModel::energies`], [`MassSpringModel::momentum`],
//!   [`MassSpringModel::dfdx_exact`] (the full non-symmetric Jacobian), and
//!   the linearised implicit-Euler system `(A, b)` with Matrix Market export
//!   ([`MassSpringModel::export_implicit_euler_system`]).
//! - Pin groups as handles ([`PinGroup`], [`MassSpringModel::add_pin_group`]):
//!   hard pins (prescribed motion) or soft pins (zero-rest-length springs
//!   with their Jacobian) whose targets move along a [`KeyframedPath`]
//!   ([`path`]), released at a time.
//! - [`Wind`] ([`MassSpringModel::set_wind`]): a constant or gusting wind
//!   field and the aerodynamic drag and lift on every triangle, with its
//!   velocity Jacobian in the implicit matrix.
//! - [`builders`]: [`tutorial_example3`], [`rope`], [`cloth`],
//!   [`jelly_block`], [`from_mesh`].
//! - [`obj`]: [`parse_obj`] / [`read_obj_file`], [`write_obj`] with per-vertex
//!   colours ([`speed_colours`]).
//!
//! # Example: one linearised implicit-Euler step of a hanging rope
//!
//! ```
//! use hookean_massspring::{rope, RopeParams, SecondOrderProblem};
//! use hookean_sparse::{filtered_pcg, BlockJacobi, CgParams, CgWorkspace, Constraints,
//!                      PreconditionerSetup};
//!
//! let (mut model, mut state) = rope(&RopeParams { n: 8, ..Default::default() })?;
//! let h = 0.01;
//! // Pins act in begin_step: they fill the constraints of the filtered solve.
//! let mut constraints = Constraints::new(model.n_particles());
//! model.begin_step(0.0, &mut state.x, &mut state.v, &mut constraints);
//!
//! // A dv = b with A = M - h df/dv - h^2 df/dx, b = h (f + h df/dx v).
//! let mut sys = model.implicit_system();
//! model.assemble_implicit_euler(h, &state.x, &state.v, &mut sys)?;
//! let mut precond = BlockJacobi::new();
//! precond.setup(&sys.a)?;
//! let mut dv = vec![0.0; model.dim()];
//! let info = filtered_pcg(&sys.a, &precond, &sys.b, &mut dv, &constraints,
//!                         &CgParams::default(), &mut CgWorkspace::new(model.dim()), None)?;
//! assert!(info.converged);
//! assert_eq!(&dv[..3], &[0.0; 3]); // the pinned end does not move
//! assert!(dv[5] < 0.0);            // the free end starts falling
//!
//! // The explicit stability limit of this state (the filtering paper's eq. 11).
//! let stab = model.stability(&state.x, &Default::default(), None)?;
//! assert!(stab.dt_max > 0.0 && stab.dt_max < h);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Options structs
//!
//! [`ModelOptions`], [`RopeParams`], [`ClothParams`], [`BlockParams`],
//! [`MeshParams`] and [`SelfCollision`] have a `Default`:
//! construct them with `..Default::default()`. Each has a hidden field, so
//! that a later version may add an option without breaking your code; a
//! literal naming every field does not compile outside this crate.
//!
//! ```
//! use hookean_massspring::{rope, ModelOptions, RopeParams};
//! let params = RopeParams {
//!     n: 5,
//!     options: ModelOptions { air_friction: 0.1, ..Default::default() },
//!     ..Default::default()
//! };
//! let (model, state) = rope(&params)?;
//! assert_eq!((model.n_particles(), state.x.len()), (5, 15));
//! assert_eq!(model.options().gravity, [0.0, 0.0, -9.81]); // the default
//! # Ok::<(), hookean_massspring::MassSpringError>(())
//! ```
//!
//! ```compile_fail
//! // Every field named, none left to the default: refused outside the crate.
//! let contact = hookean_massspring::SelfCollision { thickness: 0.004, stiffness: 50.0 };
//! ```

hookean_sparse::non_exhaustive_seal!();

mod analysis;
mod assembly;
pub mod builders;
mod carried;
mod collide;
mod contact;
mod error;
mod handles;
mod model;
pub mod obj;
pub mod path;
mod self_contact;
mod wind;

pub use analysis::{Energies, ImplicitSystem, Momentum, StabilityInfo};
pub use builders::{
    BlockParams, ClothParams, ClothPins, MAX_PARTICLES, MeshParams, RopeParams, SpringMaterial,
    State, cloth, from_mesh, jelly_block, rope, tutorial_example3,
};
pub use carried::ContactCarry;
pub use collide::{Collider, ColliderMotion, Friction, MeshCollider, MeshSequence, RigidMotion};
pub use contact::{ContactStats, STICK_SPEED};
pub use error::MassSpringError;
pub use handles::PinGroup;
pub use hookean_geometry::{GeometryError, TriMesh, surface};
pub use hookean_problem::SecondOrderProblem;
pub use model::{
    DampingInDfdx, MassSpringModel, ModelOptions, ParticleConstraint, Spring, SpringDamping,
};
pub use obj::{ObjMesh, parse_obj, read_obj_file, read_surface, speed_colours, write_obj};
pub use path::{Interpolation, Keyframe, KeyframedPath};
pub use self_contact::SelfCollision;
pub use wind::Wind;
