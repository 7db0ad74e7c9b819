//! Choosing a method by name: the [`Method`] enum.

use std::fmt;
use std::str::FromStr;

use crate::bdf_config::BdfConfig;
use crate::error::OdeError;
use crate::tableau::ButcherTableau;

/// The integration methods of the tutorial's section 2 and the filtering
/// paper's section 3.2, by name (`FromStr`/`Display` use the names below).
#[derive(Debug, Clone, PartialEq)]
pub enum Method {
    /// `"explicit-euler"`: eq. (10), order 1.
    ExplicitEuler,
    /// `"midpoint"`: the explicit midpoint rule, eqs. (16)-(17), order 2.
    Midpoint,
    /// `"rk4"`: the classical Runge-Kutta method (table 2(b)), order 4.
    Rk4,
    /// Any explicit Runge-Kutta method given by its tableau (eq. 19). Its
    /// `Display` is the tableau's name; it has no `FromStr` name.
    ExplicitRk(ButcherTableau),
    /// `"fb-euler"`: forward-backward (symplectic) Euler for second-order
    /// problems, `v_{n+1} = v_n + h M^{-1} f(x_n, v_n)`,
    /// `x_{n+1} = x_n + h v_{n+1}` (filtering paper, section 3.2), order 1.
    FbEuler,
    /// `"verlet"`: Stoermer-Verlet / leapfrog for second-order problems,
    /// eqs. (44)-(45) with `f(x_n, v_{n-1})` when `f` depends on `v`, order 2
    /// (1 when the force depends on the velocity).
    Verlet,
    /// `"implicit-euler"`: eq. (24), order 1.
    ImplicitEuler,
    /// `"implicit-midpoint"`: eq. (32), order 2.
    ImplicitMidpoint,
    /// `"bdf1"` .. `"bdf6"`: fixed-step BDF(k) (eq. 36), order k.
    Bdf(usize),
    /// `"bdf2-variable"`: BDF2 with variable step size, a local error
    /// estimate and step-size control.
    Bdf2Variable,
    /// `"bdf"`: the variable-order (1-5), variable-step BDF/NDF with error
    /// control, the recommended solver for stiff problems
    /// ([`bdf`](crate::bdf); the NDF of ode15s by default,
    /// [`BdfConfig::formula`]), with its own settings (the name `"bdf"`
    /// gives the defaults, [`Method::variable_bdf`]). Second-order
    /// problems run on the reduced stage equations with PCG. Tolerances
    /// `rtol`, `atol`, step cap and retries of
    /// [`SolverOptions`](crate::SolverOptions). Not in
    /// [`Method::all_named`], whose methods the work-precision sweeps run
    /// over step sizes: this one chooses its own.
    VariableBdf(BdfConfig),
    /// `"imex"`: the implicit-explicit Euler scheme of Eberhardt, Etzmuss
    /// and Hauth (2000) for second-order problems with a linear part
    /// (eq. 50): the linear force implicit, with its constant matrix
    /// factored once, the nonlinear remainder explicit ([`crate::imex`]
    /// has the formulas). Order 1. Not in [`Method::all_named`]: it needs
    /// a problem with [`linearized_jacobians_iso`](crate::SecondOrderProblem::linearized_jacobians_iso).
    Imex,
}

impl Method {
    /// The variable-order BDF with the default [`BdfConfig`] (the method
    /// named `"bdf"`).
    pub fn variable_bdf() -> Method {
        Method::VariableBdf(BdfConfig::default())
    }

    /// All methods that have a name and run at a given step size or by
    /// BDF2's controller, in a fixed order (not IMEX, which needs a linear
    /// part, nor the variable-order BDF, which chooses its steps).
    pub fn all_named() -> Vec<Method> {
        let mut v = vec![
            Method::ExplicitEuler,
            Method::Midpoint,
            Method::Rk4,
            Method::FbEuler,
            Method::Verlet,
            Method::ImplicitEuler,
            Method::ImplicitMidpoint,
        ];
        v.extend((1..=6).map(Method::Bdf));
        v.push(Method::Bdf2Variable);
        v
    }

    /// The classical order of convergence (for Verlet: on forces that do
    /// not depend on the velocity; for a custom tableau: its order from
    /// the order conditions up to 4; for the variable-order BDF its order
    /// limit, [`BdfConfig::max_order`]).
    pub fn order(&self) -> usize {
        match self {
            Method::ExplicitEuler | Method::FbEuler | Method::ImplicitEuler | Method::Imex => 1,
            Method::Midpoint | Method::Verlet | Method::ImplicitMidpoint | Method::Bdf2Variable => {
                2
            }
            Method::Rk4 => 4,
            Method::ExplicitRk(t) => t.order(1e-12),
            Method::Bdf(k) => *k,
            Method::VariableBdf(config) => config.max_order,
        }
    }

    /// True for the methods that solve a system every step (a nonlinear
    /// one, or IMEX's linear one): they have no explicit stability limit and
    /// are not velocity-filtered.
    pub fn is_implicit(&self) -> bool {
        matches!(
            self,
            Method::ImplicitEuler
                | Method::ImplicitMidpoint
                | Method::Bdf(_)
                | Method::Bdf2Variable
                | Method::VariableBdf(_)
                | Method::Imex
        )
    }

    /// True for the methods that only apply to second-order problems.
    pub fn is_second_order_only(&self) -> bool {
        matches!(self, Method::FbEuler | Method::Verlet | Method::Imex)
    }

    /// True for variable-step BDF2, the variable-step method of the
    /// integrators' core (the variable-order BDF is its own solver).
    pub fn is_variable_step(&self) -> bool {
        matches!(self, Method::Bdf2Variable)
    }

    /// The Butcher tableau of a Runge-Kutta method (explicit ones, implicit
    /// Euler, implicit midpoint and BDF1 = implicit Euler), `None` for the
    /// multistep and the second-order-only methods.
    pub fn tableau(&self) -> Option<ButcherTableau> {
        match self {
            Method::ExplicitEuler => Some(ButcherTableau::explicit_euler()),
            Method::Midpoint => Some(ButcherTableau::explicit_midpoint()),
            Method::Rk4 => Some(ButcherTableau::rk4()),
            Method::ExplicitRk(t) => Some(t.clone()),
            Method::ImplicitEuler | Method::Bdf(1) => Some(ButcherTableau::implicit_euler()),
            Method::ImplicitMidpoint => Some(ButcherTableau::implicit_midpoint()),
            _ => None,
        }
    }

    pub(crate) fn check(&self) -> Result<(), OdeError> {
        match self {
            Method::Bdf(k) if !(1..=6).contains(k) => Err(OdeError::InvalidParameter {
                name: "k",
                value: *k as f64,
                reason: "BDF(k) exists for k = 1..6 only",
            }),
            Method::ExplicitRk(t) if !t.is_explicit() => Err(OdeError::InvalidTableau {
                reason: "the integrator runs explicit tableaus only (A strictly lower triangular)",
            }),
            _ => Ok(()),
        }
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Method::ExplicitEuler => f.write_str("explicit-euler"),
            Method::Midpoint => f.write_str("midpoint"),
            Method::Rk4 => f.write_str("rk4"),
            Method::ExplicitRk(t) => f.write_str(t.name()),
            Method::FbEuler => f.write_str("fb-euler"),
            Method::Verlet => f.write_str("verlet"),
            Method::ImplicitEuler => f.write_str("implicit-euler"),
            Method::ImplicitMidpoint => f.write_str("implicit-midpoint"),
            Method::Bdf(k) => write!(f, "bdf{k}"),
            Method::Bdf2Variable => f.write_str("bdf2-variable"),
            Method::VariableBdf(_) => f.write_str("bdf"),
            Method::Imex => f.write_str("imex"),
        }
    }
}

impl FromStr for Method {
    type Err = OdeError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let m = match s {
            "explicit-euler" | "euler" => Method::ExplicitEuler,
            "midpoint" | "explicit-midpoint" => Method::Midpoint,
            "rk4" => Method::Rk4,
            "fb-euler" => Method::FbEuler,
            "verlet" | "leapfrog" => Method::Verlet,
            "implicit-euler" => Method::ImplicitEuler,
            "implicit-midpoint" => Method::ImplicitMidpoint,
            "bdf2-variable" => Method::Bdf2Variable,
            "bdf" => Method::variable_bdf(),
            "imex" | "imex-euler" => Method::Imex,
            _ => match s.strip_prefix("bdf").and_then(|k| k.parse::<usize>().ok()) {
                Some(k) if (1..=6).contains(&k) => Method::Bdf(k),
                _ => {
                    return Err(OdeError::UnknownMethod {
                        name: s.to_string(),
                    });
                }
            },
        };
        Ok(m)
    }
}
