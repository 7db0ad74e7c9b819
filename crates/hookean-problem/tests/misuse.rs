//! API misuse of hookean-problem (issue 28): the crate holds contracts; its
//! one fallible default, `SecondOrderProblem::step_matrix`, refuses a
//! matrix of another pattern with a typed error instead of writing out of
//! place.

use std::sync::Arc;

use hookean_problem::SecondOrderProblem;
use hookean_sparse::{BlockPattern, SymBlockMatrix, block};

/// Two unit masses joined by a spring of stiffness 1 along x (no damping).
struct Pair {
    pattern: Arc<BlockPattern>,
}

impl SecondOrderProblem for Pair {
    fn dim(&self) -> usize {
        6
    }
    fn mass(&self) -> &[f64] {
        &[1.0; 6]
    }
    fn force(&self, _t: f64, x: &[f64], _v: &[f64], f: &mut [f64]) {
        let s = x[3] - x[0] - 1.0;
        f.fill(0.0);
        f[0] = s;
        f[3] = -s;
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
        let k = [[-1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]];
        let _ = dfdx.add_to_block(0, 0, &k);
        let _ = dfdx.add_to_block(1, 1, &k);
        let _ = dfdx.add_to_block(0, 1, &block::scale(&k, -1.0));
    }
}

#[test]
fn the_step_matrix_refuses_a_matrix_of_another_pattern() {
    let pattern = Arc::new(BlockPattern::new(2, [(0, 1)]).unwrap());
    let p = Pair {
        pattern: pattern.clone(),
    };
    let (x, v) = ([0.0, 0.0, 0.0, 1.5, 0.0, 0.0], [0.0; 6]);
    let mut dfdx = SymBlockMatrix::new(pattern.clone());
    let mut dfdv = SymBlockMatrix::new(pattern.clone());
    // Another topology: no (0, 1) block.
    let other = Arc::new(BlockPattern::new(2, std::iter::empty()).unwrap());
    let mut out = SymBlockMatrix::new(other);
    assert!(
        p.step_matrix(0.0, &x, &v, -0.01, -0.1, &mut dfdx, &mut dfdv, &mut out)
            .is_err()
    );
    // On its own pattern: A = M + a K, checked entry by entry.
    let mut out = SymBlockMatrix::new(pattern);
    p.step_matrix(0.0, &x, &v, -0.01, -0.1, &mut dfdx, &mut dfdv, &mut out)
        .unwrap();
    assert_eq!(out.diagonal_block(0)[0][0], 1.0 + 0.01);
    assert_eq!(out.diagonal_block(0)[1][1], 1.0);
}
