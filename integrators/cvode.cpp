// CVODE integrator (SUNDIALS 6.4) and the ODE system it integrates; equations, Jacobian and
// tolerances are documented in cvode.hpp.
#include "integrators/cvode.hpp"
#include "integrators/registry.hpp"

#include <cvode/cvode.h>
#include <cvode/cvode_ls.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunlinsol/sunlinsol_pcg.h>
#include <sunlinsol/sunlinsol_spgmr.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <limits>
#include <memory>
#include <optional>
#include <random>
#include <type_traits>

#include "lib/error.hpp"
#include "lib/potential.hpp"

namespace jamflow {

// ---------------------------------------------------------------------------------------
// Options

void CvodeOptions::validate() const {
  if (!(rtol > 0.0 && rtol < 1.0))
    throw ConfigError("[integrator] rtol = " + fmt(rtol) + " is out of range; allowed (0, 1)");
  if (atol && !(*atol > 0.0 && std::isfinite(*atol)))
    throw ConfigError("[integrator] atol = " + fmt(*atol) + " is out of range; allowed > 0");
  if (max_steps < 1)
    throw ConfigError("[integrator] max_steps = " + std::to_string(max_steps) +
                      " is out of range; allowed >= 1");
}

double cvode_default_atol(double pressure, double alpha) {
  // Overlap at which one contact carries a force of order P a^2: delta = (P/eps)^(1/(alpha-1)).
  double delta = 0.0;
  if (pressure > 0.0 && std::isfinite(pressure))
    delta = std::pow(pressure, 1.0 / (alpha - 1.0));
  if (!std::isfinite(delta))
    delta = 1.0;
  return 1e-3 * std::clamp(delta, 1e-9, 1.0);
}

// ---------------------------------------------------------------------------------------
// SUNDIALS adapter

namespace {

struct ContextFree {
  void operator()(SUNContext c) const { SUNContext_Free(&c); }
};
struct VectorFree {
  void operator()(N_Vector v) const { N_VDestroy(v); }
};
struct LinSolFree {
  void operator()(SUNLinearSolver s) const { SUNLinSolFree(s); }
};
struct CvodeFree {
  void operator()(void* m) const { CVodeFree(&m); }
};
using ContextPtr = std::unique_ptr<std::remove_pointer_t<SUNContext>, ContextFree>;
using VectorPtr = std::unique_ptr<std::remove_pointer_t<N_Vector>, VectorFree>;
using LinSolPtr = std::unique_ptr<std::remove_pointer_t<SUNLinearSolver>, LinSolFree>;
using CvodeMemPtr = std::unique_ptr<void, CvodeFree>;

double* data(N_Vector v) {
  return N_VGetArrayPointer(v);
}

// Vector kernels. Debian's SUNDIALS 6.4.1 is built without optimisation (its N_VDotProd_Serial
// runs at ~9 ns per element, measured), and CVODE spends most of its time in these kernels, so
// the serial vectors get Eigen implementations of every operation CVODE and the Krylov solvers
// use. Clones (all of CVODE's work vectors) copy the table. Semantics follow nvector_serial.
using Vec = Eigen::Map<Eigen::ArrayXd>;
Vec arr(N_Vector v) {
  return Vec(NV_DATA_S(v), static_cast<Eigen::Index>(NV_LENGTH_S(v)));
}

namespace kernel {
void linear_sum(sunrealtype a, N_Vector x, sunrealtype b, N_Vector y, N_Vector z) {
  arr(z) = a * arr(x) + b * arr(y);
}
void constant(sunrealtype c, N_Vector z) {
  arr(z).setConstant(c);
}
void prod(N_Vector x, N_Vector y, N_Vector z) {
  arr(z) = arr(x) * arr(y);
}
void div(N_Vector x, N_Vector y, N_Vector z) {
  arr(z) = arr(x) / arr(y);
}
void scale(sunrealtype c, N_Vector x, N_Vector z) {
  arr(z) = c * arr(x);
}
void abs(N_Vector x, N_Vector z) {
  arr(z) = arr(x).abs();
}
void inv(N_Vector x, N_Vector z) {
  arr(z) = arr(x).inverse();
}
void add_const(N_Vector x, sunrealtype b, N_Vector z) {
  arr(z) = arr(x) + b;
}
// Reductions as OpenMP SIMD loops (Eigen's AVX-512 reductions trip GCC 12's
// -Wmaybe-uninitialized inside its own intrinsics headers).
sunrealtype dot(N_Vector x, N_Vector y) {
  const double* a = NV_DATA_S(x);
  const double* b = NV_DATA_S(y);
  const sunindextype n = NV_LENGTH_S(x);
  double sum = 0.0;
#pragma omp simd reduction(+ : sum)
  for (sunindextype i = 0; i < n; ++i)
    sum += a[i] * b[i];
  return sum;
}
sunrealtype max_norm(N_Vector x) {
  const double* a = NV_DATA_S(x);
  const sunindextype n = NV_LENGTH_S(x);
  double m = 0.0;
#pragma omp simd reduction(max : m)
  for (sunindextype i = 0; i < n; ++i)
    m = std::max(m, std::abs(a[i]));
  return m;
}
sunrealtype wsqr_sum(N_Vector x, N_Vector w) {
  const double* a = NV_DATA_S(x);
  const double* b = NV_DATA_S(w);
  const sunindextype n = NV_LENGTH_S(x);
  double sum = 0.0;
#pragma omp simd reduction(+ : sum)
  for (sunindextype i = 0; i < n; ++i)
    sum += (a[i] * b[i]) * (a[i] * b[i]);
  return sum;
}
sunrealtype wsqr_sum_mask(N_Vector x, N_Vector w, N_Vector id) {
  const double* xd = NV_DATA_S(x);
  const double* wd = NV_DATA_S(w);
  const double* m = NV_DATA_S(id);
  double sum = 0.0;
  for (sunindextype i = 0; i < NV_LENGTH_S(x); ++i) {
    if (m[i] > 0.0)
      sum += (xd[i] * wd[i]) * (xd[i] * wd[i]);
  }
  return sum;
}
sunrealtype wrms_norm(N_Vector x, N_Vector w) {
  return std::sqrt(wsqr_sum(x, w) / double(NV_LENGTH_S(x)));
}
sunrealtype wrms_norm_mask(N_Vector x, N_Vector w, N_Vector id) {
  return std::sqrt(wsqr_sum_mask(x, w, id) / double(NV_LENGTH_S(x)));
}
sunrealtype min(N_Vector x) {
  const double* a = NV_DATA_S(x);
  const sunindextype n = NV_LENGTH_S(x);
  double m = std::numeric_limits<double>::max();
#pragma omp simd reduction(min : m)
  for (sunindextype i = 0; i < n; ++i)
    m = std::min(m, a[i]);
  return m;
}
sunrealtype wl2_norm(N_Vector x, N_Vector w) {
  return std::sqrt(wsqr_sum(x, w));
}
sunrealtype l1_norm(N_Vector x) {
  const double* a = NV_DATA_S(x);
  const sunindextype n = NV_LENGTH_S(x);
  double sum = 0.0;
#pragma omp simd reduction(+ : sum)
  for (sunindextype i = 0; i < n; ++i)
    sum += std::abs(a[i]);
  return sum;
}
void compare(sunrealtype c, N_Vector x, N_Vector z) {
  const double* xd = NV_DATA_S(x);
  double* zd = NV_DATA_S(z);
  for (sunindextype i = 0; i < NV_LENGTH_S(x); ++i)
    zd[i] = std::abs(xd[i]) >= c ? 1.0 : 0.0;
}
sunbooleantype inv_test(N_Vector x, N_Vector z) {
  // Like nvector_serial: z = 1/x where x != 0, false if any x is 0.
  const double* a = NV_DATA_S(x);
  double* b = NV_DATA_S(z);
  bool ok = true;
  for (sunindextype i = 0; i < NV_LENGTH_S(x); ++i) {
    if (a[i] == 0.0)
      ok = false;
    else
      b[i] = 1.0 / a[i];
  }
  return ok ? SUNTRUE : SUNFALSE;
}
sunrealtype min_quotient(N_Vector num, N_Vector denom) {
  const double* n = NV_DATA_S(num);
  const double* d = NV_DATA_S(denom);
  double q = std::numeric_limits<double>::max();
  for (sunindextype i = 0; i < NV_LENGTH_S(num); ++i) {
    if (d[i] != 0.0)
      q = std::min(q, n[i] / d[i]);
  }
  return q;
}
int linear_combination(int nv, sunrealtype* c, N_Vector* x, N_Vector z) {
  // z may alias x[0] (CVODE relies on it); another alias goes through a temporary.
  for (int i = 1; i < nv; ++i) {
    if (x[i] == z) {
      Eigen::ArrayXd acc = c[0] * arr(x[0]);
      for (int k = 1; k < nv; ++k)
        acc += c[k] * arr(x[k]);
      arr(z) = acc;
      return 0;
    }
  }
  Vec out = arr(z);
  if (x[0] != z) {
    out = c[0] * arr(x[0]);
  } else if (c[0] != 1.0) {
    out *= c[0];
  }
  for (int i = 1; i < nv; ++i)
    out += c[i] * arr(x[i]);
  return 0;
}
int scale_add_multi(int nv, sunrealtype* a, N_Vector x, N_Vector* y, N_Vector* z) {
  for (int i = 0; i < nv; ++i)
    arr(z[i]) = a[i] * arr(x) + arr(y[i]);
  return 0;
}
int dot_multi(int nv, N_Vector x, N_Vector* y, sunrealtype* d) {
  for (int i = 0; i < nv; ++i)
    d[i] = dot(x, y[i]);
  return 0;
}
}  // namespace kernel

void install_kernels(N_Vector v) {
  N_Vector_Ops o = v->ops;
  o->nvlinearsum = kernel::linear_sum;
  o->nvconst = kernel::constant;
  o->nvprod = kernel::prod;
  o->nvdiv = kernel::div;
  o->nvscale = kernel::scale;
  o->nvabs = kernel::abs;
  o->nvinv = kernel::inv;
  o->nvaddconst = kernel::add_const;
  o->nvdotprod = kernel::dot;
  o->nvmaxnorm = kernel::max_norm;
  o->nvwrmsnorm = kernel::wrms_norm;
  o->nvwrmsnormmask = kernel::wrms_norm_mask;
  o->nvmin = kernel::min;
  o->nvwl2norm = kernel::wl2_norm;
  o->nvl1norm = kernel::l1_norm;
  o->nvcompare = kernel::compare;
  o->nvinvtest = kernel::inv_test;
  o->nvminquotient = kernel::min_quotient;
  o->nvlinearcombination = kernel::linear_combination;
  o->nvscaleaddmulti = kernel::scale_add_multi;
  o->nvdotprodmulti = kernel::dot_multi;
  o->nvdotprodlocal = kernel::dot;
  o->nvmaxnormlocal = kernel::max_norm;
  o->nvminlocal = kernel::min;
  o->nvl1normlocal = kernel::l1_norm;
  o->nvinvtestlocal = kernel::inv_test;
  o->nvminquotientlocal = kernel::min_quotient;
  o->nvwsqrsumlocal = kernel::wsqr_sum;
  o->nvwsqrsummasklocal = kernel::wsqr_sum_mask;
}

}  // namespace

double cvode_kernel_discrepancy(std::size_t n, unsigned seed) {
  SUNContext raw = nullptr;
  if (SUNContext_Create(nullptr, &raw) != 0)
    throw IntegrationError("CVODE: SUNContext_Create failed");
  const ContextPtr ctx(raw);
  const auto len = static_cast<sunindextype>(n);
  // Index 0: nvector_serial's own kernels, 1: ours; six vectors each.
  std::array<std::array<VectorPtr, 6>, 2> v;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<double> init(6 * n);
  for (auto& x : init)
    x = u(rng);
  for (std::size_t k = 0; k < n; k += 7)
    init[n + k] = 0.0;  // zeros in the second vector (inv_test, min_quotient)
  for (int impl = 0; impl < 2; ++impl) {
    for (int j = 0; j < 6; ++j) {
      v[impl][j].reset(N_VNew_Serial(len, ctx.get()));
      if (impl == 1)
        install_kernels(v[impl][j].get());
      std::copy_n(&init[j * n], n, NV_DATA_S(v[impl][j].get()));
    }
  }
  double worst = 0.0;
  const auto rel = [&](double a, double b) {
    worst = std::max(worst, std::abs(a - b) / (1.0 + std::abs(a)));
  };
  const auto same = [&](int j) {
    for (std::size_t i = 0; i < n; ++i)
      rel(NV_DATA_S(v[0][j].get())[i], NV_DATA_S(v[1][j].get())[i]);
  };
  const auto run = [&](const auto& op) {
    for (int impl = 0; impl < 2; ++impl) {
      std::array<N_Vector, 6> w;
      for (int j = 0; j < 6; ++j)
        w[j] = v[impl][j].get();
      op(w.data(), impl);
    }
  };
  run([&](N_Vector* x, int) { N_VLinearSum(0.3, x[0], -1.7, x[1], x[5]); });
  same(5);
  run([&](N_Vector* x, int) { N_VLinearSum(0.3, x[0], -1.7, x[1], x[1]); });
  same(1);
  run([&](N_Vector* x, int) { N_VProd(x[0], x[2], x[5]); });
  same(5);
  run([&](N_Vector* x, int) { N_VDiv(x[0], x[2], x[5]); });
  same(5);
  run([&](N_Vector* x, int) { N_VScale(2.5, x[3], x[5]); });
  same(5);
  run([&](N_Vector* x, int) { N_VAbs(x[3], x[4]); });
  same(4);
  run([&](N_Vector* x, int) { N_VInv(x[2], x[5]); });
  same(5);
  run([&](N_Vector* x, int) { N_VAddConst(x[3], 0.25, x[5]); });
  same(5);
  run([&](N_Vector* x, int) { N_VCompare(0.5, x[3], x[5]); });
  same(5);
  run([&](N_Vector* x, int) {
    N_VConst(0.0, x[5]);
    N_VInvTest(x[1], x[5]);
  });
  same(5);
  const auto scalar = [&](const auto& f) {
    std::array<double, 2> r{};
    run([&](N_Vector* x, int i) { r[i] = f(x); });
    rel(r[0], r[1]);
  };
  scalar([](N_Vector* x) { return N_VDotProd(x[0], x[2]); });
  scalar([](N_Vector* x) { return N_VMaxNorm(x[0]); });
  scalar([](N_Vector* x) { return N_VWrmsNorm(x[0], x[2]); });
  scalar([](N_Vector* x) { return N_VWrmsNormMask(x[0], x[2], x[3]); });
  scalar([](N_Vector* x) { return N_VMin(x[0]); });
  scalar([](N_Vector* x) { return N_VWL2Norm(x[0], x[2]); });
  scalar([](N_Vector* x) { return N_VL1Norm(x[0]); });
  scalar([](N_Vector* x) { return N_VMinQuotient(x[0], x[1]); });
  scalar([](N_Vector* x) { return double(N_VInvTest(x[1], x[5])); });
  // Fused operations, with the one alias nvector_serial supports (z == x[0]).
  std::array<double, 3> c{0.5, -2.0, 3.0};
  run([&](N_Vector* x, int) { N_VLinearCombination(3, c.data(), x, x[5]); });
  same(5);
  run([&](N_Vector* x, int) { N_VLinearCombination(3, c.data(), x, x[0]); });
  same(0);
  run([&](N_Vector* x, int) {
    std::array<N_Vector, 2> ys{x[1], x[2]}, zs{x[4], x[2]};
    N_VScaleAddMulti(2, c.data(), x[3], ys.data(), zs.data());
  });
  same(4);
  same(2);
  std::array<std::array<double, 2>, 2> d{};
  run([&](N_Vector* x, int i) {
    std::array<N_Vector, 2> ys{x[1], x[2]};
    N_VDotProdMulti(2, x[3], ys.data(), d[i].data());
  });
  rel(d[0][0], d[1][0]);
  rel(d[0][1], d[1][1]);
  return worst;
}

namespace {

// Krylov subspace dimension (SUNDIALS' default is 5).
constexpr int kMaxKrylov = 10;

struct Counters {
  static constexpr int kCount = 11;
  std::array<long, kCount> v{};
  Counters& operator+=(const Counters& o) {
    for (int k = 0; k < kCount; ++k)
      v[k] += o.v[k];
    return *this;
  }
};
constexpr std::array<const char*, Counters::kCount> kCounterNames{"steps",
                                                                  "rhs_evaluations",
                                                                  "nonlinear_iterations",
                                                                  "linear_iterations",
                                                                  "jtimes_evaluations",
                                                                  "error_test_failures",
                                                                  "nonlinear_convergence_failures",
                                                                  "linear_convergence_failures",
                                                                  "preconditioner_setups",
                                                                  "preconditioner_solves",
                                                                  "jtimes_setups"};

}  // namespace

struct Cvode::Impl {
  explicit Impl(const CvodeOptions& o) : opt(o) {
    opt.validate();
    SUNContext c = nullptr;
    if (SUNContext_Create(nullptr, &c) != 0 || c == nullptr)
      throw IntegrationError("CVODE: SUNContext_Create failed");
    ctx.reset(c);
  }

  CvodeOptions opt;
  // Declaration order is destruction order reversed: the context goes last.
  ContextPtr ctx;
  VectorPtr y, abstol;
  LinSolPtr ls;
  CvodeMemPtr mem;
  std::size_t neq = 0;

  std::unique_ptr<EquationOfMotion> sys;
  const Model* model = nullptr;
  const Ensemble* ensemble = nullptr;
  bool need_init = true;

  // The state this integrator left in the Model at the end of the last advance().
  bool left_valid = false;
  std::vector<double> left_pos;
  Box left_box;
  double left_time = 0.0;

  Counters total, live;  // live: since the last (re)initialisation
  long reinits = 0;
  long recoverable_failures = 0;
  double atol_len = 0.0;

  std::exception_ptr pending;
  std::string last_message, last_recoverable;

  // A stretch that the interrupt flag stopped between two internal steps (see advance()).
  // CVODE's memory is still at that step; the Model and the system are kept as the step left
  // them, so that an advance() to the same t_end goes on as if the run had never stopped.
  struct Paused {
    double t_stop = 0.0;    // the stretch's end
    double t_step = 0.0;    // the time of the step
    long steps = 0;         // steps of the advance() so far
    long budget = 0;        // steps allowed in this stretch
    long taken = 0;         // steps taken in this stretch
    Model::Snapshot model;  // the Model before it was moved to the step's time
    std::unique_ptr<EquationOfMotion> sys;
  };
  std::optional<Paused> paused;
  // The t_end of the last advance() if the flag stopped it before t_end (else NaN): a call to
  // the same t_end from the state it left continues that advance().
  double stopped_end = std::numeric_limits<double>::quiet_NaN();

  // Runs a callback body: IntegrationError (a trial point outside the physical domain) is
  // recoverable, so CVODE retries with a smaller step; anything else (CellCollapse included)
  // is kept and rethrown after CVode returns.
  template <class F>
  int guard(F&& body) noexcept {
    if (pending)
      return -1;
    try {
      body();
      return 0;
    } catch (const CellCollapse&) {
      pending = std::current_exception();
      return -1;
    } catch (const IntegrationError& e) {
      return recoverable(e.what());
    } catch (...) {
      pending = std::current_exception();
      return -1;
    }
  }
  int recoverable(const char* what) noexcept {
    ++recoverable_failures;
    try {
      last_recoverable = what;
    } catch (...) {
    }
    return 1;
  }

  static int rhs_cb(sunrealtype t, N_Vector y, N_Vector ydot, void* self) {
    auto* im = static_cast<Impl*>(self);
    return im->guard([&] { im->sys->rhs(t, data(y), data(ydot)); });
  }
  static int jtsetup_cb(sunrealtype t, N_Vector y, N_Vector /*fy*/, void* self) {
    auto* im = static_cast<Impl*>(self);
    return im->guard([&] { im->sys->jacobian_setup(t, data(y)); });
  }
  static int jtimes_cb(N_Vector v, N_Vector jv, sunrealtype t, N_Vector y, N_Vector /*fy*/,
                       void* self, N_Vector /*tmp*/) {
    auto* im = static_cast<Impl*>(self);
    return im->guard([&] {
      if (!im->sys->jacobian_ready())
        im->sys->jacobian_setup(t, data(y));
      im->sys->jacobian_times(data(v), data(jv));
    });
  }
  static int psetup_cb(sunrealtype t, N_Vector y, N_Vector /*fy*/, sunbooleantype jok,
                       sunbooleantype* jcur, sunrealtype gamma, void* self) {
    auto* im = static_cast<Impl*>(self);
    return im->guard([&] {
      *jcur = SUNFALSE;
      if (!jok || !im->sys->jacobian_ready()) {
        im->sys->jacobian_setup(t, data(y));
        *jcur = SUNTRUE;
      }
      im->sys->preconditioner_setup(gamma);
    });
  }
  static int psolve_cb(sunrealtype /*t*/, N_Vector /*y*/, N_Vector /*fy*/, N_Vector r, N_Vector z,
                       sunrealtype /*gamma*/, sunrealtype /*delta*/, int /*lr*/, void* self) {
    auto* im = static_cast<Impl*>(self);
    return im->guard([&] { im->sys->preconditioner_solve(data(r), data(z)); });
  }
  static void error_cb(int code, const char* module, const char* function, char* msg, void* self) {
    auto* im = static_cast<Impl*>(self);
    if (code > 0)
      return;  // warnings (e.g. t + h == t) carry no decision
    try {
      im->last_message = std::string(module ? module : "?") + "/" + (function ? function : "?") +
                         ": " + (msg ? msg : "");
    } catch (...) {
    }
  }

  std::string flag_text(int flag, bool linear) const {
    char* name = linear ? CVodeGetLinReturnFlagName(flag) : CVodeGetReturnFlagName(flag);
    std::string s = name ? std::string(name) : std::to_string(flag);
    std::free(name);
    return s;
  }
  void check(int flag, const char* call, bool linear = false) const {
    if (flag >= 0)
      return;
    std::string text = std::string("CVODE: ") + call + " failed with " + flag_text(flag, linear);
    if (!last_message.empty())
      text += " (" + last_message + ")";
    throw IntegrationError(text);
  }

  void create(std::size_t size, double t0) {
    mem.reset();
    ls.reset();
    abstol.reset();
    y.reset();
    neq = 0;
    const auto len = static_cast<sunindextype>(size);
    y.reset(N_VNew_Serial(len, ctx.get()));
    abstol.reset(N_VNew_Serial(len, ctx.get()));
    if (!y || !abstol)
      throw IntegrationError("CVODE: N_VNew_Serial failed");
    install_kernels(y.get());  // before CVODE and the linear solver clone y
    install_kernels(abstol.get());
    N_VConst(0.0, y.get());
    mem.reset(CVodeCreate(opt.method == CvodeOptions::Method::kBdf ? CV_BDF : CV_ADAMS, ctx.get()));
    if (!mem)
      throw IntegrationError("CVODE: CVodeCreate failed");
    check(CVodeSetErrHandlerFn(mem.get(), error_cb, this), "CVodeSetErrHandlerFn");
    check(CVodeInit(mem.get(), rhs_cb, t0, y.get()), "CVodeInit");
    check(CVodeSetUserData(mem.get(), this), "CVodeSetUserData");
    const bool jacobi = opt.preconditioner == CvodeOptions::Preconditioner::kJacobi;
    const int pretype = jacobi ? SUN_PREC_LEFT : SUN_PREC_NONE;
    ls.reset(opt.linear_solver == CvodeOptions::LinearSolver::kSpgmr
                 ? SUNLinSol_SPGMR(y.get(), pretype, kMaxKrylov, ctx.get())
                 : SUNLinSol_PCG(y.get(), pretype, kMaxKrylov, ctx.get()));
    if (!ls)
      throw IntegrationError("CVODE: creating the Krylov linear solver failed");
    check(CVodeSetLinearSolver(mem.get(), ls.get(), nullptr), "CVodeSetLinearSolver", true);
    // jtsetup refreshes the Jacobian data at every Newton iterate (exact Newton): a Jacobian
    // lagged until the next preconditioner setup cost 53 convergence failures per 200 tau_0 at
    // rtol = atol = 1e-4 on N = 1000, phi = 0.62, and none when it is current.
    check(CVodeSetJacTimes(mem.get(), jtsetup_cb, jtimes_cb), "CVodeSetJacTimes", true);
    if (jacobi)
      check(CVodeSetPreconditioner(mem.get(), psetup_cb, psolve_cb), "CVodeSetPreconditioner",
            true);
    neq = size;
  }

  Counters read_counters() const {
    Counters c;
    void* m = mem.get();
    long nfe_ls = 0;
    check(CVodeGetNumSteps(m, &c.v[0]), "CVodeGetNumSteps");
    check(CVodeGetNumRhsEvals(m, &c.v[1]), "CVodeGetNumRhsEvals");
    check(CVodeGetNumLinRhsEvals(m, &nfe_ls), "CVodeGetNumLinRhsEvals", true);
    c.v[1] += nfe_ls;
    check(CVodeGetNumNonlinSolvIters(m, &c.v[2]), "CVodeGetNumNonlinSolvIters");
    check(CVodeGetNumLinIters(m, &c.v[3]), "CVodeGetNumLinIters", true);
    check(CVodeGetNumJtimesEvals(m, &c.v[4]), "CVodeGetNumJtimesEvals", true);
    check(CVodeGetNumErrTestFails(m, &c.v[5]), "CVodeGetNumErrTestFails");
    check(CVodeGetNumNonlinSolvConvFails(m, &c.v[6]), "CVodeGetNumNonlinSolvConvFails");
    check(CVodeGetNumLinConvFails(m, &c.v[7]), "CVodeGetNumLinConvFails", true);
    check(CVodeGetNumPrecEvals(m, &c.v[8]), "CVodeGetNumPrecEvals", true);
    check(CVodeGetNumPrecSolves(m, &c.v[9]), "CVodeGetNumPrecSolves", true);
    check(CVodeGetNumJTSetupEvals(m, &c.v[10]), "CVodeGetNumJTSetupEvals", true);
    return c;
  }

  double wanted_atol(Model& model, const Ensemble& ens) const {
    if (opt.atol)
      return *opt.atol;
    const std::optional<double> p = ens.imposed_pressure();
    return cvode_default_atol(p ? *p : model.evaluate().pressure, model.force_field().alpha());
  }

  // Fresh history from the Model's current state: y = 0.
  void initialise(Model& model, const Ensemble& ens) {
    if (mem)
      total += live;
    live = Counters{};
    sys = std::make_unique<EquationOfMotion>(model, ens,
                                             opt.linear_solver == CvodeOptions::LinearSolver::kPcg);
    const double t0 = model.state().time;
    if (!mem || neq != sys->size()) {
      create(sys->size(), t0);
    } else {
      N_VConst(0.0, y.get());
      check(CVodeReInit(mem.get(), t0, y.get()), "CVodeReInit");
    }
    atol_len = wanted_atol(model, ens);
    apply_tolerances(model);
    ++reinits;
    need_init = false;
  }

  void apply_tolerances(const Model& model) {
    const std::size_t n = model.state().size();
    const double l = std::cbrt(model.state().box.volume());
    double* a = data(abstol.get());
    std::fill(a, a + 3 * n, atol_len / l);
    if (sys->has_piston())
      a[3 * n] = 3.0 * atol_len;  // dV/V = 3 dl/l: a contact-length change of atol
    check(CVodeSVtolerances(mem.get(), opt.rtol, abstol.get()), "CVodeSVtolerances");
  }

  // Time at which |tilt| passes 1/2, so that prepare_step() remaps (just past it).
  double remap_time(double t_now) const {
    return sys->remap_time(t_now, model->state().box.volume());
  }

  bool state_is_ours(const Model& m) const {
    if (!left_valid || !sys || sys->size() != neq)
      return false;
    const State& st = m.state();
    const Box& b = st.box;
    return st.time == left_time && b.lx == left_box.lx && b.ly == left_box.ly &&
           b.lz == left_box.lz && b.strain == left_box.strain && b.flips == left_box.flips &&
           st.pos == left_pos;
  }

  void remember(const Model& m) {
    left_pos = m.state().pos;
    left_box = m.state().box;
    left_time = m.state().time;
    left_valid = true;
  }
};

Cvode::Cvode(const CvodeOptions& options) : impl_(std::make_unique<Impl>(options)) {}

Cvode::~Cvode() = default;

const CvodeOptions& Cvode::options() const {
  return impl_->opt;
}

void Cvode::reset() {
  impl_->need_init = true;
}

// Each stretch (up to t_end, or to the next Lees–Edwards remap) is taken one internal step at a
// time: CVode(..., CV_ONE_STEP) with the stretch's end as CVodeSetStopTime. That is the step
// sequence of one CV_NORMAL call to the same stop time (each step is limited so as not to pass
// it, and the last one ends on it and returns y there), so uninterrupted results keep their
// bits (compared on runs through remaps, with the piston, with PCG and with Adams). CVODE's
// own step limit counts per call, so max_steps is counted here.
// Between two steps the interrupt flag is polled: a stop then costs at most one internal step
// (milliseconds at N = 1000), not the rest of the stretch, which can take minutes with tight
// tolerances or large N. On a stop the Model is moved to the last step's time and y (CVODE's
// own solution there, with forces evaluated), as the fixed-step integrators leave it. The
// solver keeps its history: an advance() to the same t_end from that state first puts back the
// Model and the system as the last step left them (the move evaluated forces once more, which
// can renew the neighbour list and fold s_ref), then takes the next step, so the run goes on
// bit for bit as if never stopped (a stop between stretches continues likewise). A checkpoint
// of the stopped state resumes with a fresh history (has_solver_history()).
void Cvode::advance(Model& model, const Ensemble& ensemble, double t_end) {
  Impl& im = *impl_;
  const State& st = model.state();
  if (!(t_end > st.time))
    return;
  if (&model != im.model || &ensemble != im.ensemble) {
    im.model = &model;
    im.ensemble = &ensemble;
    im.need_init = true;
  }
  if (!im.state_is_ours(model))
    im.need_init = true;
  im.left_valid = false;
  // A continued advance() does what the stopped one had still to do, and nothing more: in
  // particular no second atol drift check, whose evaluation (after a remap, before the
  // re-initialisation) would otherwise change when the neighbour list is rebuilt.
  const bool continuing = !im.need_init && im.stopped_end == t_end;
  im.stopped_end = std::numeric_limits<double>::quiet_NaN();
  if (!continuing)
    im.paused.reset();

  // On failure: the Model is left at CVODE's last successful step (y holds it).
  const auto fail = [&](int flag, double t_ret) {
    im.need_init = true;
    im.paused.reset();
    try {
      im.sys->apply(t_ret, data(im.y.get()));
    } catch (...) {
    }
    if (im.pending) {
      std::exception_ptr e = im.pending;
      im.pending = nullptr;
      std::rethrow_exception(e);
    }
    std::string text = "CVODE failed at t = " + fmt(t_ret) + " with " + im.flag_text(flag, false);
    if (im.sys->has_piston())
      text += " (cell volume " + fmt(st.box.volume()) + ")";
    if (flag == CV_TOO_MUCH_WORK)
      text += ": more than [integrator] max_steps = " + std::to_string(im.opt.max_steps) +
              " steps in one advance";
    if (!im.last_message.empty())
      text += " (" + im.last_message + ")";
    if (!im.last_recoverable.empty())
      text += "; last recoverable error: " + im.last_recoverable;
    throw IntegrationError(text);
  };

  long steps = 0;
  bool first = !continuing;
  while (st.time < t_end && !interrupted()) {
    double t_stop = t_end;
    long budget = 0, taken = 0;
    double t_step = st.time;  // the last step's time (y holds the solution there)
    if (im.paused && !im.need_init) {
      Impl::Paused p = std::move(*im.paused);
      im.paused.reset();
      model.restore(p.model);
      im.sys = std::move(p.sys);
      t_stop = p.t_stop;
      t_step = p.t_step;
      steps = p.steps;
      budget = p.budget;
      taken = p.taken;
    } else {
      im.paused.reset();
      if (model.prepare_step())
        im.need_init = true;
      if (first) {
        // CVODE 6.4 accepts new tolerances only before the first step after (re)initialisation
        // (CVodeSVtolerances clears the error-weight data that CVode's initial setup restores),
        // so a default atol that drifted by more than 10x since then costs a re-initialisation.
        const double want = im.wanted_atol(model, ensemble);
        if (!(want <= 10.0 * im.atol_len && im.atol_len <= 10.0 * want))
          im.need_init = true;
        first = false;
      }
      if (im.need_init)
        im.initialise(model, ensemble);
      if (ensemble.shear_rate() != 0.0)
        t_stop = std::min(t_stop, im.remap_time(st.time));
      // CVODE refuses an interval at round-off level (CV_TOO_CLOSE); the state moves by |f| dt.
      if (t_stop - st.time <= 1e-13 * std::max(1.0, std::abs(st.time))) {
        im.sys->apply(t_stop, data(im.y.get()));
        continue;
      }
      im.check(CVodeSetStopTime(im.mem.get(), t_stop), "CVodeSetStopTime");
      budget = std::max(1L, im.opt.max_steps - steps);
    }
    // One internal step per call; the stretch ends with CV_TSTOP_RETURN at exactly t_stop.
    for (;;) {
      if (taken >= budget) {
        im.live = im.read_counters();
        im.last_message.clear();
        fail(CV_TOO_MUCH_WORK, t_step);
      }
      sunrealtype t_ret = t_step;
      im.last_message.clear();
      const int flag = CVode(im.mem.get(), t_stop, im.y.get(), &t_ret, CV_ONE_STEP);
      if (im.pending || flag < 0) {
        im.live = im.read_counters();
        fail(flag, t_ret);
      }
      ++taken;
      ++steps;
      t_step = t_ret;
      if (flag == CV_TSTOP_RETURN)
        break;
      if (interrupted()) {
        im.live = im.read_counters();
        Impl::Paused p;
        p.t_stop = t_stop;
        p.t_step = t_step;
        p.steps = steps;
        p.budget = budget;
        p.taken = taken;
        p.model = model.snapshot();
        p.sys = std::make_unique<EquationOfMotion>(*im.sys);
        im.sys->apply(t_ret, data(im.y.get()));
        im.paused = std::move(p);
        im.stopped_end = t_end;
        im.remember(model);
        return;
      }
    }
    im.live = im.read_counters();
    // The Model ends exactly at t_stop with forces evaluated at the final y.
    im.sys->apply(t_stop, data(im.y.get()));
  }
  if (st.time < t_end)
    im.stopped_end = t_end;
  im.remember(model);
}

double Cvode::force_passes_per_time(const Ensemble& /*ensemble*/) const {
  return std::numeric_limits<double>::quiet_NaN();
}

// Costs against one force pass (a right-hand side: 24-30 us), measured with
// benchmarks/bench_cvode_parts on N = 1000, phi = 0.62, alpha_r = 2, gdot = 1e-3, one thread,
// CPU time of the thread, median of 9 rounds of 300 calls, constant volume / constant pressure:
//   Jacobian setup (the contact data, at the point of the last right-hand side)  2.7 / 3.4
//   Jacobian-vector product                                                      0.39-0.45 / 0.55
//   preconditioner setup (the 3 x 3 block inverses)                              0.61-0.67 / 0.58
//   preconditioner solve                                                         0.06-0.07 / 0.05-0.08
// A Jv product is about half a force pass, so it counts 0.5, not 1. The Jacobian setup is
// counted per CVODE jtsetup call: one that finds the data current (the preconditioner setup at
// the same point computed them) costs nothing but counts its 3, while the preconditioner
// setup's own contact collection is not counted; the two balance roughly. The Krylov solver's
// own vector operations are not counted.
namespace {
constexpr double kJacobianSetupCost = 3.0;
constexpr double kJtimesCost = 0.5;
constexpr double kPreconditionerSetupCost = 0.6;
constexpr double kPreconditionerSolveCost = 0.07;
}  // namespace

double Cvode::force_pass_equivalents(const Model& model) const {
  const Impl& im = *impl_;
  Counters all = im.total;
  all += im.live;
  // The counters' order is kCounterNames'. A Jacobian setup at the point of the last
  // right-hand side (the usual case) only collects the contacts; one elsewhere also evaluates
  // forces, which the model counts.
  return double(model.force_evaluations()) + kJtimesCost * double(all.v[4]) +
         kPreconditionerSetupCost * double(all.v[8]) + kPreconditionerSolveCost * double(all.v[9]) +
         kJacobianSetupCost * double(all.v[10]);
}

std::vector<std::pair<std::string, double>> Cvode::statistics() const {
  const Impl& im = *impl_;
  Counters all = im.total;
  all += im.live;
  std::vector<std::pair<std::string, double>> out;
  for (int k = 0; k < Counters::kCount; ++k)
    out.emplace_back(kCounterNames[k], double(all.v[k]));
  out.emplace_back("rhs_recoverable_failures", double(im.recoverable_failures));
  out.emplace_back("reinits", double(im.reinits));
  out.emplace_back("atol", im.atol_len);
  return out;
}

void Cvode::restore_statistics(const std::vector<std::pair<std::string, double>>& stats) {
  Impl& im = *impl_;
  Counters saved;
  for (int k = 0; k < Counters::kCount; ++k)
    saved.v[k] = static_cast<long>(statistic(stats, kCounterNames[k]));
  im.total += saved;
  im.recoverable_failures += static_cast<long>(statistic(stats, "rhs_recoverable_failures"));
  im.reinits += static_cast<long>(statistic(stats, "reinits"));
}

std::unique_ptr<Integrator> make_cvode(ConfigSection& section) {
  CvodeOptions o;
  o.rtol = section.number("rtol", o.rtol, Range{0.0, 1.0, true, true});
  if (section.has("atol"))
    o.atol = section.number("atol", Range::positive());
  o.method = section.choice("method", "bdf", {"bdf", "adams"}) == "bdf"
                 ? CvodeOptions::Method::kBdf
                 : CvodeOptions::Method::kAdams;
  o.linear_solver = section.choice("linear_solver", "spgmr", {"spgmr", "pcg"}) == "spgmr"
                        ? CvodeOptions::LinearSolver::kSpgmr
                        : CvodeOptions::LinearSolver::kPcg;
  o.preconditioner = section.choice("preconditioner", "jacobi", {"jacobi", "none"}) == "jacobi"
                         ? CvodeOptions::Preconditioner::kJacobi
                         : CvodeOptions::Preconditioner::kNone;
  o.max_steps = static_cast<long>(
      section.integer("max_steps", o.max_steps, 1, std::numeric_limits<std::int32_t>::max()));
  return std::make_unique<Cvode>(o);
}

namespace {
const IntegratorRegistrar registrar{"cvode", make_cvode,
                                    "SUNDIALS CVODE BDF/Adams, adaptive (rtol, atol, method, ...)"};
}  // namespace

}  // namespace jamflow
