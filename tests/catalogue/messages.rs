//! Cases of the catalogue: refusals in the user's words (issue 37). Every
//! refusal names the key (`--set key=value`), flag or file the user wrote,
//! with its documented range (`hookean scene-keys`, `hookean::range`); the
//! variable-step methods' step cap (`integrator.max_steps`) is a checked key
//! that the work estimate counts; near-nullspace files of the wrong shape are
//! bad input naming the file and the shape expected; a table a scene would
//! ignore is refused naming it. Every case also passes the catalogue's check
//! that no message prints a number of 20 digits the user did not write.

use crate::{CLOTH, Case, SPD, case};

/// A 12 x 12 tridiagonal SPD matrix (4 on the diagonal, -1 beside it).
const TRIDIAGONAL: &str = "%%MatrixMarket matrix coordinate real symmetric\n12 12 23\n1 1 4\n2 1 -1\n2 2 4\n3 2 -1\n3 3 4\n4 3 -1\n4 4 4\n5 4 -1\n5 5 4\n6 5 -1\n6 6 4\n7 6 -1\n7 7 4\n8 7 -1\n8 8 4\n9 8 -1\n9 9 4\n10 9 -1\n10 10 4\n11 10 -1\n11 11 4\n12 11 -1\n12 12 4\n";

/// The constant on 12 unknowns: the near-nullspace of a scalar problem.
const CONSTANT: &str =
    "%%MatrixMarket matrix array real general\n12 1\n1\n1\n1\n1\n1\n1\n1\n1\n1\n1\n1\n1\n";

/// Four columns on 12 unknowns of one unknown per node (the constant
/// first, so the block size read off it is 1).
const FOUR_COLUMNS: &str = "%%MatrixMarket matrix array real general\n12 4\n1\n1\n1\n1\n1\n1\n1\n1\n1\n1\n1\n1\n1\n2\n3\n4\n5\n6\n7\n8\n9\n10\n11\n12\n1\n4\n9\n16\n25\n36\n49\n64\n81\n100\n121\n144\n1\n0\n1\n0\n1\n0\n1\n0\n1\n0\n1\n0\n";

/// A column of zeros.
const ZERO_COLUMN: &str =
    "%%MatrixMarket matrix array real general\n12 1\n0\n0\n0\n0\n0\n0\n0\n0\n0\n0\n0\n0\n";

/// The tutorial's example 1.
const TUTORIAL: &str = "duration = 1\n[tutorial]\nexample = 1\n[integrator]\nh = 0.01\n";

pub(crate) const MESSAGES: &[Case] = &[
    case(
        "run: integrator.rtol = 1e-300 names the key and its range (it said Convergence::Rate ... inf)",
        &[("s.toml", CLOTH)],
        &[
            "run", "{}/s.toml", "--out", "{}/out", "--set", "integrator.method=bdf", "--set",
            "integrator.rtol=1e-300",
        ],
        2,
        "--set integrator.rtol=1e-300: must lie in [1e-14, 1), got 1e-300",
    )
    .absent(&["out"]),
    case(
        "run: integrator.rtol = 2 is refused by the scene with the range scene-keys documents",
        &[("s.toml", CLOTH)],
        &[
            "run", "{}/s.toml", "--out", "{}/out", "--set", "integrator.method=bdf2-variable",
            "--set", "integrator.rtol=2",
        ],
        2,
        "--set integrator.rtol=2: must lie in [1e-14, 1)",
    ),
    case(
        "run: integrator.atol = 1e-30 (its first step was 1e-27 s)",
        &[("s.toml", CLOTH)],
        &[
            "run", "{}/s.toml", "--out", "{}/out", "--set", "integrator.method=bdf", "--set",
            "integrator.atol=1e-30",
        ],
        2,
        "--set integrator.atol=1e-30: must lie in [1e-15, inf)",
    ),
    case(
        "run: a cloth of 1e-200 kg (it stayed frozen, exit 0)",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "cloth.mass=1e-200"],
        2,
        "--set cloth.mass=1e-200: must lie in [1e-100, 1e100]",
    )
    .absent(&["out"]),
    case(
        "run: a rope of 1e200 kg in the scene file names file:line:col",
        &[("s.toml", "duration = 0.02\n[rope]\nmass = 1e200\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "s.toml:3:8: must lie in [1e-100, 1e100], got 1e200",
    ),
    case(
        "run: a negative step says the range and \"auto\"",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "integrator.h=-1"],
        2,
        "--set integrator.h=-1: must lie in (0, inf) or be \"auto\", got -1",
    ),
    case(
        "run: integrator.max_steps = 0",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "integrator.max_steps=0"],
        2,
        "--set integrator.max_steps=0: must lie in 1 to 1000000000",
    ),
    case(
        "run: bdf2-variable with h_max = 1e-12 cannot finish in its step cap (it ran without bound)",
        &[("s.toml", CLOTH)],
        &[
            "run", "{}/s.toml", "--out", "{}/out", "--set", "integrator.method=bdf2-variable",
            "--set", "integrator.h_max=1e-12",
        ],
        2,
        "duration = 0.05 s at integrator.h_max = 1e-12 s takes at least 5e10 steps of bdf2-variable, more than integrator.max_steps = 100000",
    )
    .absent(&["out"]),
    case(
        "run: bdf for 1e8 s is refused before it starts (it failed after 100000 steps)",
        &[("s.toml", CLOTH)],
        &[
            "run", "{}/s.toml", "--out", "{}/out", "--set", "integrator.method=bdf", "--set",
            "duration=1e8",
        ],
        2,
        "integrator.max_steps = 100000",
    )
    .absent(&["out"]),
    case(
        "run: the step cap counts in --max-work (a bound for every run)",
        &[("s.toml", CLOTH)],
        &[
            "run", "{}/s.toml", "--out", "{}/out", "--set", "integrator.method=bdf", "--set",
            "integrator.max_steps=1000000000",
        ],
        2,
        "integrator.max_steps = 1000000000 (the most steps of bdf, for duration = 0.05 s) is about 1e9 steps of 100 particles",
    ),
    case(
        "run: a bdf run that reaches its step cap fails naming integrator.max_steps, times short",
        &[("s.toml", CLOTH)],
        &[
            "run", "{}/s.toml", "--out", "{}/out", "--set", "integrator.method=bdf", "--set",
            "integrator.max_steps=3", "--set", "integrator.rtol=1e-8",
        ],
        1,
        "raise integrator.max_steps = 3",
    ),
    case(
        "run: a tutorial scene of 1e10 steps (it ran without bound)",
        &[("s.toml", TUTORIAL)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "duration=1e8"],
        2,
        "is about 1e10 steps of 100 particles",
    )
    .absent(&["out"]),
    case(
        "run: a [filter] table in a tutorial scene (it was ignored)",
        &[("s.toml", "duration = 1\n[tutorial]\nexample = 1\n[filter]\nlambda = 2\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "s.toml: [filter]: a [tutorial] scene is a scalar ODE",
    )
    .absent(&["out"]),
    case(
        "export-system: a bdf scene exports (its work estimate was NaN)",
        &[("s.toml", CLOTH)],
        &[
            "export-system", "{}/s.toml", "--out", "{}/out", "--set", "integrator.method=bdf",
        ],
        0,
        "\"rows\":108",
    )
    .creates(&["out/A.mtx", "out/b.mtx"]),
    case(
        "export-system: a bdf scene simulated to --at 0.02 exports",
        &[("s.toml", CLOTH)],
        &[
            "export-system", "{}/s.toml", "--out", "{}/out", "--at", "0.02", "--set",
            "integrator.method=bdf",
        ],
        0,
        "\"rows\":108",
    ),
    case(
        "export-system: bdf2-variable with h_max = 1e-12 to --at 1 is refused naming the step cap",
        &[("s.toml", CLOTH)],
        &[
            "export-system", "{}/s.toml", "--out", "{}/out", "--at", "1", "--set",
            "integrator.method=bdf2-variable", "--set", "integrator.h_max=1e-12",
        ],
        2,
        "--at = 1 s at integrator.h_max = 1e-12 s takes at least 1e12 steps",
    ),
    case(
        "export-system: bdf to --at 1e9 is refused by its step cap",
        &[("s.toml", CLOTH)],
        &[
            "export-system", "{}/s.toml", "--out", "{}/out", "--at", "1e9", "--set",
            "integrator.method=bdf",
        ],
        2,
        "more than integrator.max_steps = 100000",
    ),
    case(
        "solve: a near-nullspace of 4 vectors on nodes of 1 unknown (it exited 1 with a JSON error)",
        &[("a.mtx", TRIDIAGONAL), ("n.mtx", FOUR_COLUMNS)],
        &["solve", "{}/a.mtx", "--precond", "amg", "--nullspace", "{}/n.mtx"],
        2,
        "n.mtx: 4 vectors on nodes of 1 unknown (read off the first vector's zeros); expected a 12 x k array",
    ),
    case(
        "solve: a near-nullspace of wrong shape with another preconditioner (it was ignored)",
        &[("a.mtx", TRIDIAGONAL), ("n.mtx", FOUR_COLUMNS)],
        &["solve", "{}/a.mtx", "--precond", "jacobi", "--nullspace", "{}/n.mtx"],
        2,
        "--nullspace",
    ),
    case(
        "solve: a near-nullspace vector of zeros",
        &[("a.mtx", TRIDIAGONAL), ("n.mtx", ZERO_COLUMN)],
        &["solve", "{}/a.mtx", "--precond", "amg", "--nullspace", "{}/n.mtx"],
        2,
        "n.mtx: column 1 is zero",
    ),
    case(
        "solve: a near-nullspace file of no columns (it was ignored)",
        &[
            ("a.mtx", TRIDIAGONAL),
            ("n.mtx", "%%MatrixMarket matrix array real general\n12 0\n"),
        ],
        &["solve", "{}/a.mtx", "--precond", "amg", "--nullspace", "{}/n.mtx"],
        2,
        "n.mtx: no vectors (0 columns)",
    ),
    case(
        "solve: a near-nullspace of the wrong length names the file",
        &[("a.mtx", SPD), ("n.mtx", CONSTANT)],
        &["solve", "{}/a.mtx", "--precond", "amg", "--nullspace", "{}/n.mtx"],
        2,
        "--nullspace",
    ),
    case(
        "solve: the constant as the near-nullspace of a scalar matrix",
        &[("a.mtx", TRIDIAGONAL), ("n.mtx", CONSTANT)],
        &["solve", "{}/a.mtx", "--precond", "amg", "--nullspace", "{}/n.mtx"],
        0,
        "\"converged\":true",
    ),
];
