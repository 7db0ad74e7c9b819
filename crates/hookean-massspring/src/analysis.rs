//! Analysis of a state: the explicit stability limit (the filtering
//! paper's eq. 11), energies and momenta, and the linearised implicit-Euler
//! system with its Matrix Market export.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use hookean_sparse::{MatrixFree, PowerParams, SymBlockMatrix, power_method};

use crate::assembly::AssemblyMode;
use crate::error::{MassSpringError, io_err};
use crate::model::{DampingInDfdx, MassSpringModel, SpringDamping, point};

use hookean_sparse::PowerHook;

/// The explicit stability limit of a state.
#[derive(Debug, Clone, PartialEq)]
pub struct StabilityInfo {
    /// `k0`: the largest eigenvalue of `M^-1 K`, `K = -df/dx` (clamped,
    /// constrained directions projected out).
    pub k0: f64,
    /// `dt_max = 2 / sqrt(k0)` (the filtering paper's eq. 11).
    pub dt_max: f64,
    /// Power-method iterations.
    pub iterations: usize,
}

/// Energies of a state (J).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Energies {
    /// `1/2 sum_p m_p |v_p|^2`.
    pub kinetic: f64,
    /// `-sum_p m_p g . x_p` (zero at the origin).
    pub gravitational: f64,
    /// `1/2 sum_s k_s (l_s - l0_s)^2`.
    pub spring: f64,
    /// `-sum_p F_p . x_p`: the potential of the constant external forces
    /// ([`MassSpringModel::set_external_force`]; zero without them), so
    /// that their work is the drop of this term, as gravity's is.
    pub external: f64,
}

impl Energies {
    /// Kinetic + gravitational + spring energy (+ the external forces'
    /// potential): conserved by the undamped model without contact.
    pub fn total(&self) -> f64 {
        self.kinetic + self.gravitational + self.spring + self.external
    }

    /// The terms by name, in the order of [`total`](Self::total).
    pub fn terms(&self) -> [(&'static str, f64); 4] {
        [
            ("kinetic", self.kinetic),
            ("gravitational", self.gravitational),
            ("spring", self.spring),
            ("external-force", self.external),
        ]
    }
}

/// Linear and angular momentum of a state.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Momentum {
    /// `sum_p m_p v_p` (kg m/s).
    pub linear: [f64; 3],
    /// `sum_p m_p x_p x v_p` about the origin (kg m^2/s).
    pub angular: [f64; 3],
}

/// Buffers of the linearised implicit-Euler system, reusable across steps
/// (see [`MassSpringModel::assemble_implicit_euler`]).
#[derive(Debug, Clone)]
pub struct ImplicitSystem {
    /// `A = M - h df/dv - h^2 df/dx`.
    pub a: SymBlockMatrix,
    /// `b = h (f + h df/dx v)`.
    pub b: Vec<f64>,
    /// `df/dx` at the state.
    pub dfdx: SymBlockMatrix,
    /// `df/dv` at the state.
    pub dfdv: SymBlockMatrix,
    /// `f` at the state.
    pub f: Vec<f64>,
    kv: Vec<f64>,
}

impl MassSpringModel {
    /// The largest eigenvalue `k0` of `M^-1 K` at `x` (`K = -df/dx`,
    /// clamped stiffness only, constrained directions projected out) by the
    /// power method of hookean-sparse on a matrix-free operator, and the
    /// explicit stability limit `dt_max = 2 / sqrt(k0)` (the filtering
    /// paper's eq. 11). `hook` transforms the iterate between iterations (the
    /// paper's Algorithm 1 plugs a velocity filter in); `None` for the plain
    /// method.
    ///
    /// # Errors
    /// As [`check_state`](Self::check_state) (with `v = 0`);
    /// [`MassSpringError::Sparse`] from the power method (no springs: the
    /// iterate vanishes); [`MassSpringError::PowerMethodNotConverged`].
    pub fn stability(
        &self,
        x: &[f64],
        params: &PowerParams,
        hook: Option<PowerHook<'_>>,
    ) -> Result<StabilityInfo, MassSpringError> {
        let v = vec![0.0; x.len()];
        self.check_state(x, &v)?;
        let mut dfdx = SymBlockMatrix::new(self.plan.pattern.clone());
        self.assemble_jacobians(
            x,
            &v,
            &mut dfdx,
            None,
            AssemblyMode {
                clamp: true,
                damping_in_dfdx: DampingInDfdx::Drop,
            },
        );
        let mass = &self.mass;
        let op = MatrixFree::new(x.len(), |z: &[f64], y: &mut [f64]| {
            dfdx.mul_vec(z, y).expect("sizes match by construction");
            for (yi, mi) in y.iter_mut().zip(mass) {
                *yi = -*yi / mi;
            }
        });
        let info = power_method(&op, params, hook)?;
        if !info.converged {
            return Err(MassSpringError::PowerMethodNotConverged {
                iterations: info.iterations,
                estimate: info.eigenvalue,
            });
        }
        let k0 = info.eigenvalue;
        Ok(StabilityInfo {
            k0,
            dt_max: if k0 > 0.0 {
                2.0 / k0.sqrt()
            } else {
                f64::INFINITY
            },
            iterations: info.iterations,
        })
    }

    /// Kinetic, gravitational and spring energy of `(x, v)`.
    ///
    /// # Errors
    /// As [`check_state`](Self::check_state).
    pub fn energies(&self, x: &[f64], v: &[f64]) -> Result<Energies, MassSpringError> {
        // check_state's checks, the finiteness one only when the sum is not
        // finite: a non-finite entry of x or v makes its term non-finite
        // (0 * inf and 0 * NaN are NaN), so a finite total proves a finite
        // state without a pass of its own (the energy guard evaluates this
        // after every step).
        let dim = 3 * self.n_particles();
        for (what, len) in [("x", x.len()), ("v", v.len())] {
            if len != dim {
                return Err(MassSpringError::DimensionMismatch {
                    what,
                    expected: dim,
                    found: len,
                });
            }
        }
        let check_finite = || -> Result<(), MassSpringError> {
            crate::error::check_vec("x", x, dim)?;
            crate::error::check_vec("v", v, dim)
        };
        let g = self.options.gravity;
        let (x3, v3) = (x.as_chunks::<3>().0, v.as_chunks::<3>().0);
        let (mut kinetic2, mut gravitational) = (0.0, 0.0);
        for ((&m, xp), vp) in self.particle_mass.iter().zip(x3).zip(v3) {
            kinetic2 += m * (vp[0] * vp[0] + vp[1] * vp[1] + vp[2] * vp[2]);
            gravitational -= m * (g[0] * xp[0] + g[1] * xp[1] + g[2] * xp[2]);
        }
        let mut e = Energies {
            kinetic: 0.5 * kinetic2,
            gravitational,
            external: -hookean_sparse::vecops::dot(&self.external, x),
            spring: 0.0,
        };
        let Some(spring) = self.spring_energy(x) else {
            check_finite()?;
            // The shortest spring, the first of them in the model's order:
            // one of length 0 (a sum of squares is 0 in any order of
            // addition when it is in the sweep's).
            let length2 = |s: &crate::Spring| (point(x, s.j) - point(x, s.i)).norm_squared();
            let shortest = self
                .springs
                .iter()
                .enumerate()
                .min_by(|a, b| length2(a.1).total_cmp(&length2(b.1)));
            let (k, s) = shortest.expect("a spring of length 0 exists");
            return Err(MassSpringError::ZeroLengthSpring {
                spring: k,
                i: s.i,
                j: s.j,
            });
        };
        e.spring = spring + self.soft_pin_energy(x);
        if !e.total().is_finite() {
            check_finite()?;
        }
        Ok(e)
    }

    /// Linear and angular momentum of `(x, v)`.
    ///
    /// # Errors
    /// As [`check_state`](Self::check_state).
    pub fn momentum(&self, x: &[f64], v: &[f64]) -> Result<Momentum, MassSpringError> {
        self.check_state(x, v)?;
        let mut lin = nalgebra::Vector3::zeros();
        let mut ang = nalgebra::Vector3::zeros();
        for (p, &m) in self.particle_mass.iter().enumerate() {
            let vp = point(v, p) * m;
            lin += vp;
            ang += point(x, p).cross(&vp);
        }
        Ok(Momentum {
            linear: [lin.x, lin.y, lin.z],
            angular: [ang.x, ang.y, ang.z],
        })
    }

    /// Buffers for [`assemble_implicit_euler`](Self::assemble_implicit_euler).
    pub fn implicit_system(&self) -> ImplicitSystem {
        let dim = 3 * self.n_particles();
        ImplicitSystem {
            a: SymBlockMatrix::new(self.plan.pattern.clone()),
            b: vec![0.0; dim],
            dfdx: SymBlockMatrix::new(self.plan.pattern.clone()),
            dfdv: SymBlockMatrix::new(self.plan.pattern.clone()),
            f: vec![0.0; dim],
            kv: vec![0.0; dim],
        }
    }

    /// The linearised implicit-Euler system of the state (Baraff-Witkin's
    /// velocity form, the tutorial's setting (6) with one Newton step):
    /// `A dv = b`, `A = M - h df/dv - h^2 df/dx`, `b = h (f + h df/dx v)`,
    /// with the model's Jacobian options. No allocation.
    ///
    /// # Errors
    /// As [`check_state`](Self::check_state); [`MassSpringError::InvalidParameter`]
    /// for `h <= 0` or non-finite.
    pub fn assemble_implicit_euler(
        &self,
        h: f64,
        x: &[f64],
        v: &[f64],
        sys: &mut ImplicitSystem,
    ) -> Result<(), MassSpringError> {
        if !(h > 0.0 && h.is_finite()) {
            return Err(MassSpringError::InvalidParameter {
                name: "h",
                message: format!("step size {h} must be positive and finite"),
            });
        }
        self.check_state(x, v)?;
        for (what, len) in [("b", sys.b.len()), ("f", sys.f.len()), ("kv", sys.kv.len())] {
            if len != x.len() {
                return Err(MassSpringError::DimensionMismatch {
                    what,
                    expected: x.len(),
                    found: len,
                });
            }
        }
        self.eval_force(x, v, &mut sys.f);
        self.jacobians_checked(
            x,
            v,
            self.options.clamp_stiffness,
            &mut sys.dfdx,
            &mut sys.dfdv,
        )?;
        sys.dfdx.mul_vec(v, &mut sys.kv)?;
        for ((b, f), kv) in sys.b.iter_mut().zip(&sys.f).zip(&sys.kv) {
            *b = h * (f + h * kv);
        }
        sys.a
            .assign_diagonal_plus_combination(&self.mass, -h * h, &sys.dfdx, -h, &sys.dfdv)?;
        Ok(())
    }

    /// Writes the linearised implicit-Euler system `(A, b)` of the state
    /// (see [`assemble_implicit_euler`](Self::assemble_implicit_euler)) as
    /// Matrix Market: `A` as `coordinate real symmetric`, `b` as an array.
    ///
    /// # Errors
    /// As [`assemble_implicit_euler`](Self::assemble_implicit_euler);
    /// [`MassSpringError::Sparse`] / [`MassSpringError::Io`] when writing fails.
    pub fn write_implicit_euler_system(
        &self,
        h: f64,
        x: &[f64],
        v: &[f64],
        a_out: impl Write,
        b_out: impl Write,
    ) -> Result<(), MassSpringError> {
        let mut sys = self.implicit_system();
        self.assemble_implicit_euler(h, x, v, &mut sys)?;
        hookean_sparse::write_matrix_market(a_out, &sys.a.to_csr(), true)?;
        hookean_sparse::write_vector_market(b_out, &sys.b)?;
        Ok(())
    }

    /// [`write_implicit_euler_system`](Self::write_implicit_euler_system) to two files.
    ///
    /// # Errors
    /// As [`write_implicit_euler_system`](Self::write_implicit_euler_system).
    pub fn export_implicit_euler_system(
        &self,
        h: f64,
        x: &[f64],
        v: &[f64],
        a_path: impl AsRef<Path>,
        b_path: impl AsRef<Path>,
    ) -> Result<(), MassSpringError> {
        let open = |p: &Path| {
            File::create(p)
                .map(BufWriter::new)
                .map_err(|e| io_err(&p.display().to_string(), e))
        };
        let mut a = open(a_path.as_ref())?;
        let mut b = open(b_path.as_ref())?;
        self.write_implicit_euler_system(h, x, v, &mut a, &mut b)?;
        a.flush()
            .map_err(|e| io_err(&a_path.as_ref().display().to_string(), e))?;
        b.flush()
            .map_err(|e| io_err(&b_path.as_ref().display().to_string(), e))?;
        Ok(())
    }

    /// The damping power `sum_p f^damp_p . v_p` (W) of the spring damping
    /// and air friction at `(x, v)`: zero for a rigid rotation under
    /// projected damping, negative under the incorrect one.
    ///
    /// # Errors
    /// As [`check_state`](Self::check_state).
    pub fn damping_power(&self, x: &[f64], v: &[f64]) -> Result<f64, MassSpringError> {
        self.check_state(x, v)?;
        let mut power = 0.0;
        for s in &self.springs {
            let e = point(x, s.j) - point(x, s.i);
            let u = e / e.norm();
            let dv = point(v, s.j) - point(v, s.i);
            // f_i . v_i + f_j . v_j = -f_i . dv.
            power -= match self.options.damping {
                SpringDamping::Projected => s.damping * dv.dot(&u).powi(2),
                SpringDamping::Incorrect => s.damping * dv.norm_squared(),
                SpringDamping::None => 0.0,
            };
        }
        for p in 0..self.n_particles() {
            power -= self.options.air_friction * point(v, p).norm_squared();
        }
        Ok(power)
    }
}
