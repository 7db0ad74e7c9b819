//! The catalogue of bad inputs and faults (docs/RELIABILITY.md): every
//! subcommand of `hookean`, run as a user would, on inputs an adversary
//! would give. Each case states its exit code (2: bad input, 1: a failed
//! run, 0: success) and a fragment of its message, runs under a memory cap
//! (`ulimit -v`) and a time limit, and checks that no input file changed
//! and that the outputs are what was promised: nothing on failure, the
//! named files on success.
//!
//! Cases may hold links and an earlier run of their own (`before`): the
//! file-safety cases (`files.rs`) run against a tree of the user's own
//! files and links, and check that nothing in it is deleted, truncated or
//! written through. Races of concurrent runs and signals are in `races.rs`.

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
pub(crate) const SPD: &str =
    "%%MatrixMarket matrix coordinate real symmetric\n3 3 5\n1 1 4\n2 1 1\n2 2 3\n3 2 -1\n3 3 2\n";
/// A right-hand side for [`SPD`].
pub(crate) const RHS3: &str = "%%MatrixMarket matrix array real general\n3 1\n1\n2\n3\n";

/// A small, quick cloth scene.
pub(crate) const CLOTH: &str =
    "duration = 0.05\n[cloth]\nn = 6\n[output]\nframe_rate = 0.0\nwidth = 8\nheight = 8\n";

/// One case of the catalogue.
pub(crate) struct Case {
    /// What is wrong (or right) with the input.
    name: &'static str,
    /// Input files written into the case's folder before the run.
    files: &'static [(&'static str, &'static str)],
    /// Symbolic links `(link, target)` made last (`{}` in the target is
    /// the case's folder).
    links: &'static [(&'static str, &'static str)],
    /// Commands run after the files and before the links (each must exit
    /// 0): `hookean` arguments (an earlier run whose output the case may
    /// replace), `fails` and `hookean` arguments (an earlier command that
    /// must fail with exit 1: a failed run's partial output), or `!` and a
    /// plain command (`rm`, `mkfifo`, `sh -c ...`). What they leave counts
    /// as the user's input unless `replaces` names it.
    before: &'static [&'static [&'static str]],
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
    /// Folders (relative) whose earlier hookean output the case may replace.
    replaces: &'static [&'static str],
    /// Environment variables of the command (`RAYON_NUM_THREADS`).
    env: &'static [(&'static str, &'static str)],
}

pub(crate) const fn case(
    name: &'static str,
    files: &'static [(&'static str, &'static str)],
    args: &'static [&'static str],
    exit: i32,
    says: &'static str,
) -> Case {
    Case {
        name,
        files,
        links: &[],
        before: &[],
        args,
        exit,
        says,
        creates: &[],
        absent: &[],
        replaces: &[],
        env: &[],
    }
}

impl Case {
    pub(crate) const fn creates(mut self, paths: &'static [&'static str]) -> Self {
        self.creates = paths;
        self
    }
    pub(crate) const fn absent(mut self, paths: &'static [&'static str]) -> Self {
        self.absent = paths;
        self
    }
    pub(crate) const fn links(mut self, links: &'static [(&'static str, &'static str)]) -> Self {
        self.links = links;
        self
    }
    pub(crate) const fn before(mut self, commands: &'static [&'static [&'static str]]) -> Self {
        self.before = commands;
        self
    }
    pub(crate) const fn replaces(mut self, folders: &'static [&'static str]) -> Self {
        self.replaces = folders;
        self
    }
    pub(crate) const fn env(mut self, vars: &'static [(&'static str, &'static str)]) -> Self {
        self.env = vars;
        self
    }
}

mod bounds;
mod commands;
mod contact;
mod files;
mod fuzz;
mod messages;
mod races;
mod run;
mod solve;

use commands::*;
use run::RUN;
use solve::SOLVE;

/// The shipped repository file `path`.
pub(crate) fn repo(path: &str) -> String {
    let p: PathBuf = [env!("CARGO_MANIFEST_DIR"), path].iter().collect();
    p.to_string_lossy().into_owned()
}

/// What a path holds, for comparing trees without following links.
#[derive(Debug, PartialEq)]
enum Entry {
    File(Vec<u8>),
    Link(PathBuf),
    Dir,
    /// A FIFO or a device (never read: a FIFO would block).
    Special,
}

/// Every entry under `dir` (links recorded, not followed).
pub(crate) fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Entry> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let p = entry.unwrap().path();
            let meta = std::fs::symlink_metadata(&p).unwrap();
            if meta.file_type().is_symlink() {
                out.insert(p.clone(), Entry::Link(std::fs::read_link(&p).unwrap()));
            } else if meta.is_dir() {
                out.insert(p.clone(), Entry::Dir);
                stack.push(p);
            } else if meta.is_file() {
                out.insert(p.clone(), Entry::File(std::fs::read(&p).unwrap()));
            } else {
                out.insert(p.clone(), Entry::Special);
            }
        }
    }
    out
}

/// The `hookean` command under the catalogue's memory cap, in `dir`.
pub(crate) fn hookean(dir: &Path, args: &[String]) -> Command {
    let mut cmd = Command::new("sh");
    cmd.arg("-c")
        .arg(format!("ulimit -v {MEMORY_CAP_KIB} && exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_hookean-suite-cli"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    cmd
}

/// `args` with `{}` replaced by `dir` and `@path` by the repository's file.
pub(crate) fn expand(args: &[&str], dir: &Path) -> Vec<String> {
    let d = dir.to_string_lossy().into_owned();
    args.iter()
        .map(|a| match a.strip_prefix('@') {
            Some(path) => repo(path),
            None => a.replace("{}", &d),
        })
        .collect()
}

/// A fresh folder for one case.
pub(crate) fn case_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hookean-catalogue-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Whether `text` names one of hookean's hidden staging, aside or
/// temporary entries (`.NAME.hookean-partial-PID-K`, `-old-`, `-tmp-`).
pub(crate) fn names_hidden_entry(text: &str) -> bool {
    ["hookean-partial-", "hookean-old-", "hookean-tmp-"]
        .iter()
        .any(|t| text.contains(t))
}

/// Whether `text` holds a number of 20 or more digits in a row that the
/// user did not write in `given` (messages print numbers short: `1e300`,
/// never 300 digits; quoting the user's own input is fine).
pub(crate) fn has_long_number(text: &str, given: &[&str]) -> bool {
    text.split(|c: char| !c.is_ascii_digit())
        .any(|run| run.len() >= 20 && !given.iter().any(|g| g.contains(run)))
}

/// Hidden staging, aside or temporary entries hookean left under `dir`.
pub(crate) fn leftovers(dir: &Path) -> Vec<PathBuf> {
    snapshot(dir)
        .into_keys()
        .filter(|p| {
            p.file_name()
                .is_some_and(|n| names_hidden_entry(&n.to_string_lossy()))
        })
        .collect()
}

/// Runs one case in its own folder; returns what went wrong, if anything.
fn check(index: usize, c: &Case) -> Result<(), String> {
    let dir = case_dir(&index.to_string());
    for (name, text) in c.files {
        let p = dir.join(name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, text).unwrap();
    }
    for before in c.before {
        // `!` runs a plain command (rm, sh -c ...), anything else `hookean`.
        let (out, code) = match before.split_first() {
            Some((&"!", cmd)) => {
                let cmd = expand(cmd, &dir);
                let out = Command::new(&cmd[0])
                    .args(&cmd[1..])
                    .current_dir(&dir)
                    .output()
                    .unwrap();
                (out, 0)
            }
            Some((&"fails", args)) => (hookean(&dir, &expand(args, &dir)).output().unwrap(), 1),
            _ => (hookean(&dir, &expand(before, &dir)).output().unwrap(), 0),
        };
        if out.status.code() != Some(code) {
            return Err(format!(
                "the command before the case failed: {}",
                String::from_utf8_lossy(&out.stderr)
            ));
        }
    }
    let d = dir.to_string_lossy().into_owned();
    for (link, target) in c.links {
        let p = dir.join(link);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::os::unix::fs::symlink(target.replace("{}", &d), p).unwrap();
    }
    let before = snapshot(&dir);
    let args = expand(c.args, &dir);
    let mut command = hookean(&dir, &args);
    for (k, v) in c.env {
        command.env(k, v);
    }
    let mut child = command.spawn().unwrap();
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
    let given: Vec<&str> = args
        .iter()
        .map(String::as_str)
        .chain(c.files.iter().map(|(_, text)| *text))
        .chain(c.env.iter().map(|(_, v)| *v))
        .collect();
    if has_long_number(&stderr, &given) {
        problems.push("a message prints a number of 20 or more digits".into());
    }
    // Staging folders are never named; none is left behind.
    if names_hidden_entry(&stderr) {
        problems.push("a message names a staging folder".into());
    }
    let left = leftovers(&dir);
    if !left.is_empty() {
        problems.push(format!("left hidden entries behind: {left:?}"));
    }
    let after = snapshot(&dir);
    let replaced = |p: &Path| c.replaces.iter().any(|r| p.starts_with(dir.join(r)));
    for (path, entry) in &before {
        if !replaced(path) && after.get(path) != Some(entry) {
            problems.push(format!("input {} changed or vanished", path.display()));
        }
    }
    for p in c.creates {
        if std::fs::symlink_metadata(dir.join(p)).is_err() {
            problems.push(format!("{p} was not written"));
        }
    }
    for p in c.absent {
        if std::fs::symlink_metadata(dir.join(p)).is_ok() {
            problems.push(format!("{p} was written"));
        }
    }
    // A failed command leaves nothing behind but what it names.
    if c.exit != 0 {
        for path in after.keys().filter(|p| !before.contains_key(*p)) {
            let shown = path.display().to_string();
            if after[path] != Entry::Dir
                && !stderr.contains(&shown)
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
        // Issue 28: output files and folders, bounds, readers, exit codes.
        files::FILES,
        bounds::BOUNDS,
        // Issue 26: contact input.
        contact::CONTACT,
        // Issue 37: readers of non-regular files, corrected reruns.
        files::READERS,
        // Issue 37: refusals in the user's words, the step cap, nullspaces.
        messages::MESSAGES,
    ]
    .iter()
    .flat_map(|cases| cases.iter())
    .collect();
    // 92 cases before issue 28, at least 60 more since.
    assert!(all.len() >= 152, "the catalogue holds {} cases", all.len());
    // Cases are independent (each in its own folder): two at a time.
    let next = std::sync::atomic::AtomicUsize::new(0);
    let failures = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let Some(c) = all.get(i) else { break };
                    if let Err(e) = check(i, c) {
                        failures.lock().unwrap().push(format!("{}: {e}", c.name));
                    }
                }
            });
        }
    });
    let failures = failures.into_inner().unwrap();
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        all.len(),
        failures.join("\n")
    );
}
