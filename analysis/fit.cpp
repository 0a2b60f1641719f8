// Weighted nonlinear least squares with GSL (see fit.hpp).
#include "analysis/fit.hpp"

#include <gsl/gsl_blas.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_linalg.h>
#include <gsl/gsl_matrix.h>
#include <gsl/gsl_multifit_nlinear.h>
#include <gsl/gsl_vector.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <memory>
#include <stdexcept>

#include "analysis/errors.hpp"
#include "analysis/format.hpp"

namespace jamflow::analysis {

std::size_t FitResult::index(const std::string& name) const {
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i] == name)
      return i;
  }
  throw std::out_of_range("fit has no parameter '" + name + "'");
}

Measured FitResult::operator[](const std::string& name) const {
  return at(index(name));
}

Measured FitResult::at(std::size_t i) const {
  return {params[i], std::sqrt(cov(i, i))};
}

namespace {

struct GslVectorDeleter {
  void operator()(gsl_vector* v) const { gsl_vector_free(v); }
};
struct GslMatrixDeleter {
  void operator()(gsl_matrix* m) const { gsl_matrix_free(m); }
};
struct GslWorkspaceDeleter {
  void operator()(gsl_multifit_nlinear_workspace* w) const { gsl_multifit_nlinear_free(w); }
};
using VectorPtr = std::unique_ptr<gsl_vector, GslVectorDeleter>;
using MatrixPtr = std::unique_ptr<gsl_matrix, GslMatrixDeleter>;

// GSL's default handler aborts the process; we check every return code.
void disable_gsl_abort() {
  static const bool done = [] {
    gsl_set_error_handler_off();
    return true;
  }();
  (void)done;
}

// Whitening transform of the residuals: r = L^-1 (f - y).
class Whitener {
 public:
  Whitener(const FitData& data, const std::string& label) : n_(data.size()) {
    if (!data.covariance.empty()) {
      if (data.covariance.size() != n_ * n_) {
        throw std::invalid_argument(label + ": data covariance has the wrong size");
      }
      chol_.reset(gsl_matrix_alloc(n_, n_));
      for (std::size_t i = 0; i < n_; ++i) {
        for (std::size_t j = 0; j < n_; ++j) {
          gsl_matrix_set(chol_.get(), i, j, data.covariance[i * n_ + j]);
        }
      }
      if (gsl_linalg_cholesky_decomp1(chol_.get()) != GSL_SUCCESS) {
        throw FitError(label + ": the data covariance matrix is not positive definite");
      }
    } else {
      if (data.sigma.size() != n_) {
        throw std::invalid_argument(label + ": need one error per data point");
      }
      inv_sigma_.resize(n_);
      for (std::size_t i = 0; i < n_; ++i)
        inv_sigma_[i] = 1.0 / data.sigma[i];
    }
  }

  // In-place v <- L^-1 v.
  void apply(std::span<double> v) const {
    if (!chol_) {
      for (std::size_t i = 0; i < n_; ++i)
        v[i] *= inv_sigma_[i];
      return;
    }
    gsl_vector_view view = gsl_vector_view_array(v.data(), n_);
    gsl_blas_dtrsv(CblasLower, CblasNoTrans, CblasNonUnit, chol_.get(), &view.vector);
  }

 private:
  std::size_t n_;
  std::vector<double> inv_sigma_;
  MatrixPtr chol_;
};

struct CallbackContext {
  const FitData* data;
  const ModelFunction* model;
  const Whitener* whitener;
  std::size_t p;
  std::exception_ptr error;
};

int residual_callback(const gsl_vector* x, void* params, gsl_vector* f) {
  auto* ctx = static_cast<CallbackContext*>(params);
  try {
    const std::size_t n = ctx->data->size();
    std::vector<double> p(x->data, x->data + ctx->p);
    std::vector<double> r(n);
    for (std::size_t i = 0; i < n; ++i) {
      r[i] = (*ctx->model)(ctx->data->x[i], p, {}) - ctx->data->y[i];
    }
    ctx->whitener->apply(r);
    for (std::size_t i = 0; i < n; ++i) {
      // A trial step into a region where the model overflows must be rejected
      // by the trust region, not abort the fit: make it very costly instead.
      gsl_vector_set(f, i, std::isfinite(r[i]) ? r[i] : 1e100);
    }
    return GSL_SUCCESS;
  } catch (...) {
    // Never throw through GSL's C frames: keep it and rethrow after the driver.
    ctx->error = std::current_exception();
    return GSL_EBADFUNC;
  }
}

int jacobian_callback(const gsl_vector* x, void* params, gsl_matrix* jac) {
  auto* ctx = static_cast<CallbackContext*>(params);
  try {
    const std::size_t n = ctx->data->size();
    const std::size_t np = ctx->p;
    std::vector<double> p(x->data, x->data + np);
    std::vector<double> grad(np);
    std::vector<double> columns(np * n);
    for (std::size_t i = 0; i < n; ++i) {
      (*ctx->model)(ctx->data->x[i], p, grad);
      for (std::size_t k = 0; k < np; ++k)
        columns[k * n + i] = grad[k];
    }
    for (std::size_t k = 0; k < np; ++k) {
      std::span<double> col(columns.data() + k * n, n);
      ctx->whitener->apply(col);
      for (std::size_t i = 0; i < n; ++i) {
        if (!std::isfinite(col[i]))
          return GSL_EBADFUNC;
        gsl_matrix_set(jac, i, k, col[i]);
      }
    }
    return GSL_SUCCESS;
  } catch (...) {
    ctx->error = std::current_exception();
    return GSL_EBADFUNC;
  }
}

void check_data(const FitData& data, std::size_t np, const std::string& label) {
  const std::size_t n = data.size();
  if (data.y.size() != n)
    throw std::invalid_argument(label + ": x and y differ in length");
  if (n < np + 1) {
    throw InsufficientDataError(label + ": needs at least " + std::to_string(np + 1) +
                                " points for " + std::to_string(np) + " parameters, got " +
                                std::to_string(n));
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(data.x[i]) || !std::isfinite(data.y[i])) {
      throw FitError(label + ": non-finite data at point " + std::to_string(i) +
                     " (x = " + fmt(data.x[i]) + ", y = " + fmt(data.y[i]) + ")");
    }
    if (data.covariance.empty() && !(data.sigma[i] > 0.0 && std::isfinite(data.sigma[i]))) {
      throw FitError(label + ": error of point " + std::to_string(i) + " is " + fmt(data.sigma[i]) +
                     " (must be finite and > 0)");
    }
  }
}

}  // namespace

FitResult fit_least_squares(const FitData& data, const ModelFunction& model,
                            std::vector<double> start, std::vector<std::string> names,
                            const FitOptions& options) {
  disable_gsl_abort();
  const std::size_t np = start.size();
  const std::size_t n = data.size();
  const std::string& label = options.label;
  if (names.size() != np)
    throw std::invalid_argument(label + ": one name per parameter");
  if (data.covariance.empty() && data.sigma.size() != n) {
    throw std::invalid_argument(label + ": need one error per data point");
  }
  check_data(data, np, label);
  for (std::size_t k = 0; k < np; ++k) {
    if (!std::isfinite(start[k])) {
      throw FitError(label + ": non-finite starting value for " + names[k]);
    }
  }
  Whitener whitener(data, label);
  CallbackContext ctx{&data, &model, &whitener, np, nullptr};

  gsl_multifit_nlinear_fdf fdf;
  fdf.f = residual_callback;
  fdf.df = jacobian_callback;
  fdf.fvv = nullptr;
  fdf.n = n;
  fdf.p = np;
  fdf.params = &ctx;

  gsl_multifit_nlinear_parameters params = gsl_multifit_nlinear_default_parameters();
  params.trs = gsl_multifit_nlinear_trs_lm;
  std::unique_ptr<gsl_multifit_nlinear_workspace, GslWorkspaceDeleter> work(
      gsl_multifit_nlinear_alloc(gsl_multifit_nlinear_trust, &params, n, np));
  gsl_vector_view x0 = gsl_vector_view_array(start.data(), np);
  int status = gsl_multifit_nlinear_init(&x0.vector, &fdf, work.get());
  if (ctx.error)
    std::rethrow_exception(ctx.error);
  if (status != GSL_SUCCESS) {
    throw FitError(label + ": model cannot be evaluated at the starting point (" +
                   gsl_strerror(status) + ")");
  }
  int info = 0;
  const double xtol = 1e-10, gtol = 1e-10, ftol = 0.0;
  status = gsl_multifit_nlinear_driver(static_cast<std::size_t>(options.max_iterations), xtol, gtol,
                                       ftol, nullptr, nullptr, &info, work.get());
  if (ctx.error)
    std::rethrow_exception(ctx.error);

  gsl_vector* pos = gsl_multifit_nlinear_position(work.get());
  gsl_vector* res = gsl_multifit_nlinear_residual(work.get());
  gsl_matrix* jac = gsl_multifit_nlinear_jac(work.get());
  double chi2 = 0.0;
  gsl_blas_ddot(res, res, &chi2);

  if (status == GSL_ENOPROG) {
    // No further reduction possible: accept only if we sit at a stationary
    // point (small scaled gradient J^T r), i.e. at the minimum to precision.
    VectorPtr g(gsl_vector_alloc(np));
    gsl_blas_dgemv(CblasTrans, 1.0, jac, res, 0.0, g.get());
    double worst = 0.0;
    for (std::size_t k = 0; k < np; ++k) {
      double colnorm = 0.0;
      for (std::size_t i = 0; i < n; ++i)
        colnorm += std::pow(gsl_matrix_get(jac, i, k), 2);
      double scale = std::sqrt(colnorm) * std::sqrt(std::max(chi2, 1e-300));
      if (scale > 0)
        worst = std::max(worst, std::fabs(gsl_vector_get(g.get(), k)) / scale);
    }
    if (worst < 1e-6)
      status = GSL_SUCCESS;
  }
  if (status != GSL_SUCCESS) {
    throw FitError(label + ": did not converge after " +
                   std::to_string(gsl_multifit_nlinear_niter(work.get())) +
                   " iterations (GSL: " + gsl_strerror(status) + ")");
  }

  FitResult result;
  result.names = std::move(names);
  result.params.assign(pos->data, pos->data + np);
  result.chi2 = chi2;
  result.dof = static_cast<int>(n) - static_cast<int>(np);
  result.iterations = static_cast<int>(gsl_multifit_nlinear_niter(work.get()));
  for (std::size_t k = 0; k < np; ++k) {
    if (!std::isfinite(result.params[k])) {
      throw FitError(label + ": parameter " + result.names[k] + " is not finite after the fit");
    }
  }
  if (!std::isfinite(chi2) || chi2 >= 1e100) {
    throw FitError(label + ": the model cannot be evaluated at the fitted parameters");
  }

  MatrixPtr covar(gsl_matrix_alloc(np, np));
  // epsrel: columns of J that are numerically dependent are reported by GSL
  // as zero variance; we turn that into an error below, never a 0 error bar.
  gsl_multifit_nlinear_covar(jac, 1e-13, covar.get());
  double scale = 1.0;
  // Only upwards: chi2/dof < 1 is as likely from overestimated data errors as from luck, and
  // shrinking the errors on it would claim a precision the data do not show.
  if (options.scale_errors_by_chi2 && result.dof > 0 && chi2 / result.dof > 1.0) {
    scale = chi2 / result.dof;
    result.errors_scaled = true;
  }
  result.covariance.resize(np * np);
  for (std::size_t i = 0; i < np; ++i) {
    for (std::size_t j = 0; j < np; ++j) {
      result.covariance[i * np + j] = gsl_matrix_get(covar.get(), i, j) * scale;
    }
  }
  for (std::size_t k = 0; k < np; ++k) {
    double v = result.cov(k, k);
    if (!(v > 0.0) || !std::isfinite(v)) {
      throw FitError(label + ": parameter " + result.names[k] +
                     " is not constrained by the data (singular Jacobian)");
    }
  }
  return result;
}

double power_law_offset_value(const PowerLawForm& form, double x, double a, double c, double b) {
  return a + form.sign * c * std::pow(x, form.exponent_sign * b);
}

FitResult fit_power_law_offset(const FitData& data, const PowerLawForm& form,
                               const FitOptions& options) {
  const std::size_t n = data.size();
  check_data(data, 3, options.label);
  for (std::size_t i = 0; i < n; ++i) {
    if (!(data.x[i] > 0.0)) {
      throw FitError(options.label + ": power law needs x > 0, got x = " + fmt(data.x[i]) +
                     " at point " + std::to_string(i));
    }
  }
  Whitener whitener(data, options.label);
  std::vector<double> wy(data.y);
  whitener.apply(wy);
  std::vector<double> wone(n, 1.0);
  whitener.apply(wone);

  // Profile chi2(b): for fixed b, a and c solve a 2x2 linear least-squares
  // problem in the whitened variables.
  auto profile = [&](double b, double& a, double& c) {
    std::vector<double> wx(n);
    for (std::size_t i = 0; i < n; ++i) {
      wx[i] = form.sign * std::pow(data.x[i], form.exponent_sign * b);
    }
    whitener.apply(wx);
    double s11 = 0, s12 = 0, s22 = 0, t1 = 0, t2 = 0;
    for (std::size_t i = 0; i < n; ++i) {
      s11 += wone[i] * wone[i];
      s12 += wone[i] * wx[i];
      s22 += wx[i] * wx[i];
      t1 += wone[i] * wy[i];
      t2 += wx[i] * wy[i];
    }
    double det = s11 * s22 - s12 * s12;
    if (!(std::fabs(det) > 1e-300 * std::max(1.0, s11 * s22)) || !std::isfinite(det)) {
      return std::numeric_limits<double>::infinity();
    }
    a = (s22 * t1 - s12 * t2) / det;
    c = (s11 * t2 - s12 * t1) / det;
    double chi2 = 0.0;
    for (std::size_t i = 0; i < n; ++i)
      chi2 += std::pow(wy[i] - a * wone[i] - c * wx[i], 2);
    return std::isfinite(chi2) ? chi2 : std::numeric_limits<double>::infinity();
  };

  const int grid = 240;
  double best_chi2 = std::numeric_limits<double>::infinity();
  double best_a = 0, best_c = 0, best_b = 0;
  for (int k = 0; k <= grid; ++k) {
    double b = form.b_min + (form.b_max - form.b_min) * k / grid;
    double a = 0, c = 0;
    double chi2 = profile(b, a, c);
    if (chi2 < best_chi2) {
      best_chi2 = chi2;
      best_a = a;
      best_b = b;
      best_c = c;
    }
  }
  if (!std::isfinite(best_chi2)) {
    throw FitError(options.label + ": no starting point: the profile chi2 is not finite for " +
                   form.b_name + " in [" + fmt(form.b_min) + ", " + fmt(form.b_max) + "]");
  }
  ModelFunction model = [form](double x, std::span<const double> p, std::span<double> grad) {
    const double e = form.exponent_sign * p[2];
    const double xp = std::pow(x, e);
    if (!grad.empty()) {
      grad[0] = 1.0;
      grad[1] = form.sign * xp;
      grad[2] = form.sign * p[1] * xp * std::log(x) * form.exponent_sign;
    }
    return p[0] + form.sign * p[1] * xp;
  };
  return fit_least_squares(data, model, {best_a, best_c, best_b},
                           {form.a_name, form.c_name, form.b_name}, options);
}

Measured propagate(const std::function<double(std::span<const double>)>& g,
                   std::span<const double> p, std::span<const double> cov,
                   const std::string& what) {
  const std::size_t np = p.size();
  if (cov.size() != np * np)
    throw std::invalid_argument("propagate: covariance size");
  const double value = g(p);
  if (!std::isfinite(value)) {
    throw FitError(what + " is not finite at the fitted parameters (" + fmt(value) + ")");
  }
  std::vector<double> grad(np, 0.0);
  std::vector<double> q(p.begin(), p.end());
  for (std::size_t k = 0; k < np; ++k) {
    const double sd = std::sqrt(std::max(cov[k * np + k], 0.0));
    if (sd == 0.0)
      continue;  // an exactly known input contributes nothing
    const double h = 1e-4 * sd;
    q[k] = p[k] + h;
    const double up = g(q);
    q[k] = p[k] - h;
    const double down = g(q);
    q[k] = p[k];
    grad[k] = (up - down) / (2.0 * h);
    if (!std::isfinite(grad[k])) {
      throw FitError(what +
                     ": derivative is not finite (the parameters sit at the edge of the "
                     "formula's domain)");
    }
  }
  double var = 0.0;
  for (std::size_t i = 0; i < np; ++i) {
    for (std::size_t j = 0; j < np; ++j)
      var += grad[i] * cov[i * np + j] * grad[j];
  }
  if (!(var >= 0.0) || !std::isfinite(var)) {
    throw FitError(what + ": propagated variance is not finite or negative");
  }
  return {value, std::sqrt(var)};
}

std::vector<double> block_diagonal(const std::vector<std::vector<double>>& blocks,
                                   const std::vector<std::size_t>& sizes) {
  std::size_t total = 0;
  for (auto s : sizes)
    total += s;
  std::vector<double> out(total * total, 0.0);
  std::size_t offset = 0;
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    const std::size_t m = sizes[b];
    if (blocks[b].size() != m * m)
      throw std::invalid_argument("block_diagonal: block size");
    for (std::size_t i = 0; i < m; ++i) {
      for (std::size_t j = 0; j < m; ++j) {
        out[(offset + i) * total + offset + j] = blocks[b][i * m + j];
      }
    }
    offset += m;
  }
  return out;
}

}  // namespace jamflow::analysis
