// CVODE integrator (SUNDIALS 6.4) and the ODE system it integrates; equations, Jacobian and
// tolerances are documented in cvode.hpp.
#include "integrators/cvode.hpp"
#include "integrators/cvode_vectors.hpp"
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
  return 1e-3 * typical_overlap(pressure, alpha);
}

// ---------------------------------------------------------------------------------------
// SUNDIALS adapter (handles and vector kernels: cvode_vectors.hpp)

using namespace cvode_detail;

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

// CPU time per tau_0 at N = 1000, alpha_r = 2, constant pressure, one thread: 53-55 us at
// rtol 1e-4 for P = 1e-5 and J = 0.1 to 1e-3 (benchmarks/README.md, "Time to science"); in the
// timestep study's standard runs 57 (P = 1e-5, J = 0.3) and 316 us (P = 1e-3, J = 0.1) at
// rtol 1e-4, 2x more at J = 1, and 1.9-4.4x more at rtol 1e-6: about
// P^0.35 rtol^-0.2 max(1, J / 0.1)^0.3, within a factor of 2 of every one of those runs.
// Below alpha_r = 2 a contact's stiffness, (alpha_r - 1) delta^(alpha_r - 2), grows without
// bound as the overlap delta shrinks, and CVODE's cost with it: the softness study's standard
// comparisons (N = 250, studies/softness/results/standard/alpha=*/table.csv, cpu_per_particle_tau)
// cost 88-95x the harmonic model at alpha_r = 1.5, delta = 1e-4 (stiffness factor
// delta^(alpha_r - 2) = 100), 14-22x at delta = 0.03 (5.8), 5.9-6.8x at alpha_r = 1.75, delta =
// 1e-4 (10) and 4.7-6.4x at delta = 0.03 (2.4); the stability study's alpha_r = 1.5 case (N =
// 500, P = 1e-3: delta = 1e-6, factor 1000) 2.1-3.6e3x. The factor itself is within 0.6-3.8x of
// all of them, so it multiplies the model, up to the largest measured (1e3): stiffer contacts
// (alpha_r = 1.2 at P = 1e-3 has delta = 1e-15) are not extrapolated, since such runs stop by
// their budget ([run] max_force_evaluations) or fail. Above alpha_r = 2 (softer contacts) the
// harmonic model is kept, an overestimate by up to 4x at alpha_r = 2.5 and 3 in those runs.
double Cvode::cpu_seconds_per_particle_time(const Ensemble& /*ensemble*/,
                                            const CostPoint& at) const {
  const double p = std::clamp(at.pressure, 1e-7, 1e-1);
  const double j = std::max(1.0, at.viscous_number() / 0.1);
  const double stiffness = contact_stiffness_factor(p, at.alpha);
  return 54e-9 * std::pow(p / 1e-5, 0.35) * std::pow(options().rtol / 1e-4, -0.2) *
         std::pow(j, 0.3) * stiffness;
}

// Costs against one force pass (a right-hand side: 24-30 us), measured with
// benchmarks/bench_cvode_parts on N = 1000, phi = 0.62, alpha_r = 2, gdot = 1e-3, one thread,
// CPU time of the thread, median of 9 rounds of 300 calls, constant volume / constant pressure:
//   Jacobian setup (the contact data, at the point of the last right-hand side)  2.7 / 3.4
//   Jacobian-vector product                                                      0.39-0.45 / 0.55
//   preconditioner setup (the 3 x 3 block inverses)                              0.61-0.67 / 0.58
//   preconditioner solve                                                         0.06-0.07 /
//   0.05-0.08
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
