//! The search space of `hookean tune`: the preconditioners ([`Kind`]), the
//! storages a system allows ([`Layout`]), the options of each and their
//! values ([`Axis`]), a configuration ([`Point`]), its neighbours one option
//! away and the whole grid, in a deterministic order (a pure function of the
//! system's size).

use hookean_sparse::{AmgOptions, AmgPrecision, AmgSmoother, PrecondKind, PreconditionerOptions};

/// The preconditioners, in the order their defaults are measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Kind {
    Amg,
    Ic0,
    Ssor,
    BlockJacobi,
    Jacobi,
    Mic0,
    None,
}

/// Every kind, in measuring order.
pub const KINDS: [Kind; 7] = [
    Kind::Amg,
    Kind::Ic0,
    Kind::Ssor,
    Kind::BlockJacobi,
    Kind::Jacobi,
    Kind::Mic0,
    Kind::None,
];

impl Kind {
    /// The name of `--precond` and `solver.preconditioner`.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Amg => "amg",
            Kind::Ic0 => "ic0",
            Kind::Ssor => "ssor",
            Kind::BlockJacobi => "block-jacobi",
            Kind::Jacobi => "jacobi",
            Kind::Mic0 => "mic0",
            Kind::None => "none",
        }
    }
}

/// SSOR's relaxations (`--omega`; the first is its default).
pub const OMEGAS: [f64; 6] = [1.0, 0.8, 1.2, 1.4, 1.6, 1.8];
/// MIC(0)'s relaxations (`solver.mic_omega`; the first is its default).
pub const MIC_OMEGAS: [f64; 5] = [PrecondKind::MIC_OMEGA, 0.5, 0.9, 0.95, 1.0];
/// The multigrid's smoothers.
pub const SMOOTHERS: [AmgSmoother; 3] = [
    AmgSmoother::BlockJacobi,
    AmgSmoother::SymmetricGaussSeidel,
    AmgSmoother::BlockIc0,
];
/// The multigrid's sweeps.
pub const SWEEPS: [usize; 3] = [1, 2, 3];
/// The multigrid's strength thresholds.
pub const STRENGTHS: [f64; 4] = [0.08, 0.0, 0.02, 0.16];
/// The multigrid's coarse sizes.
pub const COARSE_SIZES: [usize; 3] = [500, 100, 2000];
/// The multigrid's prolongation weights.
pub const PROLONGATION_WEIGHTS: [f64; 2] = [4.0 / 3.0, 1.0];
/// The multigrid's storage precisions.
pub const PRECISIONS: [AmgPrecision; 2] = [AmgPrecision::Single, AmgPrecision::Double];

/// One option of one preconditioner, with its grid of values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    Omega,
    MicOmega,
    Smoother,
    Sweeps,
    Strength,
    CoarseSize,
    ProlongationWeight,
    Precision,
}

/// Every axis, in the order neighbours are visited.
pub const AXES: [Axis; 8] = [
    Axis::Omega,
    Axis::MicOmega,
    Axis::Smoother,
    Axis::Sweeps,
    Axis::Strength,
    Axis::CoarseSize,
    Axis::ProlongationWeight,
    Axis::Precision,
];

pub(super) fn smoother_name(s: AmgSmoother) -> &'static str {
    match s {
        AmgSmoother::SymmetricGaussSeidel => "gauss-seidel",
        AmgSmoother::BlockIc0 => "ic0",
        _ => "block-jacobi",
    }
}

pub(super) fn precision_name(p: AmgPrecision) -> &'static str {
    match p {
        AmgPrecision::Double => "double",
        _ => "single",
    }
}

impl Axis {
    /// The preconditioner the axis belongs to.
    pub fn kind(self) -> Kind {
        match self {
            Axis::Omega => Kind::Ssor,
            Axis::MicOmega => Kind::Mic0,
            _ => Kind::Amg,
        }
    }

    /// The number of values.
    pub fn len(self) -> usize {
        match self {
            Axis::Omega => OMEGAS.len(),
            Axis::MicOmega => MIC_OMEGAS.len(),
            Axis::Smoother => SMOOTHERS.len(),
            Axis::Sweeps => SWEEPS.len(),
            Axis::Strength => STRENGTHS.len(),
            Axis::CoarseSize => COARSE_SIZES.len(),
            Axis::ProlongationWeight => PROLONGATION_WEIGHTS.len(),
            Axis::Precision => PRECISIONS.len(),
        }
    }

    /// The `hookean solve` flag.
    pub(super) fn flag(self) -> &'static str {
        match self {
            Axis::Omega => "--omega",
            Axis::MicOmega => "--mic-omega",
            Axis::Smoother => "--amg-smoother",
            Axis::Sweeps => "--amg-sweeps",
            Axis::Strength => "--amg-strength",
            Axis::CoarseSize => "--amg-coarse-size",
            Axis::ProlongationWeight => "--amg-prolongation-weight",
            Axis::Precision => "--amg-precision",
        }
    }

    /// The scene key (crates/hookean-cli/src/scene_keys.txt): its table
    /// (`solver` or `solver.amg`) and name.
    pub(super) fn scene_key(self) -> (&'static str, &'static str) {
        match self {
            Axis::Omega => ("solver", "omega"),
            Axis::MicOmega => ("solver", "mic_omega"),
            Axis::Smoother => ("solver.amg", "smoother"),
            Axis::Sweeps => ("solver.amg", "sweeps"),
            Axis::Strength => ("solver.amg", "strength_threshold"),
            Axis::CoarseSize => ("solver.amg", "coarse_size"),
            Axis::ProlongationWeight => ("solver.amg", "prolongation_weight"),
            Axis::Precision => ("solver.amg", "precision"),
        }
    }

    /// The `i`-th value as written on the command line.
    pub(super) fn value(self, i: usize) -> String {
        match self {
            Axis::Omega => format!("{:?}", OMEGAS[i]),
            Axis::MicOmega => format!("{:?}", MIC_OMEGAS[i]),
            Axis::Smoother => smoother_name(SMOOTHERS[i]).into(),
            Axis::Sweeps => SWEEPS[i].to_string(),
            Axis::Strength => format!("{:?}", STRENGTHS[i]),
            Axis::CoarseSize => COARSE_SIZES[i].to_string(),
            Axis::ProlongationWeight => format!("{:?}", PROLONGATION_WEIGHTS[i]),
            Axis::Precision => precision_name(PRECISIONS[i]).into(),
        }
    }

    /// The `i`-th value as a TOML value.
    pub(super) fn toml(self, i: usize) -> String {
        match self {
            Axis::Smoother | Axis::Precision => format!("\"{}\"", self.value(i)),
            _ => self.value(i),
        }
    }
}

/// The storage PCG runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Layout {
    /// Symmetric 3x3 blocks.
    Block,
    /// CSR with this many unknowns per node.
    Csr(usize),
}

impl Layout {
    /// `csr/2`, `block`.
    pub(super) fn label(self) -> String {
        match self {
            Layout::Block => "block".into(),
            Layout::Csr(d) => format!("csr/{d}"),
        }
    }

    /// The flags of `hookean solve`.
    pub(super) fn flags(self) -> Vec<String> {
        match self {
            Layout::Block => vec!["--format".into(), "block".into()],
            Layout::Csr(d) => vec![
                "--format".into(),
                "csr".into(),
                "--block-size".into(),
                d.to_string(),
            ],
        }
    }
}

/// The storages of an `n`-unknown system, `first` (what `hookean solve`
/// picks) first, then CSR with 1, 2 and 3 unknowns per node and 3x3 blocks,
/// where `n` is a multiple of the block.
pub fn layouts(n: usize, first: Layout) -> Vec<Layout> {
    let mut out = vec![first];
    let others = [
        Layout::Csr(1),
        Layout::Csr(2),
        Layout::Csr(3),
        Layout::Block,
    ];
    for l in others {
        let d = match l {
            Layout::Block => 3,
            Layout::Csr(d) => d,
        };
        if n.is_multiple_of(d) && !out.contains(&l) {
            out.push(l);
        }
    }
    out
}

/// The storages (indices into `layouts`) a kind is measured on: all for
/// the multigrid and block Jacobi (whose blocks follow the unknowns per
/// node); 3x3 blocks only for MIC(0); one of each storage for the rest
/// (they do not group unknowns).
pub fn kind_layouts(kind: Kind, layouts: &[Layout]) -> Vec<usize> {
    let all = 0..layouts.len();
    match kind {
        Kind::Amg | Kind::BlockJacobi => all.collect(),
        Kind::Mic0 => all.filter(|&i| layouts[i] == Layout::Block).collect(),
        _ => {
            let mut seen_csr = false;
            let mut seen_block = false;
            all.filter(|&i| match layouts[i] {
                Layout::Block => !std::mem::replace(&mut seen_block, true),
                Layout::Csr(_) => !std::mem::replace(&mut seen_csr, true),
            })
            .collect()
        }
    }
}

/// A point of the grid: a preconditioner, a storage (an index into the
/// system's [`layouts`]) and an index into each [`AXES`] value list (0 on
/// the axes of other preconditioners).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Point {
    pub kind: Kind,
    pub layout: usize,
    pub axes: [usize; AXES.len()],
}

impl Point {
    /// `kind` with its defaults on its first storage; `None` when it has
    /// no storage (MIC(0) without block storage).
    pub fn default_of(kind: Kind, layouts: &[Layout]) -> Option<Point> {
        kind_layouts(kind, layouts).first().map(|&layout| Point {
            kind,
            layout,
            axes: [0; AXES.len()],
        })
    }

    /// The options away from the kind's defaults (the storage counts).
    pub fn changes(&self, layouts: &[Layout]) -> usize {
        let first = kind_layouts(self.kind, layouts).first().copied();
        usize::from(Some(self.layout) != first) + self.axes.iter().filter(|&&i| i != 0).count()
    }

    /// The axes of this point's preconditioner.
    pub(super) fn own_axes(&self) -> impl Iterator<Item = (usize, Axis)> + '_ {
        AXES.iter()
            .copied()
            .enumerate()
            .filter(move |(_, a)| a.kind() == self.kind)
    }

    /// The library's options of this point.
    pub fn options(&self) -> PreconditionerOptions {
        let v = |axis: Axis| self.axes[AXES.iter().position(|&a| a == axis).unwrap_or(0)];
        let kind = match self.kind {
            Kind::Amg => PrecondKind::Amg,
            Kind::Ic0 => PrecondKind::Ic0,
            Kind::Ssor => PrecondKind::Ssor {
                omega: OMEGAS[v(Axis::Omega)],
            },
            Kind::BlockJacobi => PrecondKind::BlockJacobi,
            Kind::Jacobi => PrecondKind::Jacobi,
            Kind::Mic0 => PrecondKind::Mic0 {
                omega: MIC_OMEGAS[v(Axis::MicOmega)],
            },
            Kind::None => PrecondKind::None,
        };
        let mut options = PreconditionerOptions::from(kind);
        if self.kind == Kind::Amg {
            options.amg = AmgOptions {
                smoother: SMOOTHERS[v(Axis::Smoother)],
                sweeps: SWEEPS[v(Axis::Sweeps)],
                strength_threshold: STRENGTHS[v(Axis::Strength)],
                coarse_size: COARSE_SIZES[v(Axis::CoarseSize)],
                prolongation_weight: PROLONGATION_WEIGHTS[v(Axis::ProlongationWeight)],
                precision: PRECISIONS[v(Axis::Precision)],
                ..AmgOptions::default()
            };
        }
        options
    }

    /// `amg csr/2 smoother=gauss-seidel sweeps=2` (options away from the
    /// defaults only).
    pub fn label(&self, layouts: &[Layout]) -> String {
        let mut s = format!("{} {}", self.kind.name(), layouts[self.layout].label());
        for (k, axis) in self.own_axes() {
            if self.axes[k] != 0 {
                s.push_str(&format!(
                    " {}={}",
                    axis.scene_key().1,
                    axis.value(self.axes[k])
                ));
            }
        }
        s
    }
}

/// The points one option (or the storage) away from `center`, in [`AXES`]
/// order and each axis's value order, then the storages.
pub fn neighbours(center: &Point, layouts: &[Layout]) -> Vec<Point> {
    let mut out = Vec::new();
    for (k, axis) in center.own_axes() {
        for i in (0..axis.len()).filter(|&i| i != center.axes[k]) {
            let mut p = *center;
            p.axes[k] = i;
            out.push(p);
        }
    }
    for l in kind_layouts(center.kind, layouts) {
        if l != center.layout {
            out.push(Point {
                layout: l,
                ..*center
            });
        }
    }
    out
}

/// The whole grid: the default of every kind (in [`KINDS`] order), then,
/// kind by kind, every other point (storages outermost, then the axes in
/// [`AXES`] order, the last fastest).
pub fn grid(layouts: &[Layout]) -> Vec<Point> {
    let defaults: Vec<Point> = KINDS
        .iter()
        .filter_map(|&k| Point::default_of(k, layouts))
        .collect();
    let mut out = defaults.clone();
    for d in &defaults {
        let own: Vec<(usize, Axis)> = d.own_axes().collect();
        for l in kind_layouts(d.kind, layouts) {
            let mut p = Point { layout: l, ..*d };
            loop {
                if p != *d {
                    out.push(p);
                }
                // The odometer over the kind's axes.
                let mut carry = true;
                for &(k, axis) in own.iter().rev() {
                    p.axes[k] += 1;
                    if p.axes[k] < axis.len() {
                        carry = false;
                        break;
                    }
                    p.axes[k] = 0;
                }
                if carry {
                    break;
                }
            }
        }
    }
    out
}
