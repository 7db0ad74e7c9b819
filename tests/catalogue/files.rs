//! Cases of the catalogue: output files and folders (issue 28). Each runs
//! against a tree of the user's own files and links, and the harness checks
//! that nothing in it is deleted, truncated or written through.

use crate::{CLOTH, Case, case};

/// [`CLOTH`] with frames, so that an earlier run leaves OBJ files.
const CLOTH_FRAMES: &str =
    "duration = 0.05\n[cloth]\nn = 6\n[output]\nframe_rate = 40.0\nwidth = 8\nheight = 8\n";

/// An earlier run of [`CLOTH`] into `out`.
const EARLIER_RUN: &[&str] = &["run", "{}/s.toml", "--out", "{}/out"];
/// An earlier run with frames (what `view` reads) into `out`.
const EARLIER_FRAMES: &[&str] = &["run", "{}/f.toml", "--out", "{}/out"];

/// The blow-up of the run catalogue: FB Euler far above its stable step.
const BLOW_UP: &[&str] = &[
    "run",
    "{}/s.toml",
    "--out",
    "{}/out",
    "--force",
    "--set",
    "integrator.method=fb-euler",
    "--set",
    "integrator.h=0.004",
];

pub(crate) const FILES: &[Case] = &[
    case(
        "run --force: a folder of the user's that holds a steps.csv among other work",
        &[
            ("s.toml", CLOTH),
            ("out/steps.csv", "my own table"),
            ("out/thesis.tex", "my own work"),
        ],
        &["run", "{}/s.toml", "--out", "{}/out", "--force"],
        2,
        "not hookean's output",
    ),
    case(
        "run --force: --out is the folder holding the scene",
        &[("res/s.toml", CLOTH)],
        &["run", "{}/res/s.toml", "--out", "{}/res", "--force"],
        2,
        "which this command reads",
    ),
    case(
        "run --force: --out . holds the scene",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", ".", "--force"],
        2,
        "which this command reads",
    ),
    case(
        "run --force: an earlier run with a file of the user's added",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--force"],
        2,
        "notes.txt was not written by hookean",
    )
    .before(&[
        EARLIER_RUN,
        &["!", "sh", "-c", "echo mine > {}/out/notes.txt"],
    ]),
    case(
        "run --force: an earlier run holding a link to a file of the user's",
        &[("s.toml", CLOTH), ("mine.txt", "mine")],
        &["run", "{}/s.toml", "--out", "{}/out", "--force"],
        2,
        "link",
    )
    .before(&[EARLIER_RUN])
    .links(&[("out/data", "{}/mine.txt")]),
    case(
        "run --force: an earlier run whose steps.csv is now a link",
        &[("s.toml", CLOTH), ("mine.txt", "mine")],
        &["run", "{}/s.toml", "--out", "{}/out", "--force"],
        2,
        "steps.csv is a link",
    )
    .before(&[EARLIER_RUN, &["!", "rm", "{}/out/steps.csv"]])
    .links(&[("out/steps.csv", "{}/mine.txt")]),
    case(
        "run --force: an earlier run of hookean without its marker",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--force"],
        2,
        "has no .hookean-output",
    )
    .before(&[EARLIER_RUN, &["!", "rm", "{}/out/.hookean-output"]]),
    case(
        "run --force: an earlier run is replaced whole (its frames go)",
        &[("s.toml", CLOTH), ("f.toml", CLOTH_FRAMES)],
        &["run", "{}/s.toml", "--out", "{}/out", "--force"],
        0,
        "",
    )
    .before(&[&["run", "{}/f.toml", "--out", "{}/out"]])
    .replaces(&["out"])
    .creates(&["out/summary.json", "out/.hookean-output"])
    .absent(&["out/frame-0000.obj"]),
    case(
        "run --force: --out is a link to a folder",
        &[("s.toml", CLOTH), ("d/mine.txt", "mine")],
        &["run", "{}/s.toml", "--out", "{}/out", "--force"],
        2,
        "it is a link",
    )
    .links(&[("out", "{}/d")]),
    case(
        "run --force: --out is a file",
        &[("s.toml", CLOTH), ("out", "mine")],
        &["run", "{}/s.toml", "--out", "{}/out", "--force"],
        2,
        "it is a file",
    ),
    case(
        "run: --out is the root folder",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "/", "--force"],
        2,
        "root",
    ),
    case(
        "run: --out below folders that do not exist yet",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/a/b/out"],
        0,
        "",
    )
    .creates(&["a/b/out/summary.json"]),
    case(
        "run --force: a run that fails leaves the earlier run as it was",
        &[("s.toml", CLOTH)],
        BLOW_UP,
        1,
        "is unchanged",
    )
    .before(&[EARLIER_RUN]),
    case(
        "view --force: view.html is a link to a file of the user's",
        &[("f.toml", CLOTH_FRAMES), ("secret.txt", "secret")],
        &["view", "{}/out", "--force"],
        2,
        "not written by hookean",
    )
    .before(&[EARLIER_FRAMES, &["!", "rm", "{}/out/view.html"]])
    .links(&[("out/view.html", "{}/secret.txt")]),
    case(
        "view --force: view.html is a dangling link out of the folder",
        &[("f.toml", CLOTH_FRAMES)],
        &["view", "{}/out", "--force"],
        2,
        "not written by hookean",
    )
    .before(&[EARLIER_FRAMES, &["!", "rm", "{}/out/view.html"]])
    .links(&[("out/view.html", "{}/elsewhere.html")])
    .absent(&["elsewhere.html"]),
    case(
        "view --force: a view.html of the user's in a run without a marker",
        &[("f.toml", CLOTH_FRAMES)],
        &["view", "{}/out", "--force"],
        2,
        "not written by hookean",
    )
    .before(&[EARLIER_FRAMES, &["!", "rm", "{}/out/.hookean-output"]]),
    case(
        "view --force: hookean's own view.html is rewritten",
        &[("f.toml", CLOTH_FRAMES)],
        &["view", "{}/out", "--force"],
        0,
        "",
    )
    .before(&[EARLIER_FRAMES])
    .replaces(&["out/view.html", "out/.hookean-output"]),
    case(
        "view: a run without view.html gets one",
        &[("f.toml", CLOTH_FRAMES)],
        &["view", "{}/out"],
        0,
        "",
    )
    .before(&[EARLIER_FRAMES, &["!", "rm", "{}/out/view.html"]])
    .replaces(&["out/.hookean-output"])
    .creates(&["out/view.html"]),
    case(
        "export-system --force: a folder of the user's holding A.mtx",
        &[("s.toml", CLOTH), ("sys/A.mtx", "my matrix")],
        &[
            "export-system",
            "{}/s.toml",
            "--at",
            "0.02",
            "--out",
            "{}/sys",
            "--force",
        ],
        2,
        "not hookean's output",
    ),
    case(
        "export-system --force: an earlier export is replaced",
        &[("s.toml", CLOTH)],
        &[
            "export-system",
            "{}/s.toml",
            "--at",
            "0.02",
            "--out",
            "{}/sys",
            "--force",
        ],
        0,
        "\"rows\"",
    )
    .before(&[&[
        "export-system",
        "{}/s.toml",
        "--at",
        "0.01",
        "--out",
        "{}/sys",
    ]])
    .replaces(&["sys"]),
    case(
        "export-system: a scene that blows up is a failed run",
        &[("s.toml", CLOTH)],
        &[
            "export-system",
            "{}/s.toml",
            "--at",
            "0.05",
            "--out",
            "{}/sys",
            "--set",
            "integrator.method=fb-euler",
            "--set",
            "integrator.h=0.004",
        ],
        1,
        "blew up",
    )
    .absent(&["sys"]),
    case(
        "export-system: --out holds the scene",
        &[("sys/s.toml", CLOTH)],
        &[
            "export-system",
            "{}/sys/s.toml",
            "--at",
            "0.0",
            "--out",
            "{}/sys",
            "--force",
        ],
        2,
        "which this command reads",
    ),
    case(
        "filter-analysis --force: a folder of the user's",
        &[("s.toml", "[cloth]\n"), ("fig/mine.txt", "mine")],
        &[
            "filter-analysis",
            "{}/s.toml",
            "--plot",
            "{}/fig",
            "--n",
            "4",
            "--t-end",
            "0.01",
            "--force",
        ],
        2,
        "not hookean's output",
    ),
    case(
        "filter-analysis: --plot holds the scene",
        &[("fig/s.toml", "[cloth]\n")],
        &[
            "filter-analysis",
            "{}/fig/s.toml",
            "--plot",
            "{}/fig",
            "--n",
            "4",
            "--force",
        ],
        2,
        "which this command reads",
    ),
    case(
        "workprecision: --out and --plot name one file through ..",
        &[("o/keep.txt", "mine")],
        &[
            "workprecision",
            "--problem",
            "tutorial1",
            "--out",
            "{}/o/sub/../a.csv",
            "--plot",
            "{}/o/a.csv",
        ],
        2,
        "same file",
    ),
    case(
        "workprecision: --plot names --out through a link to its folder",
        &[("o/keep.txt", "mine")],
        &[
            "workprecision",
            "--problem",
            "tutorial1",
            "--out",
            "{}/o/a.csv",
            "--plot",
            "{}/l/a.csv",
        ],
        2,
        "same file",
    )
    .links(&[("l", "{}/o")]),
    case(
        "workprecision --force: --out is a link to a file of the user's (the link is replaced)",
        &[("mine.csv", "my table")],
        &[
            "workprecision",
            "--problem",
            "tutorial1",
            "--methods",
            "explicit-euler",
            "--levels",
            "3",
            "--out",
            "{}/wp.csv",
            "--force",
        ],
        0,
        "explicit-euler",
    )
    .links(&[("wp.csv", "{}/mine.csv")])
    .replaces(&["wp.csv"]),
    case(
        "workprecision --force: --out is a folder",
        &[("o/mine.txt", "mine")],
        &[
            "workprecision",
            "--problem",
            "tutorial1",
            "--out",
            "{}/o",
            "--force",
        ],
        2,
        "is a folder",
    ),
    case(
        "stability --force: --plot is a dangling link (nothing made at its target)",
        &[],
        &[
            "stability",
            "--methods",
            "explicit-euler",
            "--resolution",
            "20",
            "--plot",
            "{}/r.svg",
            "--force",
        ],
        0,
        "",
    )
    .links(&[("r.svg", "{}/elsewhere.svg")])
    .replaces(&["r.svg"])
    .absent(&["elsewhere.svg"]),
    case(
        "reproduce --force: a folder of the user's holding a claims.json",
        &[("r/claims.json", "my claims")],
        &[
            "reproduce",
            "--quick",
            "--claims",
            "2",
            "--out",
            "{}/r",
            "--force",
        ],
        2,
        "not hookean's output",
    ),
];

/// A cloth over a mesh collider `m.obj`.
const OVER_MESH: &str = "duration = 0.05\n[cloth]\nn = 4\n[output]\nframe_rate = 0.0\nwidth = 8\nheight = 8\n[[collider]]\nkind = \"mesh\"\npath = \"m.obj\"\n";
/// A `[mesh]` model of `m.obj`.
const MESH_MODEL: &str = "duration = 0.05\n[mesh]\npath = \"m.obj\"\n[output]\nframe_rate = 0.0\nwidth = 8\nheight = 8\n";
/// A FIFO at `m.obj`.
const FIFO_OBJ: &[&str] = &["!", "mkfifo", "{}/m.obj"];

/// The blow-up of [`BLOW_UP`] into a new folder (no --force): a failed
/// run that leaves its partial output.
const FAILED_RUN: &[&str] = &[
    "fails",
    "run",
    "{}/s.toml",
    "--out",
    "{}/out",
    "--set",
    "integrator.method=fb-euler",
    "--set",
    "integrator.h=0.004",
];

/// The arguments of [`FAILED_RUN`].
const FAILING_RUN: &[&str] = &[
    "run",
    "{}/s.toml",
    "--out",
    "{}/out",
    "--set",
    "integrator.method=fb-euler",
    "--set",
    "integrator.h=0.004",
];

/// Issue 37: every reader opens only regular files (a FIFO would block it
/// for ever, a device or a folder is not a file), saying what it got; a
/// failed command's partial output does not block its corrected rerun; a
/// byte-order mark is not part of the first line.
pub(crate) const READERS: &[Case] = &[
    case(
        "run: the scene is a FIFO (it blocked for ever)",
        &[],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "s.toml: it is a FIFO (named pipe), not a regular file",
    )
    .before(&[&["!", "mkfifo", "{}/s.toml"]])
    .absent(&["out"]),
    case(
        "run: the scene is a folder",
        &[("s.toml/x", "")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "s.toml: it is a folder, not a regular file",
    ),
    case(
        "run: the scene is a device",
        &[],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "s.toml: it is a character device, not a regular file",
    )
    .links(&[("s.toml", "/dev/null")]),
    case(
        "run: a mesh collider's file is a FIFO",
        &[("s.toml", OVER_MESH)],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "m.obj: it is a FIFO (named pipe)",
    )
    .before(&[FIFO_OBJ]),
    case(
        "run: a mesh collider's file is a folder",
        &[("s.toml", OVER_MESH), ("m.obj/x", "")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "m.obj: it is a folder",
    ),
    case(
        "run: a [mesh] model's file is a FIFO",
        &[("s.toml", MESH_MODEL)],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "m.obj: it is a FIFO (named pipe)",
    )
    .before(&[FIFO_OBJ]),
    case(
        "run: a [mesh] model's file is a device",
        &[("s.toml", MESH_MODEL)],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "m.obj: it is a character device",
    )
    .links(&[("m.obj", "/dev/null")]),
    case(
        "run: an OBJ file with a byte-order mark keeps its first vertex",
        &[
            ("s.toml", MESH_MODEL),
            ("m.obj", "\u{feff}v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
        ],
        &["run", "{}/s.toml", "--out", "{}/out"],
        0,
        "",
    )
    .creates(&["out/summary.json"]),
    case(
        "run: a scene with a byte-order mark",
        &[("s.toml", "\u{feff}duration = 0.05\n[cloth]\nn = 4\n[output]\nframe_rate = 0.0\nwidth = 8\nheight = 8\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        0,
        "",
    )
    .creates(&["out/summary.json"]),
    case(
        "solve: the matrix is a FIFO",
        &[],
        &["solve", "{}/a.mtx"],
        2,
        "a.mtx: it is a FIFO (named pipe)",
    )
    .before(&[&["!", "mkfifo", "{}/a.mtx"]]),
    case(
        "solve: the matrix is a folder",
        &[("a.mtx/x", "")],
        &["solve", "{}/a.mtx"],
        2,
        "a.mtx: it is a folder",
    ),
    case(
        "solve: --rhs is a FIFO",
        &[("a.mtx", crate::SPD)],
        &["solve", "{}/a.mtx", "--rhs", "{}/b.mtx"],
        2,
        "b.mtx: it is a FIFO (named pipe)",
    )
    .before(&[&["!", "mkfifo", "{}/b.mtx"]]),
    case(
        "solve: --nullspace is a FIFO",
        &[("a.mtx", crate::SPD)],
        &["solve", "{}/a.mtx", "--precond", "amg", "--nullspace", "{}/n.mtx"],
        2,
        "n.mtx: it is a FIFO (named pipe)",
    )
    .before(&[&["!", "mkfifo", "{}/n.mtx"]]),
    case(
        "solve: a Matrix Market file with a byte-order mark",
        &[("a.mtx", "\u{feff}%%MatrixMarket matrix coordinate real symmetric\n3 3 5\n1 1 4\n2 1 1\n2 2 3\n3 2 -1\n3 3 2\n")],
        &["solve", "{}/a.mtx", "--precond", "jacobi"],
        0,
        "\"converged\":true",
    ),
    case(
        "bench: a FIFO among the inputs is a row saying what it is",
        &[("a.mtx", crate::SPD)],
        &["bench", "{}/a.mtx", "{}/f.mtx", "--out", "{}/b", "--quiet"],
        0,
        "it is a FIFO (named pipe)",
    )
    .before(&[&["!", "mkfifo", "{}/f.mtx"]])
    .creates(&["b/bench.csv"]),
    case(
        "view: summary.json is a FIFO",
        &[],
        &["view", "{}/d"],
        2,
        "summary.json: it is a FIFO (named pipe)",
    )
    .before(&[&["!", "mkdir", "{}/d"], &["!", "mkfifo", "{}/d/summary.json"]]),
    case(
        "view: a frame is a FIFO",
        &[("f.toml", CLOTH_FRAMES)],
        &["view", "{}/out"],
        2,
        "frame-0001.obj: it is a FIFO (named pipe)",
    )
    .before(&[
        EARLIER_FRAMES,
        &["!", "rm", "{}/out/view.html", "{}/out/frame-0001.obj"],
        &["!", "mkfifo", "{}/out/frame-0001.obj"],
    ]),
    case(
        "view: steps.csv is a FIFO",
        &[("f.toml", CLOTH_FRAMES)],
        &["view", "{}/out"],
        2,
        "steps.csv: it is a FIFO (named pipe)",
    )
    .before(&[
        EARLIER_FRAMES,
        &["!", "rm", "{}/out/view.html", "{}/out/steps.csv"],
        &["!", "mkfifo", "{}/out/steps.csv"],
    ]),
    case(
        "run: the corrected rerun into the folder a failed run left needs no --force",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out"],
        0,
        "",
    )
    .before(&[FAILED_RUN])
    .replaces(&["out"])
    .creates(&["out/summary.json"]),
    case(
        "run: a rerun that fails again keeps its own partial output",
        &[("s.toml", CLOTH)],
        FAILING_RUN,
        1,
        "the partial output is in",
    )
    .before(&[FAILED_RUN])
    .replaces(&["out"]),
    case(
        "export-system: a failed run's partial output is not another command's to replace",
        &[("s.toml", CLOTH)],
        &["export-system", "{}/s.toml", "--at", "0", "--out", "{}/out"],
        2,
        "exists; pass --force",
    )
    .before(&[FAILED_RUN]),
    case(
        "run: a failed run's partial output with a file of the user's added needs --force",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "exists; pass --force",
    )
    .before(&[FAILED_RUN, &["!", "sh", "-c", "echo mine > {}/out/notes.txt"]]),
    case(
        "workprecision: a --plot that cannot be written leaves no table either",
        &[],
        &[
            "workprecision",
            "--problem",
            "tutorial1",
            "--methods",
            "explicit-euler",
            "--levels",
            "2",
            "--out",
            "{}/wp.csv",
            "--plot",
            "{}/none/wp.svg",
        ],
        1,
        "nothing was written",
    )
    .absent(&["wp.csv", "none"]),
];
