// eigen_pcg: Eigen 3.4's ConjugateGradient with its Jacobi (DiagonalPreconditioner)
// and incomplete Cholesky (IncompleteCholesky) preconditioners, and with an SSOR
// preconditioner written here (Eigen has none), on a Matrix Market system; and the
// CSR SpMV alone next to a STREAM-like triad. Built and run by
// scripts/peers/compare.sh (issue 29); one thread (no OpenMP).
//
//   eigen_pcg A.mtx b.mtx --precond jacobi,ic,ic-natural,ssor,none [--rtol 1e-8]
//             [--max-iter N] [--omega 1] [--uplo lower|full] [--label NAME]
//   eigen_pcg A.mtx --spmv SECONDS [--label NAME]
//
// A symmetric file (one triangle stored) is expanded to both triangles; the matrix
// is SparseMatrix<double, RowMajor, int> (CSR, 4-byte indices). CG's products:
// --uplo lower (default, Eigen's default UpLo = Lower) the symmetric product on the
// lower triangle, which reads half the matrix (the faster on one thread here:
// Jacobi-PCG 3-20% faster than full on poisson3d, elasticity2d, bar3d-p1);
// --uplo full (UpLo = Lower|Upper) plain CSR products. From x = 0 to |b - A x| <= rtol |b|
// (Eigen's test, on its recurrence residual), at most N iterations (default 2n, as
// `hookean solve`). Preconditioners:
//   jacobi      DiagonalPreconditioner
//   ic          IncompleteCholesky<double, Lower, AMDOrdering<int>> (Eigen's default:
//               Lin-More's IC with the column counts of A, AMD ordering, diagonal scaling)
//   ic-natural  the same with NaturalOrdering (the pattern closest to IC(0) in the file's order)
//   ssor        M = (D + w L) D^-1 (D + w L^T) / (w (2 - w)), A = L + D + L^T, applied as a
//               forward and a backward sweep with Eigen's sparse triangular solves
//   none        IdentityPreconditioner
// One JSON line per preconditioner on stdout: set-up (cg.compute: the preconditioner)
// and solve seconds (steady_clock), iterations and the true |b - A x| / |b|. The
// iterations are CG's products with A, as the other tools count them: Eigen's own
// count (`eigen_iterations`) leaves out the one after which the residual passed the
// test (its loop breaks before counting it).
// --spmv S: y = A x repeated for about S seconds, the best time; the triad
// a = b + s c on vectors whose 24 bytes per entry add up to the SpMV's bytes
// (nnz (8 + 4) + 4 (n + 1) + 8 n for x + 8 n for y), best of as many runs.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/Sparse>
#include <unsupported/Eigen/SparseExtra>

typedef Eigen::SparseMatrix<double, Eigen::RowMajor, int> SpMat;
typedef Eigen::VectorXd Vec;

static double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// SSOR with relaxation omega as an Eigen preconditioner (the interface of
// DiagonalPreconditioner): factorize stores D + w L (CSR) and D.
class Ssor {
  public:
    typedef double Scalar;
    typedef int StorageIndex;
    enum { ColsAtCompileTime = Eigen::Dynamic, MaxColsAtCompileTime = Eigen::Dynamic };
    static double omega;

    Ssor() {}
    Eigen::Index rows() const { return diag_.size(); }
    Eigen::Index cols() const { return diag_.size(); }
    template <class M> Ssor &analyzePattern(const M &) { return *this; }
    template <class M> Ssor &factorize(const M &a) {
        lower_ = a.template triangularView<Eigen::Lower>();
        diag_ = lower_.diagonal();
        for (int i = 0; i < lower_.outerSize(); ++i)
            for (SpMat::InnerIterator it(lower_, i); it; ++it)
                if (it.index() != i) it.valueRef() *= omega;
        return *this;
    }
    template <class M> Ssor &compute(const M &a) { return factorize(a); }
    template <class Rhs, class Dest> void _solve_impl(const Rhs &r, Dest &z) const {
        z = r;
        lower_.triangularView<Eigen::Lower>().solveInPlace(z);  // (D + w L) y = r
        z.array() *= diag_.array();                             // D y
        lower_.transpose().triangularView<Eigen::Upper>().solveInPlace(z);  // (D + w L^T) z = D y
        z *= omega * (2.0 - omega);
    }
    template <class Rhs> const Eigen::Solve<Ssor, Rhs> solve(const Eigen::MatrixBase<Rhs> &b) const {
        return Eigen::Solve<Ssor, Rhs>(*this, b.derived());
    }
    Eigen::ComputationInfo info() { return Eigen::Success; }

  private:
    SpMat lower_;
    Vec diag_;
};
double Ssor::omega = 1.0;

struct Result {
    double setup_s = 0, solve_s = 0, rel_residual = NAN;
    long iterations = 0, eigen_iterations = 0;
    bool ok = false;
    std::string error;
};

template <class Precond, int UpLo>
static Result run_uplo(const SpMat &a, const Vec &b, double rtol, long max_iter) {
    Eigen::ConjugateGradient<SpMat, UpLo, Precond> cg;
    cg.setTolerance(rtol);
    cg.setMaxIterations(max_iter);
    Result r;
    auto t0 = std::chrono::steady_clock::now();
    cg.compute(a);
    r.setup_s = seconds_since(t0);
    if (cg.preconditioner().info() != Eigen::Success) {
        r.error = "the preconditioner could not be built";
        return r;
    }
    t0 = std::chrono::steady_clock::now();
    Vec x = cg.solve(b);
    r.solve_s = seconds_since(t0);
    r.eigen_iterations = cg.iterations();
    r.rel_residual = (b - a * x).norm() / b.norm();
    r.ok = cg.info() == Eigen::Success;
    // converged in the loop (not at x = 0): one product more than Eigen counts
    r.iterations = r.eigen_iterations + (r.ok && x.squaredNorm() > 0 ? 1 : 0);
    if (!r.ok) r.error = "no convergence within " + std::to_string(max_iter) + " iterations";
    return r;
}

static bool full_products = false;

template <class Precond>
static Result run(const SpMat &a, const Vec &b, double rtol, long max_iter) {
    return full_products ? run_uplo<Precond, Eigen::Lower | Eigen::Upper>(a, b, rtol, max_iter)
                         : run_uplo<Precond, Eigen::Lower>(a, b, rtol, max_iter);
}

static bool read_matrix(const std::string &path, SpMat &a) {
    int sym = 0;
    bool complex = false, vector = false;
    if (!Eigen::getMarketHeader(path, sym, complex, vector) || complex || vector) return false;
    if (!Eigen::loadMarket(a, path)) return false;
    if (sym != 0) {  // one triangle stored: A + A^T with the diagonal once
        SpMat t = a.transpose();
        SpMat full = a + t;
        for (int i = 0; i < full.outerSize(); ++i)
            for (SpMat::InnerIterator it(full, i); it; ++it)
                if (it.index() == i) it.valueRef() *= 0.5;
        a = full;
    }
    a.makeCompressed();
    return true;
}

// Best time of f over repeats that add up to about `budget` seconds (at least 3).
template <class F> static double best_of(double budget, F f) {
    f();
    double best = 1e300, spent = 0;
    for (int k = 0; k < 3 || spent < budget; ++k) {
        auto t0 = std::chrono::steady_clock::now();
        f();
        double t = seconds_since(t0);
        best = std::min(best, t);
        spent += t;
    }
    return best;
}

static int spmv(const SpMat &a, const std::string &label, double budget) {
    const long n = a.rows(), nnz = a.nonZeros();
    Vec x = Vec::Ones(n), y(n);
    double t = best_of(budget, [&] { y.noalias() = a * x; });
    double bytes = 12.0 * nnz + 4.0 * (n + 1) + 16.0 * n;
    size_t len = std::max<size_t>(1024, size_t(bytes / 24));
    std::vector<double> ta(len, 0.0), tb(len, 1.0), tc(len, 2.0);
    double tt = best_of(budget, [&] {
        for (size_t i = 0; i < len; ++i) ta[i] = tb[i] + 3.0 * tc[i];
        asm volatile("" : : "r"(ta.data()) : "memory");
    });
    std::printf("{\"kind\":\"spmv\",\"matrix\":\"%s\",\"tool\":\"eigen CSR\",\"index_bytes\":4,"
                "\"rows\":%ld,\"nnz\":%ld,\"spmv_s\":%.6e,\"bytes\":%.0f,\"triad_gbs\":%.2f,\"check\":%.6e}\n",
                label.c_str(), n, nnz, t, bytes, 24.0 * len / tt / 1e9, y.sum());
    return 0;
}

static int usage() {
    std::cerr << "usage: eigen_pcg A.mtx b.mtx --precond jacobi,ic,ic-natural,ssor,none [--rtol R] "
                 "[--max-iter N] [--omega W] [--uplo lower|full] [--label NAME]\n"
                 "       eigen_pcg A.mtx --spmv SECONDS [--label NAME]\n";
    return 2;
}

int main(int argc, char **argv) {
    if (argc < 3) return usage();
    std::string a_path = argv[1], b_path, precond_list = "jacobi,ic,ssor", label = a_path;
    double rtol = 1e-8, spmv_budget = -1;
    long max_iter = -1;
    int first = 2;
    if (std::string(argv[2]).rfind("--", 0) != 0) b_path = argv[first++];
    for (int i = first; i + 1 < argc; i += 2) {
        std::string k = argv[i], v = argv[i + 1];
        if (k == "--precond") precond_list = v;
        else if (k == "--rtol") rtol = std::atof(v.c_str());
        else if (k == "--max-iter") max_iter = std::atol(v.c_str());
        else if (k == "--omega") Ssor::omega = std::atof(v.c_str());
        else if (k == "--label") label = v;
        else if (k == "--spmv") spmv_budget = std::atof(v.c_str());
        else if (k == "--uplo" && (v == "lower" || v == "full")) full_products = v == "full";
        else return usage();
    }
    if ((argc - first) % 2 != 0 || !(Ssor::omega > 0 && Ssor::omega < 2)) return usage();
    SpMat a;
    if (!read_matrix(a_path, a) || a.rows() != a.cols() || a.rows() == 0) {
        std::cerr << "error: " << a_path << ": not a square real sparse Matrix Market matrix\n";
        return 2;
    }
    if (spmv_budget > 0) return spmv(a, label, spmv_budget);
    Vec b;
    if (b_path.empty() || !Eigen::loadMarketVector(b, b_path) || b.size() != a.rows()) {
        std::cerr << "error: " << b_path << ": need a vector of " << a.rows() << " entries\n";
        return 2;
    }
    if (max_iter < 0) max_iter = 2 * a.rows();
    std::istringstream is(precond_list);
    std::string p;
    bool failed = false;
    while (std::getline(is, p, ',')) {
        Result r;
        if (p == "jacobi") r = run<Eigen::DiagonalPreconditioner<double>>(a, b, rtol, max_iter);
        else if (p == "ic") r = run<Eigen::IncompleteCholesky<double>>(a, b, rtol, max_iter);
        else if (p == "ic-natural")
            r = run<Eigen::IncompleteCholesky<double, Eigen::Lower, Eigen::NaturalOrdering<int>>>(
                a, b, rtol, max_iter);
        else if (p == "ssor") r = run<Ssor>(a, b, rtol, max_iter);
        else if (p == "none") r = run<Eigen::IdentityPreconditioner>(a, b, rtol, max_iter);
        else return usage();
        failed |= !r.ok;
        std::printf("{\"matrix\":\"%s\",\"tool\":\"eigen\",\"precond\":\"%s\",\"uplo\":\"%s\",\"rows\":%ld,"
                    "\"nnz\":%ld,\"iterations\":%ld,\"eigen_iterations\":%ld,\"setup_s\":%.6e,\"solve_s\":%.6e,\"rel_residual\":%.3e,"
                    "\"converged\":%s%s%s%s}\n",
                    label.c_str(), p.c_str(), full_products ? "full" : "lower", long(a.rows()),
                    long(a.nonZeros()), r.iterations, r.eigen_iterations, r.setup_s, r.solve_s, r.rel_residual, r.ok ? "true" : "false",
                    r.error.empty() ? "" : ",\"error\":\"", r.error.c_str(), r.error.empty() ? "" : "\"");
        std::fflush(stdout);
    }
    return failed ? 1 : 0;
}
