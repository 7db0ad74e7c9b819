//! The catalogue of bad inputs and faults (docs/RELIABILITY.md): every
//! subcommand of `hookean`, run as a user would, on inputs an adversary
//! would give. Each case states its exit code (2: bad input, 1: a failed
//! run, 0: success) and a fragment of its message, runs under a memory cap
//! (`ulimit -v`) and a time limit, and checks that no input file changed
//! and that the outputs are what was promised: nothing on failure, the
//! named files on success.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Address space of one case (KiB): far below what the absurd sizes of the
/// catalogue would allocate, far above what a valid small case needs.
const MEMORY_CAP_KIB: u64 = 4 << 20;
/// Wall-clock limit of one case.
const TIME_LIMIT: Duration = Duration::from_secs(120);

/// A symmetric positive definite 3 x 3 matrix (lower triangle).
const SPD: &str =
    "%%MatrixMarket matrix coordinate real symmetric\n3 3 5\n1 1 4\n2 1 1\n2 2 3\n3 2 -1\n3 3 2\n";
/// A right-hand side for [`SPD`].
const RHS3: &str = "%%MatrixMarket matrix array real general\n3 1\n1\n2\n3\n";

/// A small, quick cloth scene.
const CLOTH: &str =
    "duration = 0.05\n[cloth]\nn = 6\n[output]\nframe_rate = 0.0\nwidth = 8\nheight = 8\n";

/// One case of the catalogue.
struct Case {
    /// What is wrong (or right) with the input.
    name: &'static str,
    /// Input files written into the case's folder before the run.
    files: &'static [(&'static str, &'static str)],
    /// Arguments; `{}` in an argument is replaced by the case's folder and
    /// `@name` by a shipped file of the repository.
    args: &'static [&'static str],
    /// Expected exit code.
    exit: i32,
    /// A fragment of stderr (exit 1, 2) or stdout (exit 0).
    says: &'static str,
    /// Paths (relative to the case's folder) that must exist afterwards.
    creates: &'static [&'static str],
    /// Paths that must not exist afterwards.
    absent: &'static [&'static str],
}

const fn case(
    name: &'static str,
    files: &'static [(&'static str, &'static str)],
    args: &'static [&'static str],
    exit: i32,
    says: &'static str,
) -> Case {
    Case {
        name,
        files,
        args,
        exit,
        says,
        creates: &[],
        absent: &[],
    }
}

impl Case {
    const fn creates(mut self, paths: &'static [&'static str]) -> Self {
        self.creates = paths;
        self
    }
    const fn absent(mut self, paths: &'static [&'static str]) -> Self {
        self.absent = paths;
        self
    }
}

const SOLVE: &[Case] = &[
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
        &[(
            "a.mtx",
            "%%MatrixMarket matrix coordinate real general\n2 2 3\n1 1 2.0\n1 2 1.0\n2 2 2.0\n",
        )],
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

const RUN: &[Case] = &[
    case("run: a missing scene file", &[], &["run", "{}/none.toml", "--out", "{}/out"], 2, "none.toml")
        .absent(&["out"]),
    case(
        "run: a TOML syntax error",
        &[("s.toml", "duration = \n[cloth]\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "s.toml:1:",
    )
    .absent(&["out"]),
    case(
        "run: an unknown key",
        &[("s.toml", "[cloth]\nn = 4\nstifness = 1\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "s.toml:3:1: unknown field `stifness`",
    )
    .absent(&["out"]),
    case(
        "run: two model tables",
        &[("s.toml", "[cloth]\n[rope]\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "exactly one model",
    )
    .absent(&["out"]),
    case(
        "run: --set without '='",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "cloth.n"],
        2,
        "--set cloth.n: not key=value",
    )
    .absent(&["out"]),
    case(
        "run: --set of an unknown key names the override",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "cloth.k=1"],
        2,
        "--set cloth.k=1: unknown field `k`",
    )
    .absent(&["out"]),
    case(
        "run: an unknown integration method",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "integrator.method=rk9"],
        2,
        "rk9",
    )
    .absent(&["out"]),
    case(
        "run: a negative duration",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "duration=-1"],
        2,
        "must be a positive number, got -1",
    )
    .absent(&["out"]),
    case(
        "run: a huge number prints short",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "cloth.mass=-1e300"],
        2,
        "got -1e300",
    )
    .absent(&["out"]),
    case(
        "run: a cloth of 10^10 particles",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "cloth.n=100000"],
        2,
        "cloth.n",
    )
    .absent(&["out"]),
    case(
        "run: a cloth of 2^64 particles",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "cloth.n=4294967296"],
        2,
        "cloth.n",
    )
    .absent(&["out"]),
    case(
        "run: a jelly of 1000^3 particles",
        &[("s.toml", "[jelly]\nn = [1000, 1000, 1000]\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "jelly.n",
    )
    .absent(&["out"]),
    case(
        "run: a jelly of no particles",
        &[("s.toml", "[jelly]\nn = [0, 0, 0]\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "s.toml: [jelly]:",
    )
    .absent(&["out"]),
    case(
        "run: a cloth so large its springs have infinite length",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "cloth.size=1e308"],
        2,
        "s.toml: [cloth]:",
    )
    .absent(&["out"]),
    case(
        "run: a picture 100000 pixels wide",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "output.width=100000"],
        2,
        "pixels",
    )
    .absent(&["out"]),
    case(
        "run: a picture 2^32 pixels high",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "output.height=4294967296"],
        2,
        "pixels",
    )
    .absent(&["out"]),
    case(
        "run: a duration of 1e300 s",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "duration=1e300"],
        2,
        "--max-work",
    )
    .absent(&["out"]),
    case(
        "run: a filter on an implicit method",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "filter.lambda=1"],
        2,
        "s.toml: [filter]:",
    )
    .absent(&["out"]),
    case(
        "run: a filter whose neighbourhoods would fill 137 GB",
        &[("s.toml", "[cloth]\nn = 256\n[integrator]\nmethod = \"fb-euler\"\nh = 1e-4\n[filter]\nlambda = 1\nrings = 1000000000\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "filter.rings",
    )
    .absent(&["out"]),
    case(
        "run: a sphere of negative radius",
        &[("s.toml", "duration = 0.05\n[cloth]\nn = 4\n[[collider]]\nkind = \"sphere\"\ncenter = [0, 0, -1]\nradius = -1\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "s.toml: [collider 1]: invalid parameter sphere",
    )
    .absent(&["out"]),
    case(
        "run: a mesh collider whose file is missing",
        &[("s.toml", "duration = 0.05\n[cloth]\nn = 4\n[[collider]]\nkind = \"mesh\"\npath = \"none.obj\"\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "none.obj",
    )
    .absent(&["out"]),
    case(
        "run: an empty mesh file",
        &[("s.toml", "duration = 0.05\n[cloth]\nn = 4\n[[collider]]\nkind = \"mesh\"\npath = \"empty.obj\"\n"), ("empty.obj", "")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "empty.obj: the mesh has no vertices",
    )
    .absent(&["out"]),
    case(
        "run: a non-manifold mesh (three faces on one edge)",
        &[("s.toml", "duration = 0.05\n[cloth]\nn = 4\n[[collider]]\nkind = \"mesh\"\npath = \"fin.obj\"\n"), ("fin.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "fin.obj:8: the edge between vertices 1 and 2 is shared by 3 faces",
    )
    .absent(&["out"]),
    case(
        "run: a mesh with a NaN coordinate",
        &[("s.toml", "duration = 0.05\n[cloth]\nn = 4\n[[collider]]\nkind = \"mesh\"\npath = \"nan.obj\"\n"), ("nan.obj", "v 0 0 0\nv NaN 0 0\nv 0 1 0\nf 1 2 3\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "nan.obj:2: non-finite vertex coordinate",
    )
    .absent(&["out"]),
    case(
        "run: a mesh collider of negative thickness",
        &[("s.toml", "duration = 0.05\n[cloth]\nn = 4\n[[collider]]\nkind = \"mesh\"\npath = \"tri.obj\"\nthickness = -0.01\n"), ("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "[collider 1]: invalid parameter thickness",
    )
    .absent(&["out"]),
    case(
        "run: a negative friction coefficient",
        &[("s.toml", "duration = 0.05\n[cloth]\nn = 4\n[[collider]]\nkind = \"plane\"\npoint = [0, 0, -1]\nnormal = [0, 0, 1]\nstatic_friction = -0.5\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "[collider 1]: invalid parameter static_friction",
    )
    .absent(&["out"]),
    case(
        "run: a negative kinetic friction coefficient on a mesh",
        &[("s.toml", "duration = 0.05\n[cloth]\nn = 4\n[[collider]]\nkind = \"mesh\"\npath = \"tri.obj\"\nkinetic_friction = -1\n"), ("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "[collider 1]: invalid parameter kinetic_friction",
    )
    .absent(&["out"]),
    case(
        "run: a [mesh] model whose file is missing",
        &[("s.toml", "duration = 0.05\n[mesh]\npath = \"none.obj\"\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "none.obj",
    )
    .absent(&["out"]),
    case(
        "run: a [mesh] model with a non-manifold edge",
        &[("s.toml", "duration = 0.05\n[mesh]\npath = \"fin.obj\"\n"), ("fin.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "fin.obj:8:",
    )
    .absent(&["out"]),
    case(
        "run: a [mesh] model with a NaN coordinate",
        &[("s.toml", "duration = 0.05\n[mesh]\npath = \"nan.obj\"\n"), ("nan.obj", "v 0 0 0\nv 0 nan 0\nv 0 1 0\nf 1 2 3\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "nan.obj:2:",
    )
    .absent(&["out"]),
    case(
        "run: a [mesh] pin beyond the last vertex",
        &[("s.toml", "duration = 0.05\n[mesh]\npath = \"tri.obj\"\npins = [3]\n"), ("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "[mesh]: pins: vertex 3 does not exist",
    )
    .absent(&["out"]),
    case(
        "run: a negative self-collision thickness",
        &[("s.toml", "duration = 0.05\n[cloth]\nn = 4\n[contact]\nself_collision = true\nself_thickness = -0.004\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "s.toml:6:",
    )
    .absent(&["out"]),
    case(
        "run: a negative self-collision stiffness",
        &[("s.toml", "duration = 0.05\n[cloth]\nn = 4\n[contact]\nself_collision = true\nself_stiffness = -1\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "s.toml:6:",
    )
    .absent(&["out"]),
    case(
        "run: a negative --max-memory",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--max-memory", "-1"],
        2,
        "--max-memory",
    )
    .absent(&["out"]),
    case(
        "run: an output folder that exists, without --force",
        &[("s.toml", CLOTH), ("out/notes.txt", "mine")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "exists",
    ),
    case(
        "run: --force never replaces a folder that is not a run's",
        &[("s.toml", CLOTH), ("out/notes.txt", "mine")],
        &["run", "{}/s.toml", "--out", "{}/out", "--force"],
        2,
        "out",
    ),
    case(
        "run: an explicit step far above the stability limit blows up",
        &[("s.toml", CLOTH)],
        &[
            "run", "{}/s.toml", "--out", "{}/out", "--set", "integrator.method=fb-euler",
            "--set", "integrator.h=0.004",
        ],
        1,
        "blew up",
    )
    .absent(&["out"]),
    case(
        "run: a valid cloth",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--quiet"],
        0,
        "",
    )
    .creates(&["out/summary.json", "out/steps.csv", "out/final.png", "out/view.html"]),
    case(
        "run: a cloth in units of 1e-12 kg moves (Newton iterates)",
        &[("s.toml", "duration = 0.05\n[cloth]\nn = 6\nmass = 1e-12\nstiffness = 1e-8\nbend_stiffness = 1e-9\ndamping = 1e-13\n[output]\nframe_rate = 0.0\nwidth = 8\nheight = 8\n")],
        &["run", "{}/s.toml", "--out", "{}/out", "--quiet"],
        0,
        "",
    )
    .creates(&["out/summary.json"]),
    case(
        "run: a tutorial scene for 1e300 s",
        &[("s.toml", "duration = 1e300\n[tutorial]\nexample = 1\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "--max-work",
    )
    .absent(&["out"]),
];

const EXPORT: &[Case] = &[
    case(
        "export-system: a negative --at",
        &[("s.toml", CLOTH)],
        &[
            "export-system",
            "{}/s.toml",
            "--at",
            "-1",
            "--out",
            "{}/sys",
        ],
        2,
        "--at",
    )
    .absent(&["sys"]),
    case(
        "export-system: --at 1e9",
        &[("s.toml", CLOTH)],
        &[
            "export-system",
            "{}/s.toml",
            "--at",
            "1e9",
            "--out",
            "{}/sys",
        ],
        2,
        "--max-work",
    )
    .absent(&["sys"]),
    case(
        "export-system: a cloth of 10^10 particles",
        &[("s.toml", CLOTH)],
        &[
            "export-system",
            "{}/s.toml",
            "--out",
            "{}/sys",
            "--set",
            "cloth.n=100000",
        ],
        2,
        "cloth.n",
    )
    .absent(&["sys"]),
    case(
        "export-system: an output folder that exists",
        &[("s.toml", CLOTH), ("sys/A.mtx", "mine")],
        &["export-system", "{}/s.toml", "--out", "{}/sys"],
        2,
        "exists",
    ),
    case(
        "export-system: a valid export",
        &[("s.toml", CLOTH)],
        &[
            "export-system",
            "{}/s.toml",
            "--at",
            "0.02",
            "--out",
            "{}/sys",
        ],
        0,
        "\"rows\"",
    )
    .creates(&["sys/A.mtx", "sys/b.mtx"]),
];

const WORKPRECISION: &[Case] = &[
    case(
        "workprecision: an unknown problem",
        &[],
        &[
            "workprecision",
            "--problem",
            "tutorial9",
            "--out",
            "{}/wp.csv",
        ],
        2,
        "tutorial9",
    )
    .absent(&["wp.csv"]),
    case(
        "workprecision: --levels 0",
        &[],
        &[
            "workprecision",
            "--problem",
            "tutorial1",
            "--levels",
            "0",
            "--out",
            "{}/wp.csv",
        ],
        2,
        "--levels",
    )
    .absent(&["wp.csv"]),
    case(
        "workprecision: --n0 0",
        &[],
        &[
            "workprecision",
            "--problem",
            "tutorial1",
            "--n0",
            "0",
            "--out",
            "{}/wp.csv",
        ],
        2,
        "--n0",
    )
    .absent(&["wp.csv"]),
    case(
        "workprecision: --n0 10^9 with 16 levels",
        &[],
        &[
            "workprecision",
            "--problem",
            "tutorial1",
            "--n0",
            "1000000000",
            "--levels",
            "16",
            "--out",
            "{}/wp.csv",
        ],
        2,
        "--max-work",
    )
    .absent(&["wp.csv"]),
    case(
        "workprecision: --out and --plot name one file",
        &[],
        &[
            "workprecision",
            "--problem",
            "tutorial1",
            "--out",
            "{}/wp.csv",
            "--plot",
            "{}/wp.csv",
        ],
        2,
        "same file",
    )
    .absent(&["wp.csv"]),
    case(
        "workprecision: an existing --out without --force",
        &[("wp.csv", "mine")],
        &[
            "workprecision",
            "--problem",
            "tutorial1",
            "--out",
            "{}/wp.csv",
        ],
        2,
        "--force",
    ),
    case(
        "workprecision: a second-order method on a first-order problem",
        &[],
        &[
            "workprecision",
            "--problem",
            "tutorial1",
            "--methods",
            "verlet",
            "--out",
            "{}/wp.csv",
        ],
        2,
        "second-order",
    )
    .absent(&["wp.csv"]),
    case(
        "workprecision: a valid sweep",
        &[],
        &[
            "workprecision",
            "--problem",
            "tutorial1",
            "--methods",
            "explicit-euler,rk4",
            "--levels",
            "4",
            "--out",
            "{}/wp.csv",
        ],
        0,
        "| rk4 |",
    )
    .creates(&["wp.csv"]),
];

const STABILITY: &[Case] = &[
    case(
        "stability: an unknown method",
        &[],
        &["stability", "--methods", "rk9", "--plot", "{}/r.svg"],
        2,
        "rk9",
    )
    .absent(&["r.svg"]),
    case(
        "stability: --resolution 1",
        &[],
        &["stability", "--plot", "{}/r.svg", "--resolution", "1"],
        2,
        "--resolution",
    )
    .absent(&["r.svg"]),
    case(
        "stability: a reversed range",
        &[],
        &["stability", "--plot", "{}/r.svg", "--re", "3,-5"],
        2,
        "--re",
    )
    .absent(&["r.svg"]),
    case(
        "stability: an existing plot without --force",
        &[("r.svg", "mine")],
        &["stability", "--plot", "{}/r.svg"],
        2,
        "--force",
    ),
    case(
        "stability: valid regions",
        &[],
        &[
            "stability",
            "--methods",
            "explicit-euler,rk4",
            "--plot",
            "{}/r.svg",
        ],
        0,
        "",
    )
    .creates(&["r.svg"]),
];

const FILTER_ANALYSIS: &[Case] = &[
    case(
        "filter-analysis: a cloth of 10^10 particles",
        &[],
        &[
            "filter-analysis",
            "@scenes/drape.toml",
            "--plot",
            "{}/fa",
            "--n",
            "100000",
        ],
        2,
        "--n 100000",
    )
    .absent(&["fa"]),
    case(
        "filter-analysis: --t-end 1e9",
        &[],
        &[
            "filter-analysis",
            "@scenes/drape.toml",
            "--plot",
            "{}/fa",
            "--t-end",
            "1e9",
        ],
        2,
        "--max-work",
    )
    .absent(&["fa"]),
    case(
        "filter-analysis: a scene without a cloth",
        &[],
        &["filter-analysis", "@scenes/rope.toml", "--plot", "{}/fa"],
        2,
        "[cloth]",
    )
    .absent(&["fa"]),
    case(
        "filter-analysis: --n 2",
        &[],
        &[
            "filter-analysis",
            "@scenes/drape.toml",
            "--plot",
            "{}/fa",
            "--n",
            "2",
        ],
        2,
        "--n",
    )
    .absent(&["fa"]),
    case(
        "filter-analysis: a step fraction of 3",
        &[],
        &[
            "filter-analysis",
            "@scenes/drape.toml",
            "--plot",
            "{}/fa",
            "--step-fraction",
            "3",
        ],
        2,
        "--step-fraction",
    )
    .absent(&["fa"]),
    case(
        "filter-analysis: a negative --t-end",
        &[],
        &[
            "filter-analysis",
            "@scenes/drape.toml",
            "--plot",
            "{}/fa",
            "--t-end",
            "-1",
        ],
        2,
        "--t-end",
    )
    .absent(&["fa"]),
];

const BENCH_PRECOND: &[Case] = &[
    case(
        "bench-precond: a cloth of 1 particle per side",
        &[],
        &["bench-precond", "--n", "1"],
        2,
        "--n",
    ),
    case(
        "bench-precond: a cloth of 10^10 particles",
        &[],
        &["bench-precond", "--n", "100000"],
        2,
        "--n",
    ),
    case(
        "bench-precond: a negative stiffness",
        &[],
        &["bench-precond", "--n", "8", "--k", "-1"],
        2,
        "--k",
    ),
    case(
        "bench-precond: an unknown preconditioner",
        &[],
        &["bench-precond", "--n", "8", "--precond", "magic"],
        2,
        "magic",
    ),
    case(
        "bench-precond: a valid comparison",
        &[],
        &[
            "bench-precond",
            "--n",
            "8",
            "--k",
            "1e2",
            "--precond",
            "jacobi,mic0",
        ],
        0,
        "\"precond\"",
    ),
];

const GLOBAL: &[Case] = &[
    case(
        "--threads 0",
        &[],
        &["--threads", "0", "scene-keys"],
        2,
        "threads",
    ),
    case(
        "--threads 10^8",
        &[],
        &["--threads", "100000000", "scene-keys"],
        2,
        "1024",
    ),
    case(
        "run: a scene asking for 10^8 threads",
        &[("s.toml", "threads = 100000000\n[cloth]\nn = 4\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "at most 1024 threads",
    )
    .absent(&["out"]),
    case(
        "scene-keys lists every key",
        &[],
        &["scene-keys"],
        0,
        "solver.amg.sweeps",
    ),
    case("an unknown subcommand", &[], &["simulate"], 2, "simulate"),
];

const REPRODUCE: &[Case] = &[
    case(
        "reproduce: an unknown paper",
        &[],
        &["reproduce", "--paper", "hauth", "--out", "{}/r"],
        2,
        "hauth",
    )
    .absent(&["r"]),
    case(
        "reproduce: claim 15",
        &[],
        &["reproduce", "--claims", "15", "--out", "{}/r"],
        2,
        "1 to 14",
    )
    .absent(&["r"]),
    case(
        "reproduce: claims of the other paper only",
        &[],
        &[
            "reproduce",
            "--paper",
            "filter",
            "--claims",
            "2",
            "--out",
            "{}/r",
        ],
        2,
        "select no claim",
    )
    .absent(&["r"]),
    case(
        "reproduce: a claim that is not a number",
        &[],
        &["reproduce", "--claims", "two", "--out", "{}/r"],
        2,
        "two",
    )
    .absent(&["r"]),
    case(
        "reproduce: an existing folder of other files",
        &[("r/mine.txt", "mine")],
        &["reproduce", "--claims", "2", "--out", "{}/r", "--force"],
        2,
        "r",
    ),
    case(
        "reproduce: an existing output folder without --force",
        &[("r/claims.json", "{}")],
        &["reproduce", "--claims", "2", "--out", "{}/r"],
        2,
        "--force",
    ),
    case(
        "reproduce: one cheap claim",
        &[],
        &["reproduce", "--quick", "--claims", "2", "--out", "{}/r"],
        0,
        "| 2 | tutorial |",
    )
    .creates(&["r/claims.md", "r/claims.json"]),
    case(
        "run: integrator.h = \"auto\" with an implicit method",
        &[("s.toml", "[cloth]\nn = 4\n[integrator]\nh = \"auto\"\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "integrator.h",
    )
    .absent(&["out"]),
    case(
        "run: an unknown filter coupling",
        &[(
            "s.toml",
            "[cloth]\nn = 4\n[integrator]\nmethod = \"fb-euler\"\n[filter]\ncoupling = \"force\"\n",
        )],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "s.toml:6",
    )
    .absent(&["out"]),
];

const VIEW: &[Case] = &[
    case(
        "view: a folder without a run",
        &[("d/x.txt", "mine")],
        &["view", "{}/d"],
        2,
        "summary.json",
    ),
    case(
        "view: a missing folder",
        &[],
        &["view", "{}/none"],
        2,
        "none",
    ),
];

/// The shipped repository file `path`.
fn repo(path: &str) -> String {
    let p: PathBuf = [env!("CARGO_MANIFEST_DIR"), path].iter().collect();
    p.to_string_lossy().into_owned()
}

/// Every file under `dir` with its bytes.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let p = entry.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.insert(p.clone(), std::fs::read(&p).unwrap());
            }
        }
    }
    out
}

/// Runs one case in its own folder; returns what went wrong, if anything.
fn check(index: usize, c: &Case) -> Result<(), String> {
    let dir =
        std::env::temp_dir().join(format!("hookean-catalogue-{}-{index}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    for (name, text) in c.files {
        let p = dir.join(name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, text).unwrap();
    }
    let before = snapshot(&dir);
    let d = dir.to_string_lossy().into_owned();
    let args: Vec<String> = c
        .args
        .iter()
        .map(|a| match a.strip_prefix('@') {
            Some(path) => repo(path),
            None => a.replace("{}", &d),
        })
        .collect();
    // The memory cap: `ulimit -v` in a shell that then execs the binary.
    let mut child = Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -v {MEMORY_CAP_KIB} && exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_hookean-suite-cli"))
        .args(&args)
        .current_dir(&dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > TIME_LIMIT {
            let _ = child.kill();
            return Err(format!("still running after {TIME_LIMIT:?}"));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = child.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let mut problems = Vec::new();
    if out.status.code() != Some(c.exit) {
        problems.push(format!("exit {:?}, expected {}", out.status.code(), c.exit));
    }
    if stderr.contains("panicked") || stderr.contains("memory allocation") {
        problems.push("a panic or an abort".into());
    }
    // Success and a solver's failure report on stdout (a JSON line), bad
    // input and a failed run on stderr.
    let text = match c.exit {
        0 => stdout.to_string(),
        1 => format!("{stdout}{stderr}"),
        _ => stderr.to_string(),
    };
    if !text.contains(c.says) {
        problems.push(format!("no '{}' in the message", c.says));
    }
    if c.exit == 2
        && !(stderr.starts_with("hookean: error: ") && stderr.trim_end().lines().count() == 1)
    {
        problems.push("bad input is not one 'hookean: error:' line".into());
    }
    let after = snapshot(&dir);
    for (path, bytes) in &before {
        if after.get(path) != Some(bytes) {
            problems.push(format!("input {} changed or vanished", path.display()));
        }
    }
    for p in c.creates {
        if !dir.join(p).exists() {
            problems.push(format!("{p} was not written"));
        }
    }
    for p in c.absent {
        if dir.join(p).exists() {
            problems.push(format!("{p} was written"));
        }
    }
    // A failed command leaves nothing behind but what it names.
    if c.exit != 0 {
        for path in after.keys().filter(|p| !before.contains_key(*p)) {
            let shown = path.display().to_string();
            if !stderr.contains(&shown)
                && !stderr.contains(&path.parent().unwrap().display().to_string())
            {
                problems.push(format!("left {shown} behind without saying so"));
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    if problems.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "{}\n  stderr: {}\n  stdout: {}",
            problems.join("; "),
            stderr.trim_end(),
            stdout.chars().take(300).collect::<String>()
        ))
    }
}

#[test]
fn every_case_of_the_catalogue_exits_as_promised_and_keeps_the_user_files() {
    let all: Vec<&Case> = [
        SOLVE,
        RUN,
        EXPORT,
        WORKPRECISION,
        STABILITY,
        FILTER_ANALYSIS,
        BENCH_PRECOND,
        VIEW,
        GLOBAL,
        // Cases 84-92 (issue 18).
        REPRODUCE,
    ]
    .iter()
    .flat_map(|cases| cases.iter())
    .collect();
    assert!(all.len() >= 60, "the catalogue holds {} cases", all.len());
    let failures: Vec<String> = all
        .iter()
        .enumerate()
        .filter_map(|(i, c)| check(i, c).err().map(|e| format!("{}: {e}", c.name)))
        .collect();
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        all.len(),
        failures.join("\n")
    );
}
