// amgcl_solve: AMGCL (smoothed aggregation + CG) on a Matrix Market system,
// for the peer comparisons of docs/perf/amgcl-peer.md and of issue 29
// (docs/PERFORMANCE.md). Built and run by scripts/amgcl-compare.sh and
// scripts/peers/compare.sh against AMGCL's headers, which those scripts
// clone at run time (nothing of AMGCL is in this repository). AMGCL 1.4.x,
// header-only, compiled with AMGCL_NO_BOOST (no Boost needed).
//
//   amgcl_solve A.mtx b.mtx --value block3|scalar --relax spai0|damped_jacobi|ilu0|chebyshev[,...]
//               [--rtol 1e-8] [--repeat 3] [--label NAME] [--esr POWER_STEPS]
//               [--block-size B] [--nullspace N.mtx] [--eps-strong E]
//
// --value block3: 3x3 block values (amgcl::static_matrix<double,3,3>),
//   the block-valued builtin backend; the near-nullspace is the constant
//   per block (the three translations).
// --value scalar: scalar values with aggregation on B x B point blocks
//   (coarsening.aggr.block_size = B, default 3); with --nullspace, the
//   columns of N.mtx (a dense Matrix Market array, one column per mode, e.g.
//   the rigid-body modes) are the near-nullspace (coarsening.nullspace);
//   without, the constant per unknown of a block.
// --eps-strong E: the aggregation's strength threshold (AMGCL's default 0.08).
// --esr S: smooth the prolongator with omega = (4/3) / rho(D^-1 A), rho from
//   S power steps (AMGCL's estimate_spectral_radius; default off: omega = 2/3).
// --relax takes a comma-separated list (run in that order, in one process).
// Every repeat builds a fresh hierarchy (set-up) and solves from x = 0 with
// CG to |b - A x| <= rtol |b|. One JSON line per repeat on stdout: set-up
// and solve seconds (steady_clock), iterations, AMGCL's residual and the
// true relative residual |b - A x| / |b| recomputed here in double from the
// file's matrix.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <tuple>

#include <omp.h>

#include <amgcl/adapter/block_matrix.hpp>
#include <amgcl/adapter/crs_tuple.hpp>
#include <amgcl/amg.hpp>
#include <amgcl/backend/builtin.hpp>
#include <amgcl/coarsening/smoothed_aggregation.hpp>
#include <amgcl/io/mm.hpp>
#include <amgcl/make_solver.hpp>
#include <amgcl/relaxation/chebyshev.hpp>
#include <amgcl/relaxation/damped_jacobi.hpp>
#include <amgcl/relaxation/ilu0.hpp>
#include <amgcl/relaxation/spai0.hpp>
#include <amgcl/solver/cg.hpp>
#include <amgcl/value_type/static_matrix.hpp>

struct Csr {
    size_t n = 0;
    std::vector<ptrdiff_t> ptr, col;
    std::vector<double> val;
};

static double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// |b - A x| / |b| in double.
static double true_rel_residual(const Csr &a, const std::vector<double> &b,
                                const std::vector<double> &x) {
    double rr = 0, bb = 0;
    for (size_t i = 0; i < a.n; ++i) {
        double s = b[i];
        for (ptrdiff_t j = a.ptr[i]; j < a.ptr[i + 1]; ++j) s -= a.val[j] * x[a.col[j]];
        rr += s * s;
        bb += b[i] * b[i];
    }
    return std::sqrt(rr / bb);
}

struct Result {
    double setup_s, solve_s, amgcl_resid, rel_residual;
    size_t iterations, levels;
    double op_complexity;
};

static void parse_hierarchy(const std::string &text, size_t &levels, double &opc) {
    levels = 0;
    opc = 0;
    std::istringstream is(text);
    std::string line;
    while (std::getline(is, line)) {
        if (line.rfind("Number of levels:", 0) == 0) levels = std::stoul(line.substr(17));
        if (line.rfind("Operator complexity:", 0) == 0) opc = std::stod(line.substr(20));
    }
}

template <template <class> class Relax>
static Result run_block3(const Csr &a, const std::vector<double> &b, double rtol, int esr) {
    typedef amgcl::static_matrix<double, 3, 3> dmat;
    typedef amgcl::static_matrix<double, 3, 1> dvec;
    typedef amgcl::backend::builtin<dmat> Backend;
    typedef amgcl::make_solver<
        amgcl::amg<Backend, amgcl::coarsening::smoothed_aggregation, Relax>,
        amgcl::solver::cg<Backend> > Solver;
    typename Solver::params prm;
    prm.solver.tol = rtol;
    prm.solver.maxiter = 1000;
    if (esr > 0) {
        prm.precond.coarsening.estimate_spectral_radius = true;
        prm.precond.coarsening.power_iters = esr;
    }
    Result r;
    auto t0 = std::chrono::steady_clock::now();
    auto A = std::tie(a.n, a.ptr, a.col, a.val);
    Solver solve(amgcl::adapter::block_matrix<dmat>(A), prm);
    r.setup_s = seconds_since(t0);
    size_t nb = a.n / 3;
    std::vector<dvec> f(nb), x(nb);
    for (size_t i = 0; i < nb; ++i)
        for (int c = 0; c < 3; ++c) {
            f[i](c, 0) = b[3 * i + c];
            x[i](c, 0) = 0.0;
        }
    t0 = std::chrono::steady_clock::now();
    std::tuple<size_t, double> it = solve(f, x);
    r.solve_s = seconds_since(t0);
    r.iterations = std::get<0>(it);
    r.amgcl_resid = std::get<1>(it);
    std::vector<double> xs(a.n);
    for (size_t i = 0; i < nb; ++i)
        for (int c = 0; c < 3; ++c) xs[3 * i + c] = x[i](c, 0);
    r.rel_residual = true_rel_residual(a, b, xs);
    std::ostringstream os;
    os << solve.precond();
    parse_hierarchy(os.str(), r.levels, r.op_complexity);
    if (std::getenv("AMGCL_SOLVE_VERBOSE")) std::cerr << os.str() << "\n";
    return r;
}

// The aggregation of --value scalar: unknowns per block, the near-nullspace
// (row-major, `modes` columns; none when 0), the strength threshold (< 0: AMGCL's).
struct Aggregation {
    int block_size = 3;
    std::vector<double> nullspace;
    int modes = 0;
    double eps_strong = -1;
};

template <template <class> class Relax>
static Result run_scalar(const Csr &a, const std::vector<double> &b, double rtol, int esr,
                         const Aggregation &ag) {
    typedef amgcl::backend::builtin<double> Backend;
    typedef amgcl::make_solver<
        amgcl::amg<Backend, amgcl::coarsening::smoothed_aggregation, Relax>,
        amgcl::solver::cg<Backend> > Solver;
    typename Solver::params prm;
    prm.solver.tol = rtol;
    prm.solver.maxiter = 1000;
    if (esr > 0) {
        prm.precond.coarsening.estimate_spectral_radius = true;
        prm.precond.coarsening.power_iters = esr;
    }
    prm.precond.coarsening.aggr.block_size = ag.block_size;
    if (ag.eps_strong >= 0) prm.precond.coarsening.aggr.eps_strong = ag.eps_strong;
    if (ag.modes > 0) {
        prm.precond.coarsening.nullspace.cols = ag.modes;
        prm.precond.coarsening.nullspace.B = ag.nullspace;
    }
    Result r;
    auto t0 = std::chrono::steady_clock::now();
    auto A = std::tie(a.n, a.ptr, a.col, a.val);
    Solver solve(A, prm);
    r.setup_s = seconds_since(t0);
    std::vector<double> x(a.n, 0.0);
    t0 = std::chrono::steady_clock::now();
    std::tuple<size_t, double> it = solve(b, x);
    r.solve_s = seconds_since(t0);
    r.iterations = std::get<0>(it);
    r.amgcl_resid = std::get<1>(it);
    r.rel_residual = true_rel_residual(a, b, x);
    std::ostringstream os;
    os << solve.precond();
    parse_hierarchy(os.str(), r.levels, r.op_complexity);
    if (std::getenv("AMGCL_SOLVE_VERBOSE")) std::cerr << os.str() << "\n";
    return r;
}

static int usage() {
    std::cerr << "usage: amgcl_solve A.mtx b.mtx --value block3|scalar "
                 "--relax spai0|damped_jacobi|ilu0|chebyshev[,...] [--rtol 1e-8] [--repeat 3] "
                 "[--label NAME] [--esr POWER_STEPS] [--block-size B] [--nullspace N.mtx] "
                 "[--eps-strong E]\n";
    return 2;
}

int main(int argc, char **argv) {
    if (argc < 3) return usage();
    std::string a_path = argv[1], b_path = argv[2], value = "block3", relax_list = "damped_jacobi",
                label = a_path, nullspace_path;
    double rtol = 1e-8;
    int repeat = 3;
    int esr = 0;
    Aggregation ag;
    for (int i = 3; i + 1 < argc; i += 2) {
        std::string k = argv[i], v = argv[i + 1];
        if (k == "--value") value = v;
        else if (k == "--relax") relax_list = v;
        else if (k == "--rtol") rtol = std::atof(v.c_str());
        else if (k == "--repeat") repeat = std::atoi(v.c_str());
        else if (k == "--label") label = v;
        else if (k == "--esr") esr = std::atoi(v.c_str());
        else if (k == "--block-size") ag.block_size = std::atoi(v.c_str());
        else if (k == "--nullspace") nullspace_path = v;
        else if (k == "--eps-strong") ag.eps_strong = std::atof(v.c_str());
        else return usage();
    }
    const int block_size = ag.block_size;
    if (block_size < 1 || (value == "block3" && (block_size != 3 || !nullspace_path.empty())))
        return usage();
    Csr a;
    std::vector<double> b;
    try {
        amgcl::io::mm_reader ra(a_path);
        if (!ra.is_symmetric()) std::cerr << "note: " << a_path << " is stored general\n";
        size_t rows, cols;
        std::tie(rows, cols) = ra(a.ptr, a.col, a.val);
        a.n = rows;
        amgcl::io::mm_reader rb(b_path);
        size_t brows, bcols;
        std::tie(brows, bcols) = rb(b);
        if (rows != cols || brows != rows || bcols != 1 || rows % block_size != 0) {
            std::cerr << "error: " << a_path << " is " << rows << "x" << cols << ", " << b_path
                      << " is " << brows << "x" << bcols << " (need a square matrix with "
                      << block_size << "k rows and a matching column)\n";
            return 2;
        }
        if (!nullspace_path.empty()) {
            amgcl::io::mm_reader rn(nullspace_path);
            size_t nrows, ncols;
            std::tie(nrows, ncols) = rn(ag.nullspace);  // row-major, as AMGCL wants it
            if (nrows != rows || ncols == 0) {
                std::cerr << "error: " << nullspace_path << " is " << nrows << "x" << ncols
                          << " (need " << rows << " rows)\n";
                return 2;
            }
            ag.modes = int(ncols);
        }
        // The reader keeps the file's order within a row; sort each row by
        // column (the builtin backend and the block adapter expect it).
        for (size_t i = 0; i < a.n; ++i) {
            std::vector<std::pair<ptrdiff_t, double>> row;
            for (ptrdiff_t j = a.ptr[i]; j < a.ptr[i + 1]; ++j) row.emplace_back(a.col[j], a.val[j]);
            std::sort(row.begin(), row.end(),
                      [](const std::pair<ptrdiff_t, double> &p, const std::pair<ptrdiff_t, double> &q) {
                          return p.first < q.first;
                      });
            for (size_t j = 0; j < row.size(); ++j) {
                a.col[a.ptr[i] + j] = row[j].first;
                a.val[a.ptr[i] + j] = row[j].second;
            }
        }
    } catch (const std::exception &e) {
        std::cerr << "error: reading " << a_path << " / " << b_path << ": " << e.what() << "\n";
        return 2;
    }
    bool failed = false;
    std::vector<std::string> relaxes;
    {
        std::istringstream is(relax_list);
        std::string item;
        while (std::getline(is, item, ',')) relaxes.push_back(item);
    }
    for (int rep = 0; rep < repeat; ++rep) for (const std::string &relax : relaxes) {
        Result r;
        try {
            if (value == "block3") {
                if (relax == "spai0") r = run_block3<amgcl::relaxation::spai0>(a, b, rtol, esr);
                else if (relax == "damped_jacobi") r = run_block3<amgcl::relaxation::damped_jacobi>(a, b, rtol, esr);
                else if (relax == "ilu0") r = run_block3<amgcl::relaxation::ilu0>(a, b, rtol, esr);
                else if (relax == "chebyshev") r = run_block3<amgcl::relaxation::chebyshev>(a, b, rtol, esr);
                else return usage();
            } else if (value == "scalar") {
                if (relax == "spai0") r = run_scalar<amgcl::relaxation::spai0>(a, b, rtol, esr, ag);
                else if (relax == "damped_jacobi") r = run_scalar<amgcl::relaxation::damped_jacobi>(a, b, rtol, esr, ag);
                else if (relax == "ilu0") r = run_scalar<amgcl::relaxation::ilu0>(a, b, rtol, esr, ag);
                else if (relax == "chebyshev") r = run_scalar<amgcl::relaxation::chebyshev>(a, b, rtol, esr, ag);
                else return usage();
            } else {
                return usage();
            }
        } catch (const std::exception &e) {
            std::cerr << "error: AMGCL failed on " << a_path << ": " << e.what() << "\n";
            return 1;
        }
        failed |= !(r.rel_residual <= 10 * rtol);
        std::printf("{\"matrix\":\"%s\",\"solver\":\"amgcl\",\"value\":\"%s\",\"relax\":\"%s\","
                    "\"threads\":%d,\"rows\":%zu,\"nnz\":%td,\"iterations\":%zu,\"setup_s\":%.6f,"
                    "\"solve_s\":%.6f,\"amgcl_resid\":%.3e,\"rel_residual\":%.3e,\"levels\":%zu,"
                    "\"operator_complexity\":%.2f,\"esr\":%d,\"block_size\":%d,\"nullspace_cols\":%d,"
                    "\"converged\":%s}\n",
                    label.c_str(), value.c_str(), relax.c_str(), omp_get_max_threads(), a.n,
                    a.ptr[a.n], r.iterations, r.setup_s, r.solve_s, r.amgcl_resid,
                    r.rel_residual, r.levels, r.op_complexity, esr, block_size, ag.modes,
                    r.amgcl_resid <= rtol ? "true" : "false");
        std::fflush(stdout);
    }
    return failed ? 1 : 0;
}
