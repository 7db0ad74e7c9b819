//! A sequence of linear systems in a folder, as `hookean export-system
//! --every K` writes it and `hookean bench --sequence` reads it: the
//! systems Newton handed to PCG during a run, numbered from 1 in the order
//! they were solved.
//!
//! ```text
//! system-00001-A.mtx            A (coordinate real symmetric)
//! system-00001-b.mtx            b (array)
//! system-00001-x0.mtx           PCG's starting guess (the warm start), when it had one
//! system-00001-x.mtx            the solution PCG returned in the run
//! system-00001-constraints.csv  filtered PCG's constraints, when it had some:
//!                               particle,dx,dy,dz,value (d . x_particle = value)
//! ...
//! index.csv                     one row per system (below)
//! ```
//!
//! `index.csv`: `system` (the file number), `solve` (the solve's number in
//! the run: `system` with `--every 1`), `step` (the accepted time step
//! during which it was solved, from 1), `t` (s, the time at the start of
//! that step), `newton_iteration` (the solve's number within its step, from
//! 1), `unknowns`, `rtol` and `max_iter` (PCG's relative tolerance and
//! iteration limit, empty for `2 n`), `set_up` (1 if the run set the
//! preconditioner up for this matrix), `iterations` and `converged` (what
//! PCG did in the run). A folder without `index.csv` is a plain sequence of
//! numbered systems: solved from zero, without constraints, to `--rtol`.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use hookean::nonlinear::{RecordedSolve, SolveRecorder};
use hookean_sparse::{
    BlockPattern, Constraints, ReadOptions, SymBlockMatrix, read_matrix_market_file_with,
    write_matrix_market, write_vector_market,
};

use crate::CliError;

/// The name of system `k`'s file `part` (`A.mtx`, `b.mtx`, `x0.mtx`,
/// `constraints.csv`, `x.mtx`).
pub fn file_name(k: usize, part: &str) -> String {
    format!("system-{k:05}-{part}")
}

/// The header of `index.csv`.
const INDEX_HEADER: &str =
    "system,solve,step,t,newton_iteration,unknowns,rtol,max_iter,set_up,iterations,converged";

/// What the run says about one system (a row of `index.csv`).
#[derive(Debug, Clone, PartialEq)]
pub struct IndexRow {
    pub solve: usize,
    pub step: usize,
    pub t: f64,
    pub newton_iteration: usize,
    pub unknowns: usize,
    pub rtol: f64,
    pub max_iter: Option<usize>,
    pub set_up: bool,
    pub iterations: usize,
    pub converged: bool,
}

/// The [`SolveRecorder`] of `hookean export-system --every K`: writes every
/// `every`-th solve (the 1st, the `K+1`-th, ...) into `dir` as it comes, and
/// keeps the index rows and the first error for the command to collect.
pub struct SequenceWriter {
    dir: PathBuf,
    every: usize,
    /// Solves seen, systems written.
    solves: usize,
    written: usize,
    /// The current step (from 1), its start time and the solves in it.
    step: usize,
    t: f64,
    in_step: usize,
    rows: Vec<IndexRow>,
    /// The first failure; nothing is written after it.
    pub error: Option<String>,
}

impl SequenceWriter {
    pub fn new(dir: &Path, every: usize) -> Self {
        Self {
            dir: dir.to_path_buf(),
            every,
            solves: 0,
            written: 0,
            step: 1,
            t: 0.0,
            in_step: 0,
            rows: Vec::new(),
            error: None,
        }
    }

    /// The step that ended at `t` was accepted: later solves belong to the next.
    pub fn next_step(&mut self, t: f64) {
        self.step += 1;
        self.t = t;
        self.in_step = 0;
    }

    /// Solves seen and systems written.
    pub fn counts(&self) -> (usize, usize) {
        (self.solves, self.written)
    }

    /// `index.csv`'s text.
    pub fn index(&self) -> String {
        let mut s = format!("{INDEX_HEADER}\n");
        for (k, r) in self.rows.iter().enumerate() {
            s.push_str(&format!(
                "{},{},{},{:e},{},{},{:e},{},{},{},{}\n",
                k + 1,
                r.solve,
                r.step,
                r.t,
                r.newton_iteration,
                r.unknowns,
                r.rtol,
                r.max_iter.map_or(String::new(), |m| m.to_string()),
                u8::from(r.set_up),
                r.iterations,
                u8::from(r.converged)
            ));
        }
        s
    }

    fn write(&self, k: usize, solve: &RecordedSolve<'_>) -> Result<(), String> {
        let file = |part: &str| self.dir.join(file_name(k, part));
        let create = |p: &Path| {
            crate::output::new_file(p)
                .map(std::io::BufWriter::new)
                .map_err(|e| format!("cannot write {}: {e}", p.display()))
        };
        let finish = |p: &Path, w: std::io::BufWriter<std::fs::File>| {
            w.into_inner()
                .map(drop)
                .map_err(|e| format!("cannot write {}: {}", p.display(), e.error()))
        };
        let matrix = solve
            .matrix()
            .ok_or("the solver's matrix is not a stored matrix")?;
        let p = file("A.mtx");
        let mut w = create(&p)?;
        write_matrix_market(&mut w, &matrix, true).map_err(|e| format!("{}: {e}", p.display()))?;
        finish(&p, w)?;
        let vectors = [
            ("b.mtx", Some(solve.rhs)),
            ("x0.mtx", solve.guess),
            ("x.mtx", Some(solve.solution)),
        ];
        for (part, v) in vectors {
            let Some(v) = v else { continue };
            let p = file(part);
            let mut w = create(&p)?;
            write_vector_market(&mut w, v).map_err(|e| format!("{}: {e}", p.display()))?;
            finish(&p, w)?;
        }
        if let Some(c) = solve.constraints {
            let mut text = String::from("particle,dx,dy,dz,value\n");
            for (p, d, v) in c.directions() {
                text.push_str(&format!(
                    "{p},{:.16e},{:.16e},{:.16e},{v:.16e}\n",
                    d[0], d[1], d[2]
                ));
            }
            let p = file("constraints.csv");
            let mut w = create(&p)?;
            std::io::Write::write_all(&mut w, text.as_bytes())
                .map_err(|e| format!("cannot write {}: {e}", p.display()))?;
            finish(&p, w)?;
        }
        Ok(())
    }
}

impl SolveRecorder for SequenceWriter {
    fn record(&mut self, solve: &RecordedSolve<'_>) {
        self.solves += 1;
        self.in_step += 1;
        if self.error.is_some() || !(self.solves - 1).is_multiple_of(self.every) {
            return;
        }
        let k = self.written + 1;
        if let Err(e) = self.write(k, solve) {
            self.error = Some(e);
            return;
        }
        self.written = k;
        self.rows.push(IndexRow {
            solve: self.solves,
            step: self.step,
            t: self.t,
            newton_iteration: self.in_step,
            unknowns: solve.rhs.len(),
            rtol: solve.rtol,
            max_iter: solve.max_iter,
            set_up: solve.set_up,
            iterations: solve.stats.iterations,
            converged: solve.stats.converged,
        });
    }
}

/// One system of a sequence, in the block storage PCG runs on in a run.
pub struct SequenceSystem {
    /// `A`, on the pattern every system of the sequence shares.
    pub a: SymBlockMatrix,
    pub b: Vec<f64>,
    /// PCG's starting guess (`None`: zero).
    pub x0: Option<Vec<f64>>,
    /// The solution PCG returned in the run (`None`: not recorded, as in
    /// folders written before it was).
    pub x: Option<Vec<f64>>,
    /// Filtered PCG's constraints (`None`: plain PCG).
    pub constraints: Option<Constraints>,
    /// The run's row of `index.csv`, if the folder has one.
    pub run: Option<IndexRow>,
}

/// The parts of a system's files.
const PARTS: [&str; 5] = ["A.mtx", "b.mtx", "x0.mtx", "constraints.csv", "x.mtx"];

/// `(number, part)` of a file named like a sequence's.
fn parse_name(name: &str) -> Option<(usize, usize)> {
    let rest = name.strip_prefix("system-")?;
    let (digits, part) = rest.split_once('-')?;
    if digits.is_empty() || !digits.bytes().all(|c| c.is_ascii_digit()) {
        return None;
    }
    let k = digits.parse().ok()?;
    let p = PARTS.iter().position(|&q| q == part)?;
    Some((k, p))
}

/// `path: message`, unless the message names the path already.
fn named(path: &Path, message: impl std::fmt::Display) -> CliError {
    let (m, p) = (message.to_string(), path.display().to_string());
    if m.contains(&p) {
        CliError::Input(m)
    } else {
        CliError::Input(format!("{p}: {m}"))
    }
}

/// Reads every system of the sequence in `dir` within `cap` bytes. Bad
/// input, each naming its file: no numbered systems, a gap in the
/// numbering (a number without its `A.mtx`), a missing right-hand side,
/// a file that cannot be read, a matrix without 3x3 block storage, or one
/// of another size or pattern than system 1.
pub fn read_sequence(dir: &Path, cap: u64) -> Result<Vec<SequenceSystem>, CliError> {
    let entries = std::fs::read_dir(dir).map_err(|e| named(dir, e))?;
    // present[k - 1][part]
    let mut present: Vec<[bool; 5]> = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| named(dir, e))?;
        let Some((k, part)) = entry.file_name().to_str().and_then(parse_name) else {
            continue;
        };
        if k == 0 {
            return Err(named(
                &entry.path(),
                "systems are numbered from 1 (system-00001-A.mtx)",
            ));
        }
        if present.len() < k {
            if k > crate::bench::MAX_SYSTEMS {
                return Err(named(
                    &entry.path(),
                    format!(
                        "more than {} systems: replay fewer at a time",
                        crate::bench::MAX_SYSTEMS
                    ),
                ));
            }
            present.resize(k, [false; 5]);
        }
        present[k - 1][part] = true;
    }
    if present.is_empty() {
        return Err(named(
            dir,
            "no numbered systems (system-00001-A.mtx, system-00001-b.mtx, ...)",
        ));
    }
    let file = |k: usize, part: usize| dir.join(file_name(k, PARTS[part]));
    for (i, parts) in present.iter().enumerate() {
        let k = i + 1;
        if !parts[0] {
            return Err(named(
                &file(k, 0),
                format!(
                    "missing: the numbering has a gap (the folder has systems up to {})",
                    present.len()
                ),
            ));
        }
        if !parts[1] {
            return Err(named(
                &file(k, 1),
                "missing: every system needs its right-hand side",
            ));
        }
    }
    let index_path = dir.join("index.csv");
    let index = if index_path.exists() {
        Some(read_index(&index_path, present.len())?)
    } else {
        None
    };
    let opts = ReadOptions {
        max_bytes: cap,
        ..ReadOptions::default()
    };
    let read_vector = |path: &Path, n: usize| -> Result<Vec<f64>, CliError> {
        let v = read_matrix_market_file_with(path, &opts)
            .and_then(|m| m.into_vector())
            .map_err(|e| named(path, e))?;
        if v.len() != n {
            return Err(named(
                path,
                format!("{} entries, the matrix has {n} rows", v.len()),
            ));
        }
        Ok(v)
    };
    let mut systems: Vec<SequenceSystem> = Vec::with_capacity(present.len());
    let mut pattern: Option<Arc<BlockPattern>> = None;
    for (i, parts) in present.iter().enumerate() {
        let k = i + 1;
        let path = file(k, 0);
        let csr = read_matrix_market_file_with(&path, &opts)
            .map_err(|e| named(&path, e))?
            .into_csr();
        let read = SymBlockMatrix::from_csr(&csr)
            .map_err(|e| named(&path, format!("cannot use 3x3 block storage: {e}")))?;
        drop(csr);
        let a = match &pattern {
            None => {
                // The sequence held in memory: every system's values and
                // vectors (b, x0, x and the replay's own start).
                let per_system = (read.values().len() * 72 + 32 * read.dim()) as u64;
                let total = per_system.saturating_mul(present.len() as u64);
                if total > cap {
                    return Err(named(
                        dir,
                        format!(
                            "{} systems of {} unknowns need about {:.1} GiB, more than the {:.1} GiB allowed (--max-memory)",
                            present.len(),
                            read.dim(),
                            total as f64 / (1u64 << 30) as f64,
                            cap as f64 / (1u64 << 30) as f64
                        ),
                    ));
                }
                pattern = Some(read.pattern().clone());
                read
            }
            Some(p) => {
                if read.dim() != p.dim() {
                    return Err(named(
                        &path,
                        format!(
                            "{} unknowns, {} has {} (the systems of a sequence have one size)",
                            read.dim(),
                            file_name(1, PARTS[0]),
                            p.dim()
                        ),
                    ));
                }
                if **read.pattern() != **p {
                    return Err(named(
                        &path,
                        format!(
                            "another sparsity pattern than {} (the systems of a sequence share one)",
                            file_name(1, PARTS[0])
                        ),
                    ));
                }
                let mut a = SymBlockMatrix::new(p.clone());
                a.values_mut().copy_from_slice(read.values());
                a
            }
        };
        let n = a.dim();
        let b = read_vector(&file(k, 1), n)?;
        let x0 = if parts[2] {
            Some(read_vector(&file(k, 2), n)?)
        } else {
            None
        };
        let constraints = if parts[3] {
            Some(read_constraints(&file(k, 3), n / 3)?)
        } else {
            None
        };
        let x = if parts[4] {
            Some(read_vector(&file(k, 4), n)?)
        } else {
            None
        };
        if let Some(row) = index.as_ref().map(|rows| &rows[i])
            && row.unknowns != n
        {
            return Err(named(
                &index_path,
                format!(
                    "line {}: {} unknowns, {} has {n}",
                    k + 1,
                    row.unknowns,
                    path.display()
                ),
            ));
        }
        systems.push(SequenceSystem {
            a,
            b,
            x0,
            x,
            constraints,
            run: index.as_ref().map(|rows| rows[i].clone()),
        });
    }
    Ok(systems)
}

/// The lines of a small text file (at most 64 MiB), after its header,
/// numbered from 2; the header must be `header`.
fn data_lines(path: &Path, header: &str) -> Result<Vec<(usize, String)>, CliError> {
    let text = hookean_io::read_file(path, 64 << 20).map_err(|e| named(path, e))?;
    let mut lines = text.lines();
    match lines.next().map(str::trim) {
        Some(h) if h == header => {}
        other => {
            return Err(named(
                path,
                format!(
                    "line 1: expected the header '{header}', found '{}'",
                    other.unwrap_or("")
                ),
            ));
        }
    }
    Ok(lines
        .enumerate()
        .map(|(i, l)| (i + 2, l.trim().to_string()))
        .filter(|(_, l)| !l.is_empty())
        .collect())
}

/// A constraints file on `particles` particles.
fn read_constraints(path: &Path, particles: usize) -> Result<Constraints, CliError> {
    let mut c = Constraints::new(particles);
    for (line, text) in data_lines(path, "particle,dx,dy,dz,value")? {
        let bad = |m: String| named(path, format!("line {line}: {m}"));
        let fields: Vec<&str> = text.split(',').map(str::trim).collect();
        if fields.len() != 5 {
            return Err(bad(format!("{} fields, expected 5", fields.len())));
        }
        let p: usize = fields[0]
            .parse()
            .map_err(|_| bad(format!("particle '{}' is not a number", fields[0])))?;
        let mut x = [0.0; 4];
        for (v, f) in x.iter_mut().zip(&fields[1..]) {
            *v = f
                .parse()
                .map_err(|_| bad(format!("'{f}' is not a number")))?;
        }
        c.constrain(p, [x[0], x[1], x[2]], x[3])
            .map_err(|e| bad(e.to_string()))?;
    }
    Ok(c)
}

/// `index.csv` of a sequence of `systems` systems: one row per system, in order.
fn read_index(path: &Path, systems: usize) -> Result<Vec<IndexRow>, CliError> {
    let lines = data_lines(path, INDEX_HEADER)?;
    if lines.len() != systems {
        return Err(named(
            path,
            format!(
                "{} rows for {systems} systems (one row per system)",
                lines.len()
            ),
        ));
    }
    let mut rows = Vec::with_capacity(systems);
    for (k, (line, text)) in lines.iter().enumerate() {
        let bad = |m: String| named(path, format!("line {line}: {m}"));
        let f: Vec<&str> = text.split(',').map(str::trim).collect();
        if f.len() != 11 {
            return Err(bad(format!("{} fields, expected 11", f.len())));
        }
        let int = |i: usize| -> Result<usize, CliError> {
            f[i].parse()
                .map_err(|_| bad(format!("'{}' is not a count", f[i])))
        };
        let num = |i: usize| -> Result<f64, CliError> {
            f[i].parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| bad(format!("'{}' is not a number", f[i])))
        };
        let flag = |i: usize| -> Result<bool, CliError> {
            match f[i] {
                "0" => Ok(false),
                "1" => Ok(true),
                other => Err(bad(format!("'{other}' is not 0 or 1"))),
            }
        };
        if int(0)? != k + 1 {
            return Err(bad(format!(
                "system {} in row {}: the rows follow the numbering",
                f[0],
                k + 1
            )));
        }
        let rtol = num(6)?;
        if !(0.0..1.0).contains(&rtol) {
            return Err(bad(format!("rtol {rtol} is outside [0, 1)")));
        }
        rows.push(IndexRow {
            solve: int(1)?,
            step: int(2)?,
            t: num(3)?,
            newton_iteration: int(4)?,
            unknowns: int(5)?,
            rtol,
            max_iter: if f[7].is_empty() { None } else { Some(int(7)?) },
            set_up: flag(8)?,
            iterations: int(9)?,
            converged: flag(10)?,
        });
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn file_names_parse_back() {
        assert_eq!(file_name(7, "A.mtx"), "system-00007-A.mtx");
        assert_eq!(parse_name("system-00007-A.mtx"), Some((7, 0)));
        assert_eq!(
            parse_name("system-123456-constraints.csv"),
            Some((123_456, 3))
        );
        assert_eq!(parse_name("system-00007-A.mtx.bak"), None);
        assert_eq!(parse_name("system--A.mtx"), None);
        assert_eq!(parse_name("index.csv"), None);
    }
}
