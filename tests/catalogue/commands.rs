//! Cases of the catalogue: the other subcommands and the global flags.

use crate::{CLOTH, Case, case};

pub(crate) const EXPORT: &[Case] = &[
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
    case(
        "export-system: --at and --every together",
        &[("s.toml", CLOTH)],
        &[
            "export-system",
            "{}/s.toml",
            "--at",
            "0.02",
            "--every",
            "1",
            "--out",
            "{}/sys",
        ],
        2,
        "--every",
    )
    .absent(&["sys"]),
    case(
        "bench: a sequence whose numbering has a gap (issue 42)",
        &[
            ("seq/system-00001-A.mtx", ONE_BLOCK),
            ("seq/system-00001-b.mtx", THREE),
            ("seq/system-00003-A.mtx", ONE_BLOCK),
            ("seq/system-00003-b.mtx", THREE),
        ],
        &["bench", "--sequence", "{}/seq", "--out", "{}/bench"],
        2,
        "system-00002-A.mtx",
    )
    .absent(&["bench"]),
    case(
        "bench: a sequence of mixed sizes (issue 42)",
        &[
            ("seq/system-00001-A.mtx", ONE_BLOCK),
            ("seq/system-00001-b.mtx", THREE),
            ("seq/system-00002-A.mtx", TWO_BLOCKS),
            ("seq/system-00002-b.mtx", SIX),
        ],
        &["bench", "--sequence", "{}/seq", "--out", "{}/bench"],
        2,
        "system-00002-A.mtx",
    )
    .absent(&["bench"]),
];

/// A 3 x 3 system (one particle) and its right-hand side, for sequences.
const ONE_BLOCK: &str =
    "%%MatrixMarket matrix coordinate real symmetric\n3 3 3\n1 1 2\n2 2 2\n3 3 2\n";
const THREE: &str = "%%MatrixMarket matrix array real general\n3 1\n1\n2\n3\n";
/// Two particles.
const TWO_BLOCKS: &str = "%%MatrixMarket matrix coordinate real symmetric\n6 6 6\n1 1 2\n2 2 2\n3 3 2\n4 4 2\n5 5 2\n6 6 2\n";
const SIX: &str = "%%MatrixMarket matrix array real general\n6 1\n1\n2\n3\n4\n5\n6\n";

pub(crate) const WORKPRECISION: &[Case] = &[
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

pub(crate) const STABILITY: &[Case] = &[
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

pub(crate) const FILTER_ANALYSIS: &[Case] = &[
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

pub(crate) const BENCH_PRECOND: &[Case] = &[
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

pub(crate) const GLOBAL: &[Case] = &[
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

pub(crate) const REPRODUCE: &[Case] = &[
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

pub(crate) const VIEW: &[Case] = &[
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
    case(
        "export-cache: a frame of the run is missing",
        &[(
            "s.toml",
            "duration = 0.05\n[cloth]\nn = 4\n[output]\nframe_rate = 40.0\nwidth = 8\nheight = 8\n",
        )],
        &["export-cache", "{}/out", "--format", "pc2"],
        2,
        "frame-0001.obj",
    )
    .before(&[
        &["run", "{}/s.toml", "--out", "{}/out", "--quiet"],
        &["!", "rm", "{}/out/frame-0001.obj"],
    ])
    .absent(&["out/cache.pc2", "out/cache-rest.obj"]),
    case(
        "export-cache: an unknown format",
        &[],
        &["export-cache", "{}", "--format", "abc"],
        2,
        "pc2",
    ),
    case(
        "run: output.cache without OBJ frames",
        &[(
            "s.toml",
            "[cloth]\nn = 4\n[output]\nframe_rate = 0.0\ncache = \"pc2\"\n",
        )],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "output.cache",
    )
    .absent(&["out"]),
    case(
        "run: a pin group's vertex past the mesh",
        &[("s.toml", "[cloth]\nn = 4\n[[pin]]\nvertices = [16]\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "[pin 1]: vertices: vertex 16 does not exist (16 vertices",
    )
    .absent(&["out"]),
    case(
        "run: a pin group's weight outside [0, 1]",
        &[("s.toml", "[cloth]\nn = 4\n[[pin]]\nvertices = [0]\nweight = 1.5\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "s.toml:5:10: pin.weight: must lie in [0, 1], got 1.5",
    )
    .absent(&["out"]),
    case(
        "run: a pin group's negative stiffness",
        &[("s.toml", "[cloth]\nn = 4\n[[pin]]\nvertices = [0]\nweight = 0.5\nstiffness = -2\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "pin.stiffness: must lie in [0, inf), got -2",
    )
    .absent(&["out"]),
    case(
        "run: a NaN in a pin group's path",
        &[("s.toml", "[cloth]\nn = 4\n[[pin]]\nvertices = [0]\nkeys = [{ t = 0 }, { t = 1, translation = [nan, 0, 0] }]\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "s.toml:5:43: keys.translation: components must be finite numbers",
    )
    .absent(&["out"]),
    case(
        "run: a pin group's key times that do not increase",
        &[("s.toml", "[cloth]\nn = 4\n[[pin]]\nvertices = [0]\nkeys = [{ t = 1 }, { t = 1 }]\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "[pin 1]: keys: key 2: t = 1 does not come after",
    )
    .absent(&["out"]),
];
