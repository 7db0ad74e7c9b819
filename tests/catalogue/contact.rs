//! Cases of the catalogue: contact input (issue 26, docs/CONTACT.md): mesh
//! files that are missing, empty, non-manifold or not finite, as colliders
//! and as the model; negative thickness, friction and self-collision keys.

use crate::{Case, case};

pub(crate) const CONTACT: &[Case] = &[
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
        "run: a cloth that starts inside a mesh collider (issue 37)",
        &[("s.toml", "duration = 0.05\n[cloth]\nn = 4\npins = \"none\"\nsize = 0.5\norigin = [0.2, 0.2, 0.5]\n[[collider]]\nkind = \"plane\"\npoint = [0, 0, -1]\nnormal = [0, 0, 1]\n[[collider]]\nkind = \"mesh\"\npath = \"box.obj\"\n"), ("box.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nv 1 0 1\nv 0 1 1\nv 1 1 1\nf 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "[collider 2]: 16 of the model's 16 particles start inside it",
    )
    .absent(&["out"]),
    case(
        "run: a cloth that starts below a floor plane (issue 37)",
        &[("s.toml", "duration = 0.05\n[cloth]\nn = 4\npins = \"none\"\norigin = [0, 0, -0.1]\n[[collider]]\nkind = \"plane\"\npoint = [0, 0, 0]\nnormal = [0, 0, 1]\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "[collider 1]: 16 of the model's 16 particles start inside it",
    )
    .absent(&["out"]),
    case(
        "run: a closed mesh collider wound inside-out (issue 37)",
        &[("s.toml", "duration = 0.05\n[cloth]\nn = 4\norigin = [0, 0, 1.5]\n[[collider]]\nkind = \"mesh\"\npath = \"box.obj\"\n"), ("box.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nv 1 0 1\nv 0 1 1\nv 1 1 1\nf 2 4 3 1\nf 7 8 6 5\nf 5 6 2 1\nf 4 8 7 3\nf 3 7 5 1\nf 6 8 4 2\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "box.obj:9: the closed surface this face belongs to is inside-out",
    )
    .absent(&["out"]),
    case(
        "run: a mesh coordinate whose products overflow (issue 37)",
        &[("s.toml", "duration = 0.05\n[cloth]\nn = 4\n[[collider]]\nkind = \"mesh\"\npath = \"big.obj\"\n"), ("big.obj", "v 0 0 -1\nv 1e155 0 -1\nv 0 1e155 -1\nf 1 2 3\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "big.obj: vertex 2 has the coordinate 1e155",
    )
    .absent(&["out"]),
    case(
        "run: a mesh thickness beyond the mesh's size (issue 37)",
        &[("s.toml", "duration = 0.05\n[cloth]\nn = 4\norigin = [0, 0, 1]\n[[collider]]\nkind = \"mesh\"\npath = \"tri.obj\"\nthickness = 1e300\n"), ("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "[collider 1]: invalid parameter thickness: 1e300 m is outside [0, 1.414214] m",
    )
    .absent(&["out"]),
    case(
        "run: a self-collision thickness above the cloth's limit (issue 37)",
        &[("s.toml", "duration = 0.05\n[cloth]\nn = 8\n[contact]\nself_collision = true\nself_thickness = 0.11\n")],
        &["run", "{}/s.toml", "--out", "{}/out"],
        2,
        "[contact]: invalid parameter self_thickness: 0.11 m is outside (0, 0.101015) m",
    )
    .absent(&["out"]),
];
