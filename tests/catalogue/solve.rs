//! Cases of the catalogue: `hookean solve`.

use crate::{Case, RHS3, SPD, case};

/// A general 2 x 2 matrix whose (1, 2) entry has no (2, 1) partner.
const NONSYMMETRIC: &str =
    "%%MatrixMarket matrix coordinate real general\n2 2 3\n1 1 2.0\n1 2 1.0\n2 2 2.0\n";

pub(crate) const SOLVE: &[Case] = &[
    case(
        "solve: a missing matrix file",
        &[],
        &["solve", "{}/none.mtx"],
        2,
        "none.mtx",
    ),
    case(
        "solve: an empty file",
        &[("a.mtx", "")],
        &["solve", "{}/a.mtx"],
        2,
        "a.mtx",
    ),
    case(
        "solve: no Matrix Market banner",
        &[("a.mtx", "3 3 1\n1 1 1\n")],
        &["solve", "{}/a.mtx"],
        2,
        "a.mtx:1:",
    ),
    case(
        "solve: a size line of 10^12 rows",
        &[(
            "a.mtx",
            "%%MatrixMarket matrix coordinate real general\n1000000000000 1000000000000 1\n1 1 1\n",
        )],
        &["solve", "{}/a.mtx"],
        2,
        "a.mtx:2:",
    ),
    case(
        "solve: 10^19 entries declared",
        &[(
            "a.mtx",
            "%%MatrixMarket matrix coordinate real general\n3 3 10000000000000000000\n1 1 1\n",
        )],
        &["solve", "{}/a.mtx"],
        2,
        "a.mtx:2:",
    ),
    case(
        "solve: a dense 2^32 x 2^32 array",
        &[(
            "a.mtx",
            "%%MatrixMarket matrix array real general\n4294967296 4294967296\n1\n",
        )],
        &["solve", "{}/a.mtx"],
        2,
        "a.mtx:2:",
    ),
    case(
        "solve: fewer entries than declared",
        &[(
            "a.mtx",
            "%%MatrixMarket matrix coordinate real symmetric\n3 3 5\n1 1 4\n2 1 1\n",
        )],
        &["solve", "{}/a.mtx"],
        2,
        "a.mtx",
    ),
    case(
        "solve: an index outside the matrix",
        &[(
            "a.mtx",
            "%%MatrixMarket matrix coordinate real symmetric\n3 3 1\n4 1 1\n",
        )],
        &["solve", "{}/a.mtx"],
        2,
        "a.mtx:3:",
    ),
    case(
        "solve: a value that is not a number",
        &[(
            "a.mtx",
            "%%MatrixMarket matrix coordinate real symmetric\n3 3 1\n1 1 x\n",
        )],
        &["solve", "{}/a.mtx"],
        2,
        "a.mtx:3:",
    ),
    case(
        "solve: a symmetric file listing an entry above the diagonal",
        &[(
            "a.mtx",
            "%%MatrixMarket matrix coordinate real symmetric\n2 2 3\n1 1 2\n1 2 1\n2 2 2\n",
        )],
        &["solve", "{}/a.mtx"],
        2,
        "a.mtx:4:",
    ),
    case(
        "solve: a nonsymmetric general matrix given to the direct solver",
        &[("a.mtx", NONSYMMETRIC)],
        &[
            "solve",
            "{}/a.mtx",
            "--precond",
            "direct",
            "--format",
            "csr",
            "--block-size",
            "1",
        ],
        1,
        "not symmetric",
    ),
    case(
        "solve: a nonsymmetric general matrix given to PCG",
        &[("a.mtx", NONSYMMETRIC)],
        &[
            "solve",
            "{}/a.mtx",
            "--precond",
            "ssor",
            "--format",
            "csr",
            "--block-size",
            "1",
        ],
        1,
        "not symmetric",
    ),
    case(
        "solve: an indefinite matrix with PCG",
        &[
            (
                "a.mtx",
                "%%MatrixMarket matrix coordinate real symmetric\n3 3 3\n1 1 1\n2 2 -1\n3 3 1\n",
            ),
            ("b.mtx", RHS3),
        ],
        &[
            "solve",
            "{}/a.mtx",
            "--rhs",
            "{}/b.mtx",
            "--precond",
            "none",
        ],
        1,
        "positive definite",
    ),
    case(
        "solve: --rtol 0 cannot converge",
        &[("a.mtx", SPD), ("b.mtx", RHS3)],
        &[
            "solve",
            "{}/a.mtx",
            "--rhs",
            "{}/b.mtx",
            "--precond",
            "jacobi",
            "--rtol",
            "0",
        ],
        1,
        "\"converged\":false",
    ),
    case(
        "solve: --max-iter 0 does not converge",
        &[("a.mtx", SPD), ("b.mtx", RHS3)],
        &[
            "solve",
            "{}/a.mtx",
            "--rhs",
            "{}/b.mtx",
            "--precond",
            "jacobi",
            "--max-iter",
            "0",
        ],
        1,
        "\"converged\":false",
    ),
    case(
        "solve: a negative --rtol",
        &[("a.mtx", SPD)],
        &["solve", "{}/a.mtx", "--rtol", "-1"],
        2,
        "--rtol",
    ),
    case(
        "solve: an unknown preconditioner",
        &[("a.mtx", SPD)],
        &["solve", "{}/a.mtx", "--precond", "magic"],
        2,
        "magic",
    ),
    case(
        "solve: an SSOR omega outside (0, 2)",
        &[("a.mtx", SPD)],
        &["solve", "{}/a.mtx", "--precond", "ssor", "--omega", "3"],
        2,
        "--omega",
    ),
    case(
        "solve: a right-hand side of the wrong length",
        &[
            ("a.mtx", SPD),
            (
                "b.mtx",
                "%%MatrixMarket matrix array real general\n2 1\n1\n2\n",
            ),
        ],
        &["solve", "{}/a.mtx", "--rhs", "{}/b.mtx"],
        2,
        "b.mtx",
    ),
    case(
        "solve: a block size of 4",
        &[("a.mtx", SPD)],
        &["solve", "{}/a.mtx", "--block-size", "4"],
        2,
        "--block-size",
    ),
    case(
        "solve: a valid system",
        &[("a.mtx", SPD), ("b.mtx", RHS3)],
        &[
            "solve",
            "{}/a.mtx",
            "--rhs",
            "{}/b.mtx",
            "--precond",
            "ic0",
            "--format",
            "csr",
            "--block-size",
            "1",
        ],
        0,
        "\"converged\":true",
    ),
];
