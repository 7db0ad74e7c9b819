//! Events: roots of user functions `g(t, y)` located on an integrator's
//! dense output after each step, with a direction and a terminal flag
//! ([`Integrator::solve_at_with_events`](crate::Integrator::solve_at_with_events)).

use crate::error::OdeError;

/// The direction of zero crossings an event reacts to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Direction {
    /// Both directions.
    #[default]
    Both,
    /// From negative to positive.
    Rising,
    /// From positive to negative.
    Falling,
}

/// The event functions' callback `g(t, y, out)`.
type EventFn<'a> = Box<dyn FnMut(f64, &[f64], &mut [f64]) + 'a>;

/// Event functions `g(t, y)` whose roots
/// [`Integrator::solve_at_with_events`](crate::Integrator::solve_at_with_events)
/// locates on the dense output, each with a direction and a terminal flag
/// (a terminal event ends the run at the root).
pub struct Events<'a> {
    g: EventFn<'a>,
    directions: Vec<Direction>,
    terminal: Vec<bool>,
    g_old: Vec<f64>,
    g_new: Vec<f64>,
    g_mid: Vec<f64>,
}

/// A located event.
#[derive(Debug, Clone, PartialEq)]
pub struct EventHit {
    /// Which event function.
    pub index: usize,
    /// The time of the root.
    pub t: f64,
    /// The state there (from the dense output).
    pub y: Vec<f64>,
    /// Whether the event is terminal (the run ended here).
    pub terminal: bool,
}

impl<'a> Events<'a> {
    /// `directions.len()` event functions, written by `g(t, y, out)` into `out`.
    ///
    /// # Errors
    /// [`OdeError::DimensionMismatch`] if `terminal` and `directions` differ in length.
    pub fn new(
        g: impl FnMut(f64, &[f64], &mut [f64]) + 'a,
        directions: Vec<Direction>,
        terminal: Vec<bool>,
    ) -> Result<Self, OdeError> {
        let m = directions.len();
        if terminal.len() != m {
            return Err(OdeError::DimensionMismatch {
                what: "event terminal flags",
                expected: m,
                found: terminal.len(),
            });
        }
        Ok(Self {
            g: Box::new(g),
            directions,
            terminal,
            g_old: vec![0.0; m],
            g_new: vec![0.0; m],
            g_mid: vec![0.0; m],
        })
    }

    fn crosses(&self, i: usize, a: f64, b: f64) -> bool {
        let rising = a < 0.0 && b >= 0.0;
        let falling = a > 0.0 && b <= 0.0;
        match self.directions[i] {
            Direction::Both => rising || falling,
            Direction::Rising => rising,
            Direction::Falling => falling,
        }
    }

    /// Evaluates the functions at the start of a run.
    pub(crate) fn start(&mut self, t: f64, y: &[f64]) -> Result<(), OdeError> {
        (self.g)(t, y, &mut self.g_old);
        Ok(())
    }

    /// Finds the roots of the event functions in the last step
    /// `[t_prev, t]` (`step`), which ended in `y_end`, on its dense output
    /// `interpolate(t, out)`; appends them (in time order, up to and
    /// including the first terminal one) to `hits`; returns whether a
    /// terminal event was hit and how many evaluations of `g` it took.
    pub(crate) fn locate(
        &mut self,
        step: (f64, f64),
        y_end: &[f64],
        interpolate: impl Fn(f64, &mut [f64]) -> Result<(), OdeError>,
        hits: &mut Vec<EventHit>,
    ) -> Result<(bool, usize), OdeError> {
        let m = self.directions.len();
        let (ta, tb) = step;
        (self.g)(tb, y_end, &mut self.g_new);
        let mut evaluations = 1;
        let tol = 4.0 * f64::EPSILON * ta.abs().max(tb.abs()).max(tb - ta);
        let mut found: Vec<(f64, usize)> = Vec::new();
        let mut y = vec![0.0; y_end.len()];
        for i in 0..m {
            let (ga, gb) = (self.g_old[i], self.g_new[i]);
            if !self.crosses(i, ga, gb) {
                continue;
            }
            // Illinois: regula falsi, halving the weight of a retained end.
            let (mut a, mut b, mut fa, mut fb) = (ta, tb, ga, gb);
            let mut side = 0i32;
            let mut root = tb;
            for _ in 0..100 {
                if (b - a).abs() <= tol {
                    break;
                }
                let mut tm = (a * fb - b * fa) / (fb - fa);
                if !(tm > a && tm < b) {
                    tm = 0.5 * (a + b);
                }
                interpolate(tm, &mut y)?;
                (self.g)(tm, &y, &mut self.g_mid);
                evaluations += 1;
                let fm = self.g_mid[i];
                if fm == 0.0 {
                    a = tm;
                    b = tm;
                    break;
                }
                if (fm > 0.0) == (fb > 0.0) {
                    b = tm;
                    fb = fm;
                    if side == 1 {
                        fa *= 0.5;
                    }
                    side = 1;
                } else {
                    a = tm;
                    fa = fm;
                    if side == -1 {
                        fb *= 0.5;
                    }
                    side = -1;
                }
                root = b;
            }
            if a == b {
                root = a;
            }
            found.push((root, i));
        }
        found.sort_by(|x, y| x.0.total_cmp(&y.0));
        let mut terminal = false;
        for (t_root, i) in found {
            interpolate(t_root, &mut y)?;
            hits.push(EventHit {
                index: i,
                t: t_root,
                y: y.clone(),
                terminal: self.terminal[i],
            });
            if self.terminal[i] {
                terminal = true;
                (self.g)(t_root, &y, &mut self.g_old);
                evaluations += 1;
                break;
            }
        }
        if !terminal {
            std::mem::swap(&mut self.g_old, &mut self.g_new);
        }
        Ok((terminal, evaluations))
    }
}
