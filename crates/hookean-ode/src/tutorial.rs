//! The ODE examples of Hauth's tutorial (section 2) with exact solutions:
//! the reference problems of the work-precision diagrams (figures 3, 5, 7)
//! and the order tests.
//!
//! 1. Dahlquist's equation `y' = lambda y`, `y(0) = 1`, `t in [0, 1]`,
//!    `lambda = 2` or `-15`: `y(t) = e^{lambda t}` ([`Dahlquist`]).
//! 2. The overdamped "wave equation" `y'' = (lambda/2) y + lambda y'` with
//!    `lambda = -5`, i.e. `y'' = -5/2 y - 5 y'`, `y(0) = 0`, `y'(0) = 1`,
//!    `t in [0, 10]`. The characteristic roots of `r^2 + 5 r + 5/2 = 0` are
//!    `r_{1,2} = (-5 +- sqrt 15) / 2`, so
//!    `y(t) = (e^{r_1 t} - e^{r_2 t}) / sqrt 15` (the printed formula is
//!    garbled; this is the derived solution, and it matches the printed
//!    coefficients `1/15 sqrt 15`).
//! 3. A particle of mass `m = 0.1` on a spring (`k = 100`, rest length
//!    `l0 = -1`, damping `d = 1`) under gravity `g = -10`, eq. (8):
//!    `z'' = k (l0 - z)/m - (d/m) z' + g`, `z(0) = -1`, `z'(0) = -5`,
//!    `t in [0, 2]`. With `w = z - z_eq`, `z_eq = l0 + m g / k = -1.01`:
//!    `w'' + 10 w' + 1000 w = 0`, underdamped,
//!    `w = e^{-5 t} (A cos nu t + B sin nu t)`, `nu = sqrt 975`,
//!    `A = 0.01`, `B = (-5 + 5 A) / nu`.
//!
//! Examples 2 and 3 (and the undamped `y'' = -5 y` of figure 7) are
//! instances of [`LinearOscillator`] `m z'' = -k (z - a) - d z' + m g`,
//! available as a first-order system (6) ([`OscillatorFirstOrder`]) and as
//! a one-particle [`SecondOrderProblem`] ([`OscillatorParticle`]: the same
//! law in each of the three coordinates, anchor `(0, 0, a)`, gravity along
//! z; started on the z axis it stays there).

use std::sync::Arc;

use hookean_problem::{FirstOrderProblem, SecondOrderProblem};
use hookean_sparse::{BlockPattern, SymBlockMatrix, block};

/// Example 1: Dahlquist's test equation `y' = lambda y` (eq. 20).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dahlquist {
    /// The eigenvalue `lambda`.
    pub lambda: f64,
}

impl Dahlquist {
    /// The tutorial's interval end, `t_end = 1`.
    pub const T_END: f64 = 1.0;

    /// The exact solution `e^{lambda t}` for `y(0) = 1` (eq. 21).
    pub fn exact(&self, t: f64) -> f64 {
        (self.lambda * t).exp()
    }
}

impl FirstOrderProblem for Dahlquist {
    fn dim(&self) -> usize {
        1
    }

    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = self.lambda * y[0];
    }

    fn jacobian(&self, _t: f64, _y: &[f64], jac: &mut [f64]) -> bool {
        jac[0] = self.lambda;
        true
    }
}

/// A damped linear oscillator `m z'' = -k (z - a) - d z' + m g` with
/// initial values and an interval: examples 2 and 3 and figure 7's `y'' = -5 y`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearOscillator {
    /// Mass `m > 0`.
    pub mass: f64,
    /// Spring stiffness `k >= 0`.
    pub stiffness: f64,
    /// Damping `d >= 0`.
    pub damping: f64,
    /// Spring anchor (rest position without gravity) `a`.
    pub anchor: f64,
    /// Gravity `g`.
    pub gravity: f64,
    /// `z(0)`.
    pub z0: f64,
    /// `z'(0)`.
    pub v0: f64,
    /// End of the tutorial's interval.
    pub t_end: f64,
}

impl LinearOscillator {
    /// Example 2: `y'' = -5/2 y - 5 y'`, `y(0) = 0`, `y'(0) = 1`, `t in [0, 10]`.
    pub fn example2() -> Self {
        Self {
            mass: 1.0,
            stiffness: 2.5,
            damping: 5.0,
            anchor: 0.0,
            gravity: 0.0,
            z0: 0.0,
            v0: 1.0,
            t_end: 10.0,
        }
    }

    /// Example 3: eq. (8) with `m = 0.1, k = 100, l0 = -1, d = 1, g = -10`,
    /// `z(0) = -1`, `z'(0) = -5`, `t in [0, 2]`.
    pub fn example3() -> Self {
        Self {
            mass: 0.1,
            stiffness: 100.0,
            damping: 1.0,
            anchor: -1.0,
            gravity: -10.0,
            z0: -1.0,
            v0: -5.0,
            t_end: 2.0,
        }
    }

    /// Figure 7's undamped wave equation `y'' = -omega2 y` (the tutorial
    /// uses `omega2 = 5`), `y(0) = 1`, `y'(0) = 0`, `t in [0, 10]`.
    pub fn undamped(omega2: f64) -> Self {
        Self {
            mass: 1.0,
            stiffness: omega2,
            damping: 0.0,
            anchor: 0.0,
            gravity: 0.0,
            z0: 1.0,
            v0: 0.0,
            t_end: 10.0,
        }
    }

    /// The equilibrium `z_eq = a + m g / k` (`a` when `k = 0`).
    pub fn equilibrium(&self) -> f64 {
        if self.stiffness > 0.0 {
            self.anchor + self.mass * self.gravity / self.stiffness
        } else {
            self.anchor
        }
    }

    /// The exact `(z(t), z'(t))`: with `w = z - z_eq`, `w'' + gamma w' +
    /// omega^2 w = 0` (`gamma = d/m`, `omega^2 = k/m`), solved in the
    /// over-, under- and critically damped cases. Requires `k > 0`.
    pub fn exact(&self, t: f64) -> [f64; 2] {
        let gamma = self.damping / self.mass;
        let w2 = self.stiffness / self.mass;
        let zeq = self.equilibrium();
        let (w0, dw0) = (self.z0 - zeq, self.v0);
        let disc = gamma * gamma / 4.0 - w2;
        let mu = -gamma / 2.0;
        let (w, dw) = if disc > 1e-12 * w2 {
            let s = disc.sqrt();
            let (r1, r2) = (mu + s, mu - s);
            let c1 = (dw0 - r2 * w0) / (r1 - r2);
            let c2 = w0 - c1;
            let (e1, e2) = ((r1 * t).exp(), (r2 * t).exp());
            (c1 * e1 + c2 * e2, c1 * r1 * e1 + c2 * r2 * e2)
        } else if disc < -1e-12 * w2 {
            let nu = (-disc).sqrt();
            let a = w0;
            let b = (dw0 - mu * a) / nu;
            let e = (mu * t).exp();
            let (c, s) = ((nu * t).cos(), (nu * t).sin());
            (
                e * (a * c + b * s),
                e * ((mu * a + nu * b) * c + (mu * b - nu * a) * s),
            )
        } else {
            let a = w0;
            let b = dw0 - mu * a;
            let e = (mu * t).exp();
            (e * (a + b * t), e * (b + mu * (a + b * t)))
        };
        [zeq + w, dw]
    }

    /// The exact state `[x; v]` of [`particle`](Self::particle) at `t`.
    pub fn exact_particle(&self, t: f64) -> [f64; 6] {
        let [z, v] = self.exact(t);
        [0.0, 0.0, z, 0.0, 0.0, v]
    }

    /// The mechanical energy `m v^2 / 2 + k (z - z_eq)^2 / 2` (with gravity
    /// folded into the shifted spring); conserved when `d = 0`.
    pub fn energy(&self, z: f64, v: f64) -> f64 {
        let w = z - self.equilibrium();
        0.5 * self.mass * v * v + 0.5 * self.stiffness * w * w
    }

    /// The first-order form (6): `y = (z, z')`.
    pub fn first_order(&self) -> OscillatorFirstOrder {
        OscillatorFirstOrder { osc: *self }
    }

    /// The initial value `[z0, v0]` of [`first_order`](Self::first_order).
    pub fn y0(&self) -> [f64; 2] {
        [self.z0, self.v0]
    }

    /// The one-particle second-order problem.
    pub fn particle(&self) -> OscillatorParticle {
        OscillatorParticle {
            osc: *self,
            mass: [self.mass; 3],
            pattern: Arc::new(BlockPattern::new(1, std::iter::empty()).expect("one block")),
        }
    }

    /// The initial positions `(0, 0, z0)` of [`particle`](Self::particle).
    pub fn x0(&self) -> [f64; 3] {
        [0.0, 0.0, self.z0]
    }

    /// The initial velocities `(0, 0, v0)` of [`particle`](Self::particle).
    pub fn v0_vec(&self) -> [f64; 3] {
        [0.0, 0.0, self.v0]
    }
}

/// [`LinearOscillator`] as the first-order system `(z, v)' = (v, a(z, v))`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OscillatorFirstOrder {
    /// The oscillator.
    pub osc: LinearOscillator,
}

impl FirstOrderProblem for OscillatorFirstOrder {
    fn dim(&self) -> usize {
        2
    }

    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) {
        let o = &self.osc;
        dy[0] = y[1];
        dy[1] = (-o.stiffness * (y[0] - o.anchor) - o.damping * y[1]) / o.mass + o.gravity;
    }

    fn jacobian(&self, _t: f64, _y: &[f64], jac: &mut [f64]) -> bool {
        let o = &self.osc;
        jac.copy_from_slice(&[0.0, 1.0, -o.stiffness / o.mass, -o.damping / o.mass]);
        true
    }
}

/// [`LinearOscillator`] as one particle in 3D: `f = -k (x - (0,0,a)) - d v
/// + m (0, 0, g)`, `df/dx = -k I`, `df/dv = -d I`.
#[derive(Debug, Clone)]
pub struct OscillatorParticle {
    /// The oscillator.
    pub osc: LinearOscillator,
    mass: [f64; 3],
    pattern: Arc<BlockPattern>,
}

impl SecondOrderProblem for OscillatorParticle {
    fn dim(&self) -> usize {
        3
    }

    fn mass(&self) -> &[f64] {
        &self.mass
    }

    fn force(&self, _t: f64, x: &[f64], v: &[f64], f: &mut [f64]) {
        let o = &self.osc;
        let anchor = [0.0, 0.0, o.anchor];
        let g = [0.0, 0.0, o.gravity];
        for i in 0..3 {
            f[i] = -o.stiffness * (x[i] - anchor[i]) - o.damping * v[i] + o.mass * g[i];
        }
    }

    fn jacobian_pattern(&self) -> Arc<BlockPattern> {
        self.pattern.clone()
    }

    fn force_jacobians(
        &self,
        _t: f64,
        _x: &[f64],
        _v: &[f64],
        dfdx: &mut SymBlockMatrix,
        dfdv: &mut SymBlockMatrix,
    ) {
        dfdx.set_zero();
        dfdv.set_zero();
        dfdx.add_to_block(0, 0, &block::scale(&block::IDENTITY, -self.osc.stiffness))
            .expect("diagonal block");
        dfdv.add_to_block(0, 0, &block::scale(&block::IDENTITY, -self.osc.damping))
            .expect("diagonal block");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The exact solutions satisfy their ODE: residual of `m z'' + d z' +
    /// k (z - a) - m g` with `z''` by central differences of `z'`.
    #[test]
    fn exact_solutions_satisfy_the_ode() {
        for o in [
            LinearOscillator::example2(),
            LinearOscillator::example3(),
            LinearOscillator::undamped(5.0),
        ] {
            assert_eq!(o.exact(0.0)[0], o.z0);
            assert!((o.exact(0.0)[1] - o.v0).abs() < 1e-14);
            for t in [0.1, 0.37, 1.3] {
                let e = 1e-5;
                let [z, v] = o.exact(t);
                // z' is the derivative of z:
                let dz = (o.exact(t + e)[0] - o.exact(t - e)[0]) / (2.0 * e);
                assert!((dz - v).abs() < 1e-6 * (1.0 + v.abs()), "{dz} vs {v}");
                let acc = (o.exact(t + e)[1] - o.exact(t - e)[1]) / (2.0 * e);
                let res = o.mass * acc + o.damping * v + o.stiffness * (z - o.anchor)
                    - o.mass * o.gravity;
                assert!(res.abs() < 1e-5 * (1.0 + o.stiffness), "residual {res}");
            }
        }
    }

    /// Example 2 against the closed form (e^{r1 t} - e^{r2 t}) / sqrt 15.
    #[test]
    fn example2_matches_its_closed_form() {
        let o = LinearOscillator::example2();
        let s15 = 15f64.sqrt();
        let (r1, r2) = ((-5.0 + s15) / 2.0, (-5.0 - s15) / 2.0);
        for t in [0.5, 2.0, 10.0] {
            let y = ((r1 * t).exp() - (r2 * t).exp()) / s15;
            assert!((o.exact(t)[0] - y).abs() < 1e-15);
        }
    }

    #[test]
    fn example3_equilibrium_and_frequency() {
        let o = LinearOscillator::example3();
        assert!((o.equilibrium() + 1.01).abs() < 1e-15);
        // Decays like e^{-5 t} around -1.01.
        let late = o.exact(2.0)[0] + 1.01;
        assert!(late.abs() < 0.0105 * (-10.0f64).exp() * 50.0);
    }
}
