//! Preconditioners and SpMV kernels on the reference cloth systems.
//!
//! ```text
//! cargo bench --bench preconditioners                # criterion groups + tables
//! cargo bench --bench preconditioners -- --table-only # just the tables and bars
//! cargo bench --bench preconditioners -- --table-only --bars-only
//! cargo bench --bench preconditioners -- --bandwidth  # kernels against the memory bound
//! cargo bench --bench preconditioners -- --spmv-files A.mtx...  # CSR SpMV on files (JSON lines)
//! ```
//!
//! Criterion groups: SpMV of the symmetric block matrix against sprs and
//! faer on the same matrix; preconditioner setup; full PCG solves (N = 32, 64).
//! Then a table for N in {32, 64, 128} and k in {1e2, 1e4, 1e6}: setup time,
//! solve time and iteration count of every preconditioner (PCG to 1e-8 from
//! zero, best of a few runs), and the two bars of issue 2 measured in this
//! one run: SpMV speed-up over sprs CSR at N = 128, and the cost of one
//! Jacobi-PCG iteration in SpMVs.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{BenchmarkId, Criterion};
use faer::{Accum, MatMut, MatRef, Par};
use hookean_sparse::{
    AnyPreconditioner, CgParams, CgWorkspace, LinearOperator, PrecondKind, Preconditioner,
    PreconditionerSetup, SymBlockMatrix, SymCsrMatrix, pcg,
};
use hookean_testkit::cloth::{ClothSystemParams, cloth_system};

fn system(n: usize, k: f64) -> (SymBlockMatrix, Vec<f64>) {
    cloth_system(&ClothSystemParams {
        n,
        k,
        ..Default::default()
    })
}

/// Best wall time of `f` over `reps` runs (after one warm-up).
fn best_of(reps: usize, mut f: impl FnMut()) -> f64 {
    f();
    (0..reps)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

fn sprs_spmv(a: &sprs::CsMat<f64>, x: &[f64], y: &mut [f64]) {
    y.fill(0.0);
    sprs::prod::mul_acc_mat_vec_csr(a.view(), x, &mut y[..]);
}

fn faer_spmv(a: &faer::sparse::SparseColMat<usize, f64>, x: &[f64], y: &mut [f64]) {
    let n = x.len();
    faer::sparse::linalg::matmul::sparse_dense_matmul(
        MatMut::from_column_major_slice_mut(y, n, 1),
        Accum::Replace,
        a.as_ref(),
        MatRef::from_column_major_slice(x, n, 1),
        1.0,
        Par::Seq,
    );
}

fn criterion_groups(c: &mut Criterion) {
    let mut g = c.benchmark_group("spmv");
    g.sample_size(30).measurement_time(Duration::from_secs(2));
    for n in [32, 64, 128] {
        let (a, b) = system(n, 1e4);
        let csr = a.to_csr();
        let fa = a.to_faer();
        let mut y = vec![0.0; b.len()];
        g.bench_with_input(BenchmarkId::new("sym-block", n), &n, |bench, _| {
            bench.iter(|| a.apply(black_box(&b), &mut y))
        });
        g.bench_with_input(BenchmarkId::new("sprs-csr", n), &n, |bench, _| {
            bench.iter(|| sprs_spmv(&csr, black_box(&b), &mut y))
        });
        g.bench_with_input(BenchmarkId::new("faer-csc", n), &n, |bench, _| {
            bench.iter(|| faer_spmv(&fa, black_box(&b), &mut y))
        });
    }
    g.finish();

    let mut g = c.benchmark_group("precond-setup");
    g.sample_size(10).measurement_time(Duration::from_secs(2));
    for n in [64, 128] {
        let (a, _) = system(n, 1e4);
        for kind in kinds() {
            g.bench_with_input(BenchmarkId::new(kind.name(), n), &n, |bench, _| {
                let mut p = AnyPreconditioner::new(kind).unwrap();
                bench.iter(|| p.setup(&a).unwrap())
            });
        }
    }
    g.finish();

    let mut g = c.benchmark_group("pcg-solve");
    g.sample_size(10).measurement_time(Duration::from_secs(3));
    for n in [32, 64] {
        let (a, b) = system(n, 1e4);
        let mut ws = CgWorkspace::new(b.len());
        let mut x = vec![0.0; b.len()];
        for kind in kinds() {
            let mut p = AnyPreconditioner::new(kind).unwrap();
            p.setup(&a).unwrap();
            g.bench_with_input(BenchmarkId::new(kind.name(), n), &n, |bench, _| {
                bench.iter(|| pcg(&a, &p, &b, &mut x, &CgParams::default(), &mut ws, None).unwrap())
            });
        }
    }
    g.finish();
}

/// Every preconditioner: the six of `PrecondKind::all` (AMG included) and MIC(0).
fn kinds() -> Vec<PrecondKind> {
    let mut kinds = PrecondKind::all(1.0).to_vec();
    kinds.push(PrecondKind::Mic0 {
        omega: PrecondKind::MIC_OMEGA,
    });
    kinds
}

fn table() {
    println!(
        "\n## PCG to |r|/|b| <= 1e-8 from x = 0 on the implicit-Euler cloth system (h = 0.01)\n"
    );
    println!("| N | k | precond | iterations | setup (ms) | solve (ms) | total (ms) |");
    println!("|---|---|---|---|---|---|---|");
    for n in [32, 64, 128] {
        for k in [1e2, 1e4, 1e6] {
            let (a, b) = system(n, k);
            let mut ws = CgWorkspace::new(b.len());
            let mut x = vec![0.0; b.len()];
            for kind in kinds() {
                let reps = if n == 128 { 1 } else { 3 };
                let mut p = AnyPreconditioner::new(kind).unwrap();
                let setup = best_of(reps, || {
                    p = AnyPreconditioner::new(kind).unwrap();
                    p.setup(&a).unwrap();
                });
                let params = CgParams {
                    max_iter: Some(20_000),
                    ..Default::default()
                };
                let mut iterations = 0;
                let mut converged = true;
                let solve = best_of(reps, || {
                    let info = pcg(&a, &p, &b, &mut x, &params, &mut ws, None).unwrap();
                    iterations = info.iterations;
                    converged = info.converged;
                });
                let mark = if converged { "" } else { " (not converged)" };
                println!(
                    "| {n} | {k:.0e} | {} | {iterations}{mark} | {:.3} | {:.2} | {:.2} |",
                    kind.name(),
                    setup * 1e3,
                    solve * 1e3,
                    (setup + solve) * 1e3
                );
            }
        }
    }
}

fn bars() {
    let n = 128;
    let (a, b) = system(n, 1e4);
    let csr = a.to_csr();
    let fa = a.to_faer();
    let mut y = vec![0.0; b.len()];
    let mut jacobi = AnyPreconditioner::new(PrecondKind::Jacobi).unwrap();
    jacobi.setup(&a).unwrap();
    let mut mic = AnyPreconditioner::new(PrecondKind::Mic0 {
        omega: PrecondKind::MIC_OMEGA,
    })
    .unwrap();
    mic.setup(&a).unwrap();
    let mut z = vec![0.0; b.len()];
    let mut ws = CgWorkspace::new(b.len());
    let mut x = vec![0.0; b.len()];
    let iters = 50;
    let mut pcg_run = |max: usize| {
        let params = CgParams {
            rtol: 0.0,
            max_iter: Some(max),
            ..Default::default()
        };
        pcg(&a, &jacobi, &b, &mut x, &params, &mut ws, None).unwrap();
    };
    // Interleave the kernels round by round and keep each one's best time,
    // so that a noisy neighbour on the machine affects all of them alike.
    let rounds = 40;
    let (mut t_block, mut t_sprs, mut t_faer, mut t_long, mut t_short, mut t_mic) = (
        f64::INFINITY,
        f64::INFINITY,
        f64::INFINITY,
        f64::INFINITY,
        f64::INFINITY,
        f64::INFINITY,
    );
    let time = |f: &mut dyn FnMut()| {
        let t = Instant::now();
        f();
        t.elapsed().as_secs_f64()
    };
    for _ in 0..rounds {
        // Each kernel is timed right after an untimed call of itself, so it
        // runs with its data as warm as inside an iteration, whatever ran before.
        a.apply(black_box(&b), &mut y);
        t_block = t_block.min(time(&mut || a.apply(black_box(&b), &mut y)));
        t_sprs = t_sprs.min(time(&mut || sprs_spmv(&csr, black_box(&b), &mut y)));
        t_faer = t_faer.min(time(&mut || faer_spmv(&fa, black_box(&b), &mut y)));
        t_long = t_long.min(time(&mut || pcg_run(iters)));
        t_short = t_short.min(time(&mut || pcg_run(0)));
        mic.apply(black_box(&b), &mut z);
        t_mic = t_mic.min(time(&mut || mic.apply(black_box(&b), &mut z)));
    }
    // One Jacobi-PCG iteration: (time of `iters` iterations - start-up) / iters.
    let t_iter = (t_long - t_short) / iters as f64;
    println!("\n## Bars (N = {n}, k = 1e4, one thread, best of {rounds} interleaved rounds)\n");
    println!("| kernel | time (ms) | ratio to sym-block SpMV |");
    println!("|---|---|---|");
    println!("| SpMV sym-block 3x3 | {:.3} | 1.00 |", t_block * 1e3);
    println!(
        "| SpMV sprs CSR | {:.3} | {:.2} |",
        t_sprs * 1e3,
        t_sprs / t_block
    );
    println!(
        "| SpMV faer CSC | {:.3} | {:.2} |",
        t_faer * 1e3,
        t_faer / t_block
    );
    println!(
        "| one Jacobi-PCG iteration | {:.3} | {:.2} |",
        t_iter * 1e3,
        t_iter / t_block
    );
    println!(
        "| one MIC(0) application (block factor) | {:.3} | {:.2} |",
        t_mic * 1e3,
        t_mic / t_block
    );
    let spmv_ok = t_sprs / t_block >= 2.0;
    let iter_ok = t_iter / t_block <= 1.5;
    println!(
        "\nbar: SpMV >= 2x faster than sprs CSR: {} ({:.2}x)",
        if spmv_ok { "met" } else { "MISSED" },
        t_sprs / t_block
    );
    println!(
        "bar: one Jacobi-PCG iteration <= 1.5 SpMV: {} ({:.2} SpMV)",
        if iter_ok { "met" } else { "MISSED" },
        t_iter / t_block
    );
}

/// Bytes one symmetric block SpMV streams: every stored block (72 bytes of
/// values, a 4-byte column index), the row pointers, `x` read and `y`
/// written (the transposed index of the threaded kernel adds 8 bytes per
/// off-diagonal block; counted).
fn spmv_bytes(a: &SymBlockMatrix) -> f64 {
    let blocks = a.pattern().stored_blocks() as f64;
    let n = a.n_blocks() as f64;
    blocks * 76.0 + (blocks - n) * 8.0 + n * 8.0 + 2.0 * a.dim() as f64 * 8.0
}

/// STREAM's triad `a = b + s c` on vectors of `len` doubles in the current
/// rayon pool (fixed chunks), best of `reps`: GB/s counting 24 bytes per
/// entry as STREAM does.
fn triad_gbs(len: usize, reps: usize) -> f64 {
    use rayon::prelude::*;
    let mut a = vec![0.0f64; len];
    let b = vec![1.0f64; len];
    let c = vec![2.0f64; len];
    let chunk = len.div_ceil(rayon::current_num_threads()).max(1);
    let t = best_of(reps, || {
        a.par_chunks_mut(chunk)
            .zip(b.par_chunks(chunk))
            .zip(c.par_chunks(chunk))
            .for_each(|((a, b), c)| {
                for i in 0..a.len() {
                    a[i] = b[i] + 3.0 * c[i];
                }
            });
        black_box(&mut a);
    });
    24.0 * len as f64 / t / 1e9
}

/// How far the SpMV and the MIC(0) application are from the machine's
/// memory bandwidth: STREAM triad on 2 MiB (L2), 24 MiB (L3) and 768 MiB
/// (DRAM) of vectors, then the kernels' effective bandwidth (bytes they must
/// stream / time) at N = 64, 128, 256, in the current pool (run with
/// `RAYON_NUM_THREADS=1` and `=2`).
fn bandwidth() {
    let threads = rayon::current_num_threads();
    println!("\n## Memory bandwidth, {threads} thread(s)\n");
    println!("| what | working set (MiB) | GB/s |");
    println!("|---|---|---|");
    for (mib, reps) in [(2usize, 2000), (24, 200), (768, 10)] {
        let len = mib * (1 << 20) / 24;
        println!("| STREAM triad | {mib} | {:.1} |", triad_gbs(len, reps));
    }
    for n in [64usize, 128, 256] {
        let (a, b) = system(n, 1e4);
        let mut y = vec![0.0; b.len()];
        let bytes = spmv_bytes(&a);
        let row = |what: &str, bytes: f64, t: f64| {
            println!(
                "| {what}, N = {n} | {:.1} | {:.1} ({:.3} ms) |",
                bytes / (1 << 20) as f64,
                bytes / t / 1e9,
                t * 1e3
            );
        };
        row(
            "SpMV",
            bytes,
            best_of(50, || a.apply(black_box(&b), &mut y)),
        );
        let mut mic = AnyPreconditioner::new(PrecondKind::Mic0 { omega: 0.99 }).unwrap();
        mic.setup(&a).unwrap();
        // Forward and backward sweeps each stream the factor (the matrix's
        // layout) and read r or write z.
        let t = best_of(50, || mic.apply(black_box(&b), &mut y));
        row("MIC(0) apply", 2.0 * bytes, t);
        // The V-cycle (f32 levels, block-Jacobi) reads every operator but
        // the coarsest twice (the residual before restriction and after the
        // correction; the smoothing passes need only the inverted diagonal):
        // 4-byte entries and a 4-byte column per 3x3 block. P, R, the
        // diagonal blocks and the vectors are left out, so these bytes (and
        // the GB/s) are a lower bound.
        let mut amg = hookean_sparse::Amg::with_options(Default::default()).unwrap();
        amg.setup(&a).unwrap();
        let t = best_of(50, || amg.apply(black_box(&b), &mut y));
        let levels = &amg.stats().levels;
        let ops: f64 = levels[..levels.len() - 1]
            .iter()
            .map(|l| l.nonzeros as f64 * (4.0 + 4.0 / 9.0))
            .sum();
        row("AMG V-cycle (f32)", 2.0 * ops, t);
    }
}

/// `--spmv-files A.mtx...`: the CSR SpMV on each file, best of about a second
/// of runs, two kernels: the product `hookean solve --format csr` runs (the
/// symmetric [`SymCsrMatrix`]: diagonal, upper triangle, `u32` indices) and the
/// [`LinearOperator`] of the full `sprs::CsMat` (8-byte indices); each with
/// two STREAM triads in the current pool (`RAYON_NUM_THREADS=1` for one
/// thread): on vectors as large as the bytes the kernel must stream (values
/// and indices, row pointers, the diagonal, `x` read, `y` written; in L3 for
/// a matrix that fits), and on three vectors of 128 MiB each, four times the
/// 32 MiB L3 as STREAM asks (DRAM, the memory-bandwidth bound). One JSON line
/// per file and kernel, for scripts/peers/compare.sh (issue 29).
fn spmv_files(paths: &[String]) {
    let dram = triad_gbs((128 << 20) / 8, 20);
    for path in paths {
        let a = match hookean_sparse::read_matrix_market_file(path) {
            Ok(m) => m.into_csr(),
            Err(e) => {
                eprintln!("{path}: {e}");
                std::process::exit(2);
            }
        };
        let (n, nnz) = (a.rows(), a.nnz());
        let x = vec![1.0; n];
        let mut y = vec![0.0; n];
        let word = std::mem::size_of::<usize>() as f64;
        let mut report = |tool: &str, index_bytes: f64, bytes: f64, op: &dyn LinearOperator| {
            let once = best_of(1, || op.apply(black_box(&x), &mut y));
            let reps = ((1.0 / once) as usize).clamp(10, 100_000);
            let t = best_of(reps, || op.apply(black_box(&x), &mut y));
            let len = (bytes / 24.0) as usize;
            let triad = triad_gbs(len.max(1024), reps.min(1000));
            println!(
                "{{\"kind\":\"spmv\",\"matrix\":\"{path}\",\"tool\":\"{tool}\",\"index_bytes\":{index_bytes},\"rows\":{n},\"nnz\":{nnz},\"spmv_s\":{t:.6e},\"bytes\":{bytes:.0},\"triad_gbs\":{triad:.2},\"dram_triad_gbs\":{dram:.2},\"check\":{:.6e}}}",
                y.iter().sum::<f64>()
            );
        };
        if let Ok(s) = SymCsrMatrix::from_csr(&a) {
            let m = (s.stored() - n) as f64;
            // u32 columns and row pointers; the diagonal, x and y.
            let bytes = m * 12.0 + (n + 1) as f64 * 4.0 + 24.0 * n as f64;
            report("hookean symmetric CSR", 4.0, bytes, &s);
        }
        let bytes = nnz as f64 * (8.0 + word) + (n + 1) as f64 * word + 16.0 * n as f64;
        report("hookean CSR", word, bytes, &a);
    }
}

fn main() {
    if std::env::args().any(|a| a == "--bandwidth") {
        bandwidth();
        return;
    }
    let args: Vec<String> = std::env::args().collect();
    if let Some(i) = args.iter().position(|a| a == "--spmv-files") {
        // (cargo bench appends `--bench`)
        let files: Vec<String> = args[i + 1..]
            .iter()
            .filter(|a| !a.starts_with("--"))
            .cloned()
            .collect();
        spmv_files(&files);
        return;
    }
    let table_only = std::env::args().any(|a| a == "--table-only");
    if !table_only {
        let mut c = Criterion::default().configure_from_args();
        criterion_groups(&mut c);
        c.final_summary();
    }
    bars();
    if !std::env::args().any(|a| a == "--bars-only") {
        table();
    }
}
