//! Cases of the catalogue: `hookean run`.

use crate::{CLOTH, Case, case};

pub(crate) const RUN: &[Case] = &[
    case(
        "run: a bdf run with atol = 1e300 stores energy in its springs: exit 1 naming the term",
        &[(
            "s.toml",
            "duration = 2.0\n[cloth]\nn = 8\n[integrator]\nmethod = \"bdf\"\natol = 1e300\n\
             [output]\nframe_rate = 0.0\nwidth = 8\nheight = 8\n",
        )],
        &["run", "{}/s.toml", "--out", "{}/out"],
        1,
        "the spring energy grew from 0.0000e0 J to",
    ),
    case(
        "run: an energy budget below the integrator's own error cannot be met even in 64 substeps: exit 1 naming the key (issue 37)",
        &[(
            "s.toml",
            "duration = 0.2\n[cloth]\nn = 6\n[integrator]\nmethod = \"implicit-midpoint\"\n\
             energy_budget = 1e-9\n[output]\nframe_rate = 0.0\nwidth = 8\nheight = 8\n",
        )],
        &["run", "{}/s.toml", "--out", "{}/out"],
        1,
        "plus integrator.energy_budget = 1e-9 times the scene's energy scale, even with the step split into 64 substeps",
    ),
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
        "must lie in (0, inf), got -1",
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
        "run: a cloth so large its springs have infinite length (refused by the size's range)",
        &[("s.toml", CLOTH)],
        &["run", "{}/s.toml", "--out", "{}/out", "--set", "cloth.size=1e308"],
        2,
        "--set cloth.size=1e308: must lie in [1e-100, 1e100]",
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
    // The partial output (steps.csv up to the blow-up) goes to --out, named.
    .creates(&["out/steps.csv", "out/.hookean-output"]),
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
