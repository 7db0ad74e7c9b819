//! Cases of the catalogue: bounds, readers and exit codes (issue 28). Every
//! flag and environment variable at and past the ends of its documented
//! range, readers on endless or absurd input, systems of no unknowns or of
//! tiny numbers, and the exit code of a valid run that fails. The scene
//! keys' ranges are checked at their ends by `crates/hookean/tests/ranges.rs`;
//! the cases here run a few of them through the command.

use crate::{CLOTH, Case, SPD, case};

/// [`CLOTH`] with the multigrid, for `[solver.amg]` keys.
const CLOTH_AMG: &str = "duration = 0.02\n[cloth]\nn = 6\n[solver]\npreconditioner = \"amg\"\n[output]\nframe_rate = 0.0\nwidth = 8\nheight = 8\n";

/// [`SPD`] times 1e-308: its inner products underflow.
const TINY: &str = "%%MatrixMarket matrix coordinate real symmetric\n3 3 5\n1 1 4e-308\n2 1 1e-308\n2 2 3e-308\n3 2 -1e-308\n3 3 2e-308\n";

pub(crate) const BOUNDS: &[Case] = &[
    case(
        "run: solver.max_newton = 1e9 (it reserved 8 GB)",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "solver.max_newton=1000000000"],
        2,
        "--set solver.max_newton=1000000000: must lie in 1 to 1000",
    )
    .absent(&["out"]),
    case(
        "run: solver.max_newton at its upper end runs",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "solver.max_newton=1000"],
        0,
        "",
    )
    .creates(&["out/summary.json"]),
    case(
        "run: solver.max_cg past its range",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "solver.max_cg=100001"],
        2,
        "must lie in 1 to 100000",
    ),
    case(
        "run: [solver.amg] sweeps = 10^9 (never answered)",
        &[("s.toml", CLOTH_AMG)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "solver.amg.sweeps=1000000000"],
        2,
        "solver.amg.sweeps=1000000000: must lie in 1 to 100",
    ),
    case(
        "run: [solver.amg] sweeps at its upper end runs",
        &[("s.toml", CLOTH_AMG)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "solver.amg.sweeps=100"],
        0,
        "",
    ),
    case(
        "run: a dense coarse level of 10^6 unknowns",
        &[("s.toml", CLOTH_AMG)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "solver.amg.coarse_size=1000000"],
        2,
        "must lie in 1 to 4096",
    ),
    case(
        "run: 65 multigrid levels",
        &[("s.toml", CLOTH_AMG)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "solver.amg.max_levels=65"],
        2,
        "must lie in 1 to 64",
    ),
    case(
        "run: 10^9 power steps of the multigrid",
        &[("s.toml", CLOTH_AMG)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "solver.amg.power_iterations=1000000000"],
        2,
        "must lie in 0 to 100",
    ),
    case(
        "run: an origin of four numbers (it was truncated)",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "cloth.origin=[0, 0, 0, 7]"],
        2,
        "must be an array of 3 numbers, got 4",
    ),
    case(
        "run: a gravity of two numbers in the file",
        &[("s.toml", "[cloth]\nn = 4\n[model]\ngravity = [0, -9.81]\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "s.toml:4:",
    ),
    case(
        "run: a jelly of four axes",
        &[("s.toml", "[jelly]\nn = [2, 2, 2, 2]\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "array of 3 numbers",
    ),
    case(
        "run: 10^9 frames per second for 1000 s",
        &[("s.toml", CLOTH)],
        &[
            "run", "{}/s.toml", "--out", "{}/out", "--set", "duration=1000", "--set",
            "output.frame_rate=1e9", "--set", "integrator.h=0.001",
        ],
        2,
        "output.frame_rate",
    ),
    case(
        "run: a variable-step method's work is counted at its step cap, not its first step",
        &[("s.toml", CLOTH)],
        &[
            "run", "{}/s.toml", "--out", "{}/out", "--max-work", "1e5", "--set",
            "integrator.method=bdf2-variable", "--set", "integrator.h=1e-7", "--set",
            "integrator.max_steps=1000",
        ],
        0,
        "",
    ),
    case(
        "run: --max-memory of 1e300 GiB",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--max-memory", "1e300"],
        2,
        "machine's memory",
    ),
    case(
        "run: --max-work of 1e300",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--max-work", "1e300"],
        2,
        "--max-work must lie in",
    ),
    case(
        "run: RAYON_NUM_THREADS=10^8",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "RAYON_NUM_THREADS=100000000",
    )
    .env(&[("RAYON_NUM_THREADS", "100000000")])
    .absent(&["out"]),
    case(
        "run: RAYON_NUM_THREADS that is not a number",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "RAYON_NUM_THREADS=many",
    )
    .env(&[("RAYON_NUM_THREADS", "many")]),
    case(
        "run: RAYON_NUM_THREADS=0 means all cores",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out"],
        0,
        "",
    )
    .env(&[("RAYON_NUM_THREADS", "0")]),
    case(
        "run: --threads makes RAYON_NUM_THREADS irrelevant",
        &[("s.toml", CLOTH)],
        &["--threads", "1", "run", "{}/s.toml", "--out", "{}/out"],
        0,
        "",
    )
    .env(&[("RAYON_NUM_THREADS", "-3")]),
    case(
        "run: a scene file without line breaks, larger than a scene may be",
        &[],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "larger than 16777216 bytes",
    )
    .before(&[&[
        "!",
        "sh",
        "-c",
        "head -c 16777217 /dev/zero | tr '\\000' x > {}/s.toml",
    ]]),
    case(
        "run: the scene is /dev/zero (a device is not read)",
        &[],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "s.toml: it is a character device, not a regular file",
    )
    .links(&[("s.toml", "/dev/zero")]),
    case(
        "run: a scene that is not text",
        &[("s.toml", "[cloth]\nn = 4\n\u{0}\u{1}")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "s.toml:3:",
    ),
    case(
        "solve: /dev/zero (it aborted at 4 GiB; a device is not read)",
        &[],
        &["solve", "/dev/zero"],
        2,
        "/dev/zero: it is a character device, not a regular file",
    ),
    case(
        "solve: a comment line of 2 MiB",
        &[],
        &["solve", "{}/a.mtx"],
        2,
        "a.mtx:2: line 2 is longer than",
    )
    .before(&[&[
        "!",
        "sh",
        "-c",
        "{ echo '%%MatrixMarket matrix coordinate real general'; printf '%%'; head -c 2097152 /dev/zero | tr '\\000' x; printf '\\n1 1 1\\n1 1 1\\n'; } > {}/a.mtx",
    ]]),
    case(
        "solve: a 0 x 0 matrix",
        &[("a.mtx", "%%MatrixMarket matrix coordinate real general\n0 0 0\n")],
        &["solve", "{}/a.mtx"],
        2,
        "empty",
    ),
    case(
        "solve: entries of 1e-308 solve (not 'converged' at x = 0)",
        &[("a.mtx", TINY)],
        &["solve", "{}/a.mtx", "--precond", "jacobi,ic0,amg,direct"],
        0,
        "\"iterations\":3",
    ),
    case(
        "solve: --repeat past its range (never answered)",
        &[("a.mtx", SPD)],
        &["solve", "{}/a.mtx", "--repeat", "1000000000"],
        2,
        "--repeat must lie in 1 to 1000",
    ),
    case(
        "solve: --repeat at its upper end",
        &[("a.mtx", SPD)],
        &["solve", "{}/a.mtx", "--precond", "jacobi", "--repeat", "1000"],
        0,
        "\"converged\":true",
    ),
    case(
        "solve: --max-iter past its range",
        &[("a.mtx", SPD)],
        &["solve", "{}/a.mtx", "--max-iter", "10000001"],
        2,
        "--max-iter must lie in 0 to",
    ),
    case(
        "solve: --rtol of 1",
        &[("a.mtx", SPD)],
        &["solve", "{}/a.mtx", "--rtol", "1"],
        2,
        "--rtol must lie in [0, 1)",
    ),
    case(
        "stability: a window of +-1e308 (its width overflowed)",
        &[],
        &["stability", "--plot", "{}/r.svg", "--re=-1e308,1e308"],
        2,
        "--re expects",
    )
    .absent(&["r.svg"]),
    case(
        "stability: the widest window draws",
        &[],
        &[
            "stability",
            "--methods",
            "rk4",
            "--resolution",
            "21",
            "--plot",
            "{}/r.svg",
            "--re=-1e6,1e6",
            "--im=-1e6,1e6",
        ],
        0,
        "",
    )
    .creates(&["r.svg"]),
    case(
        "bench-precond: a solve that misses its tolerance is a failed run",
        &[],
        &[
            "bench-precond",
            "--n",
            "4",
            "--k",
            "1e4",
            "--precond",
            "jacobi",
            "--max-iter",
            "1",
        ],
        1,
        "\"converged\":false",
    ),
    case(
        "bench-precond: an in-range --amg-jacobi-weight whose smoother diverges says so",
        &[],
        &[
            "bench-precond",
            "--n",
            "16",
            "--precond",
            "amg",
            "--amg-jacobi-weight",
            "1.9",
        ],
        1,
        "the multigrid's smoother diverges: with --amg-jacobi-weight 1.9",
    ),
    case(
        "bench-precond: --repeat 0",
        &[],
        &["bench-precond", "--n", "4", "--repeat", "0"],
        2,
        "--repeat",
    ),
    case(
        "view: a summary.json claiming 10^18 frames",
        &[(
            "d/summary.json",
            "{\"frames\": 1000000000000000000, \"simulated_s\": 1.0}",
        )],
        &["view", "{}/d"],
        2,
        "more than a run writes",
    ),
    case(
        "view: a summary.json without end (/dev/zero; a device is not read)",
        &[],
        &["view", "{}/d"],
        2,
        "summary.json: it is a character device",
    )
    .before(&[&["!", "mkdir", "{}/d"]])
    .links(&[("d/summary.json", "/dev/zero")]),
    case(
        "workprecision: a variable-step sweep is counted (tolerances down to 1e-16)",
        &[],
        &[
            "workprecision",
            "--problem",
            "tutorial3",
            "--methods",
            "bdf2-variable",
            "--levels",
            "16",
            "--max-work",
            "1e6",
            "--out",
            "{}/wp.csv",
        ],
        2,
        "--max-work",
    )
    .absent(&["wp.csv"]),
    case(
        "bench-precond: the documented largest cloth with the direct solver (it aborted)",
        &[],
        &["bench-precond", "--n", "1024", "--k", "1e4", "--precond", "direct"],
        2,
        "--n 1024: the system would need about",
    ),
    case(
        "bench-precond: --max-memory above the machine's memory",
        &[],
        &["bench-precond", "--n", "4", "--max-memory", "1e300"],
        2,
        "machine's memory",
    ),
    case(
        "solve: a matrix larger than --max-memory",
        &[("a.mtx", SPD)],
        &["solve", "{}/a.mtx", "--max-memory", "1e-9"],
        2,
        "a.mtx:1: the input is larger than",
    ),
    case(
        "bench: --repeat 0",
        &[("a.mtx", SPD)],
        &["bench", "{}/a.mtx", "--repeat", "0", "--out", "{}/out"],
        2,
        "--repeat must lie in 1 to 1000",
    )
    .absent(&["out"]),
    case(
        "bench: --cloth 1 and 513, outside 2 to 512",
        &[],
        &["bench", "--cloth", "1,513", "--out", "{}/out"],
        2,
        "--cloth: size 1 must lie in 2 to 512",
    )
    .absent(&["out"]),
    case(
        "bench: --block-size 4",
        &[("a.mtx", SPD)],
        &["bench", "{}/a.mtx", "--block-size", "4", "--out", "{}/out"],
        2,
        "--block-size must be 1, 2 or 3",
    ),
    case(
        "bench: an input that does not exist",
        &[],
        &["bench", "{}/none.mtx", "--out", "{}/out"],
        2,
        "none.mtx: no such file or folder",
    )
    .absent(&["out"]),
    case(
        "bench: a malformed file and a solver missing its tolerance are rows, not a failed run",
        &[("m/a.mtx", SPD), ("m/bad.mtx", "%%MatrixMarket matrix coordinate real symmetric\n3 3 1\n9 9 1\n")],
        &["bench", "{}/m", "--precond", "jacobi", "--max-iter", "0", "--out", "{}/out", "--quiet"],
        0,
        "",
    )
    .creates(&["out/bench.md", "out/bench.csv", "out/residual-a.svg"]),
    case(
        "tune: --budget 0",
        &[("a.mtx", SPD)],
        &["tune", "{}/a.mtx", "--budget", "0", "--out", "{}/out"],
        2,
        "--budget must be a positive number of seconds, got 0",
    )
    .absent(&["out"]),
    case(
        "tune: --budget NaN",
        &[("a.mtx", SPD)],
        &["tune", "{}/a.mtx", "--budget", "NaN", "--out", "{}/out"],
        2,
        "--budget must be a positive number of seconds, got NaN",
    )
    .absent(&["out"]),
    case(
        "tune: --budget -1",
        &[("a.mtx", SPD)],
        &["tune", "{}/a.mtx", "--budget", "-1"],
        2,
        "--budget must be a positive number of seconds, got -1",
    ),
    case(
        "tune: --repeat 0",
        &[("a.mtx", SPD)],
        &["tune", "{}/a.mtx", "--repeat", "0"],
        2,
        "--repeat must lie in 1 to 100",
    ),
    case(
        "tune: a matrix that does not exist",
        &[],
        &["tune", "{}/none.mtx", "--out", "{}/out"],
        2,
        "none.mtx",
    )
    .absent(&["out"]),
];
